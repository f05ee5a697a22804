"""Scenes: a TOML description of a contact problem as pure data, parsed with :mod:`tomllib` (never ``eval``).

One small validated dataclass per TOML section; :func:`fenics_coulomb.scenes.builder.build_problem` turns a scene
into forms, boundary conditions and a :class:`~fenics_coulomb.ContactProblem`. Precedence: built-in defaults
< scene file < command-line flags. Example (``demos/scenes/d3_L2.toml``)::

    [body]
    shape = "cuboid"        # or "mesh" with mesh = "meshes/roller.msh" and a [boundaries] table
    lev = 4
    gap = "d3"              # d1, d2, d3 or an expression in x1, x2, e.g. "0.01 + 0.005*sin(2*pi*x1)"
    clamped = ["left"]
    contact = ["bottom"]

    [material]
    young = 70.0            # GPa
    poisson = 0.334

    [friction]
    coefficient = 0.23

    [load]
    case = "L2"             # the paper's tractions, or a [tractions] table: top = [0, 0, -1] ...
    scale = 1.0

    [[obstacle]]            # rigid obstacles (fenics_coulomb.model.obstacles); none: the plane x3 = 0
    type = "sphere"         # plane (point, normal) | sphere (center, radius) | cylinder (point, axis, radius)
    center = [1.0, 0.5, -0.5]
    radius = 0.5
    displacement = [0.0, 0.0, 0.01]   # rigid translation δ (an indentation may overlap the body)

    [solver]                # the fields of fenics_coulomb.settings.SolverSettings, and start
    variant = "4a"
    tol = 0.1
    rtol = 1e-12            # the paper's reduction (default 1e-8)
    pc = "auto"             # ilu on hexahedra below 50 000 unknowns on <= 2 ranks, gamg otherwise
    start = "auto"          # auto (default) | zero (the paper's) | undeformed | an earlier run's solution.xdmf

    Two elastic bodies (fenics_coulomb.model.pairs.two_body; a gmsh mesh with one volume group per body) replace
    ``contact`` and ``[[obstacle]]`` by contact pairs, with materials per body:

    [bodies]                # volume physical groups: name = cell tag
    block = 1
    ball = 2
    [material.ball]         # overrides [material] on that body
    young = 200.0
    poisson = 0.3
    [[contact_pair]]        # slave and master: boundary names (lists allowed); friction: default [friction]
    slave = "curved"
    master = "block_top"
    friction = 0.0          # optional: search_distance (default 0.1 × the master's bounding-box diagonal), name,
    method = "mortar"       #   method: "mortar" (dual mortar, default) or "node-to-surface";
                            #   the smaller surface is the slave

    [[path.step]]           # optional: a quasi-static load path (fenics_coulomb.scenes.path), one table per step;
    substeps = 3            # what a step does not set is the scene's value (per boundary, per obstacle)
    [[path.step]]
    tractions = { right = [0.17, 0.1, 0.0] }   # also prescribed = {...}, move = { name = δ }, body_force

Size: about 740 lines: one validated dataclass per TOML section and the scene's cross-section checks; every
message names its key, which keeps the checks beside the fields they check.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from fenics_coulomb.errors import InputError
from fenics_coulomb.model import surface as _surface  # noqa: F401  (its register_obstacle call: type = "surface")
from fenics_coulomb.model.arguments import SLIDING, validate_friction
from fenics_coulomb.model.pairs.registry import check_method
from fenics_coulomb.model.materials import Material
from fenics_coulomb.model.obstacles import Obstacle, _rotation, obstacles_from_list
from fenics_coulomb.scd.preconditioner import NEARLY_INCOMPRESSIBLE_POISSON
from fenics_coulomb.scenes.cuboid import FACE_NAMES, GAP_PROFILES, LOAD_CASES, GapFunction, paper_tractions
from fenics_coulomb.scenes.expression import parse_gap_expression, parse_point_expression
from fenics_coulomb.settings import GAMMA_SCALE_RANGE, START_RULES, SolverSettings, setting_kinds

__all__ = ["KINDS", "NEARLY_INCOMPRESSIBLE_RTOL", "MAX_SCENE_BYTES", "YOUNG_RANGE", "GAMMA_SCALE_RANGE", "MAX_LOAD",
           "MAX_LEV", "check_kind", "OPTIONAL", "check_kinds", "read_scene_text", "check_gap_values", "BodySection",
           "MaterialSection", "FrictionSection", "ContactSection", "LoadSection", "MAX_PATH_SOLVES", "PathStep",
           "check_table", "path_steps_from_toml", "PairSection", "pairs_from_toml", "FLAGS", "SECTIONS", "Scene"]


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{name} = {value!r}: must be a finite number")
    return float(value)


def _vector(name: str, value: Any) -> list[float]:
    if not isinstance(value, list | tuple) or len(value) != 3:
        raise InputError(f"{name} = {value!r}: must be 3 numbers")
    return [_number(name, c) for c in value]


#: The type of every key of every section: "str", "int", "number" (int or float), "bool", "names" (a list of
#: strings), "vector" (a list of 3 numbers). The free tables [boundaries] (name = integer tag) and
#: [tractions] (name = vector) are listed under the key "*".
KINDS: dict[str, dict[str, str]] = {
    "body": {"shape": "str", "lev": "int", "gap": "str", "mesh": "str", "clamped": "names", "contact": "names",
             "name": "str"},
    "boundaries": {"*": "int"},
    "material": {"young": "number", "poisson": "number"},
    "friction": {"coefficient": "number"},
    "contact": {"sliding": "str"},
    "load": {"case": "str", "scale": "number", "body_force": "vector"},
    "tractions": {"*": "traction"},
    "prescribed": {"*": "prescription"},
    "roller": {"*": "components"},
    "obstacle": {"name": "str", "type": "str", "point": "vector", "normal": "vector", "center": "vector",
                 "axis": "vector", "radius": "number", "displacement": "vector", "file": "str", "side": "str"},
    "solver": setting_kinds(),  # the fields of SolverSettings
    "path.step": {"tractions": "table", "prescribed": "table", "move": "table", "rotate": "table",
                  "body_force": "vector", "substeps": "int"},
    "bodies": {"*": "int"},
    "contact_pair": {"slave": "surface", "master": "surface", "friction": "number", "search_distance": "number",
                     "name": "str", "method": "str"},
}
_KIND_TEXT = {"str": "a string", "int": "an integer", "number": "a finite number", "bool": "true or false",
              "names": "a list of boundary names (strings)",
              "surface": "a boundary name or a non-empty list of boundary names",
              "vector": "a list of 3 numbers, all finite",
              "traction": "a list of 3 numbers (finite) or expressions in x1, x2, x3",
              "components": "a list of distinct components 0, 1, 2",
              "prescription": 'a list of 3 entries, each a finite number or "free", at least one a number',
              "table": "a table (name = value, ...)"}

#: Largest scene file read (a scene is a few hundred bytes; /dev/zero or a mesh given by mistake is refused).
MAX_SCENE_BYTES = 1 << 20
#: Physically sensible ranges: Young's modulus in GPa (1 Pa to 10^18 Pa), the factor on the power-method
#: estimate of λ_max(A) for γ (outside these bounds the approximation step's d̂ = u − r/γ is either u to
#: machine precision or dominated by r), and the magnitude of tractions and body forces (GPa) times the load
#: scale. Within them every derived quantity (displacements ~ load/E, residuals ~ E·u, their squared norms)
#: stays far inside the float64 range.
YOUNG_RANGE = (1e-9, 1e9)
MAX_LOAD = 1e12
#: Largest level of the cuboid accepted at all (lev 40 has ~10^13 unknowns); the memory check in the CLI
#: refuses far smaller ones on an ordinary machine.
MAX_LEV = 40


#: A ``[prescribed]`` component left free (not held by the support).
FREE = "free"
__all__ += ["FREE", "held_components"]


def held_components(value: Sequence[Any]) -> list[int]:
    """The components a ``[prescribed]`` value holds (its numbers; "free" entries are not held)."""
    return [i for i, c in enumerate(value) if c != FREE]


def check_kind(where: str, value: Any, kind: str) -> None:
    """Raise InputError ``"<where> = <value>: must be ..."`` unless ``value`` is of ``kind`` (see KINDS)."""
    optional = kind.endswith("?")
    kind = kind.rstrip("?")
    if optional and value is None:
        return

    def is_number(v: Any) -> bool:
        return not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v)

    ok = {
        "str": lambda v: isinstance(v, str),
        "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
        "number": is_number,
        "bool": lambda v: isinstance(v, bool),
        "names": lambda v: isinstance(v, list) and all(isinstance(n, str) for n in v),
        "surface": lambda v: isinstance(v, str) or (isinstance(v, list) and bool(v)
                                                    and all(isinstance(n, str) for n in v)),
        "vector": lambda v: isinstance(v, list | tuple) and len(v) == 3 and all(is_number(c) for c in v),
        "traction": lambda v: isinstance(v, list | tuple) and len(v) == 3
        and all(is_number(c) or isinstance(c, str) for c in v),
        "components": lambda v: isinstance(v, list) and bool(v) and len(set(map(repr, v))) == len(v)
        and all(isinstance(c, int) and not isinstance(c, bool) and c in (0, 1, 2) for c in v),
        "table": lambda v: isinstance(v, dict),
        "prescription": lambda v: isinstance(v, list | tuple) and len(v) == 3
        and all(is_number(c) or c == FREE for c in v) and any(is_number(c) for c in v),
    }[kind](value)
    if not ok:
        raise InputError(f"{where} = {value!r}: must be {_KIND_TEXT[kind]}")


#: Section attributes that may be None (set so in code, never from TOML).
OPTIONAL = {"mesh", "name", "case", "accuracy", "gamma", "gamma_node_scale", "poisson_ratio"}


def check_kinds(section: str, obj: Any) -> None:
    """check_kind on every attribute of a section dataclass that KINDS lists (values set by flags or code),
    named as the command line names it (:data:`FLAGS`, e.g. ``load_scale`` for [load] scale)."""
    names = {key: flag for flag, key in FLAGS.items()}
    for f in fields(obj):
        kind = KINDS[section].get(f.name)
        value = getattr(obj, f.name)
        if kind is not None and not (value is None and f.name in OPTIONAL):
            check_kind(names.get((section, f.name), f.name), value, kind)


def read_scene_text(path: Path) -> str:
    """The text of a scene file; InputError for anything but a readable UTF-8 regular file of sensible size."""
    name = str(path)
    try:
        if path.is_dir():
            raise InputError(f"scene file {name!r} is a directory")
        if path.exists() and not path.is_file():
            raise InputError(f"scene file {name!r} is not a regular file")
        with path.open("rb") as f:
            data = f.read(MAX_SCENE_BYTES + 1)
    except OSError as err:
        raise InputError(f"scene file {name!r}: {err.strerror or err}") from None
    if len(data) > MAX_SCENE_BYTES:
        raise InputError(f"scene file {name!r} is larger than {MAX_SCENE_BYTES // 1024} KiB: not a scene (TOML)")
    if b"\0" in data:
        raise InputError(f"scene file {name!r} is a binary file, not a scene (TOML)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"scene file {name!r} is not UTF-8 text, not a scene (TOML)") from None


def check_gap_values(text: str, gap: GapFunction) -> None:
    """Evaluate a gap expression on a grid over the cuboid's bottom (no communication): InputError if it fails
    or leaves [0, 1) there, so that a bad expression is refused before the mesh is built."""
    x1, x2 = np.meshgrid(np.linspace(0.0, 2.0, 41), np.linspace(0.0, 1.0, 21))
    try:
        values = np.asarray(gap(x1.ravel(), x2.ravel()), dtype=np.float64)
    except (ArithmeticError, ValueError, TypeError) as err:
        raise InputError(f"gap expression {text!r} cannot be evaluated: {err}") from None
    bad = ~np.isfinite(values) | (values < 0.0) | (values >= 1.0)
    if np.any(bad):
        raise InputError(f"gap expression {text!r} takes the value {values[bad][0]!r} outside [0, 1) "
                         "on the cuboid's bottom (the body would invert)")


@dataclass
class BodySection:
    """``[body]``: the paper's cuboid at a level with a gap profile, or a gmsh mesh."""

    shape: str = "cuboid"
    lev: int = 4
    gap: str = "d3"
    mesh: str | None = None
    clamped: list[str] = field(default_factory=lambda: ["left"])
    contact: list[str] = field(default_factory=lambda: ["bottom"])
    name: str | None = None

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        check_kinds("body", self)
        if self.shape not in ("cuboid", "mesh"):
            raise InputError(f"body shape {self.shape!r}: choose 'cuboid' or 'mesh'")
        if isinstance(self.lev, bool) or not isinstance(self.lev, int) or not 0 <= self.lev <= MAX_LEV:
            raise InputError(f"lev = {self.lev!r}: must be an integer in [0, {MAX_LEV}]")
        if self.shape == "cuboid":
            gap = self.gap_function()  # raises for an unknown name or a rejected expression
            if self.gap not in GAP_PROFILES:
                check_gap_values(self.gap, gap)
        else:
            if not self.mesh:
                raise InputError("body shape 'mesh' needs mesh = \"path/to/file.msh\"")
            if not Path(self.mesh).is_file():
                raise InputError(f"mesh file {self.mesh!r} does not exist")
        if not isinstance(self.clamped, list):
            raise InputError(f"clamped = {self.clamped!r}: must be a list of boundary names")
        if not isinstance(self.contact, list):
            raise InputError(f"contact = {self.contact!r}: must be a list of boundary names")

    def gap_function(self) -> GapFunction:
        """The gap profile: a named one or a safe expression."""
        if self.gap in GAP_PROFILES:
            return GAP_PROFILES[self.gap]
        if not isinstance(self.gap, str):
            raise InputError(f"gap = {self.gap!r}: a profile name or an expression in x1, x2")
        if self.gap.isidentifier() and self.gap not in ("x1", "x2"):
            raise InputError(f"gap profile {self.gap!r}: choose one of {sorted(GAP_PROFILES)} or an expression")
        return parse_gap_expression(self.gap)


@dataclass
class MaterialSection:
    """``[material]``: isotropic linear elasticity (GPa)."""

    young: float = 70.0
    poisson: float = 0.334

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        check_kinds("material", self)
        self.material().validate()
        if not YOUNG_RANGE[0] <= self.young <= YOUNG_RANGE[1]:
            raise InputError(f"Young's modulus E = {self.young!r} GPa: must lie in [{YOUNG_RANGE[0]:g}, "
                             f"{YOUNG_RANGE[1]:g}] GPa (1 Pa to 1e18 Pa)")

    def material(self) -> Material:
        """The material, with the values checked to be numbers."""
        return Material(_number("young", self.young), _number("poisson", self.poisson))


@dataclass
class FrictionSection:
    """``[friction]``: the Coulomb coefficient F."""

    coefficient: float = 0.23

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        check_kinds("friction", self)
        validate_friction(_number("friction", self.coefficient))


@dataclass
class ContactSection:
    """``[contact]``: the sliding model, "finite" (the contact geometry follows the deformation) or "small"."""

    sliding: str = "finite"

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        check_kinds("contact", self)
        if self.sliding not in SLIDING:
            raise InputError(f"[contact] sliding = {self.sliding!r}: must be one of {', '.join(SLIDING)}")


@dataclass
class LoadSection:
    """``[load]``: a load case of Section 7 (or None when ``[tractions]`` is given), its scale and a body force."""

    case: str | None = "L2"
    scale: float = 1.0
    body_force: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        check_kinds("load", self)
        if self.case is not None and self.case not in LOAD_CASES:
            raise InputError(f"load case {self.case!r}: choose one of {sorted(LOAD_CASES)}")
        _number("load scale", self.scale)
        _vector("body_force", self.body_force)


#: The most solves a load path may take (its steps' substeps summed; also the largest ``--steps``).
MAX_PATH_SOLVES = 10_000


@dataclass
class PathStep:
    """One ``[[path.step]]`` of a quasi-static load path (solved by :mod:`fenics_coulomb.scenes.path`).

    Everything a step does not set takes the SCENE's value (not the previous step's): per boundary for
    ``tractions`` (``[tractions]`` or the ``[load]`` case, times the load scale) and ``prescribed``
    (``[prescribed]``), per obstacle for ``move`` (its ``displacement``) and ``rotate`` (its ``rotation``), and
    ``[load] body_force``.
    """

    #: Boundary name → traction (3 numbers or expressions in x1, x2, x3; GPa, times ``[load] scale``).
    tractions: dict[str, list[Any]] = field(default_factory=dict)
    #: Boundary name (one of the scene's ``[prescribed]``) → its displacement at this step.
    prescribed: dict[str, list[float]] = field(default_factory=dict)
    #: Obstacle name → its total displacement δ at this step.
    move: dict[str, list[float]] = field(default_factory=dict)
    #: Obstacle name → its total rotation [angle_deg, [ax, ay, az], [cx, cy, cz]] at this step (about the centre
    #: at its scene position, then δ); substeps blend the angle about the same axis and centre.
    rotate: dict[str, list[Any]] = field(default_factory=dict)
    #: The body force at this step (GPa/L); None: the scene's.
    body_force: list[float] | None = None
    #: Reach this step in this many equal increments of every load from the previous step's values.
    substeps: int = 1


def _surface_file_beside(table: Any, path: Path) -> Any:
    """A surface obstacle's relative ``file`` is relative to the scene file (as the body's mesh)."""
    if isinstance(table, dict) and table.get("type") == "surface" and isinstance(table.get("file"), str) \
            and table["file"] and not Path(table["file"]).is_absolute():
        candidate = path.parent / table["file"]
        return {**table, "file": str(candidate if candidate.exists() else Path(table["file"]))}
    return table


def check_table(where: str, section: str, number: int, table: dict[str, Any]) -> None:
    """Raise InputError for an unknown key or a value of the wrong kind in the ``number``-th ``[[section]]``."""
    kinds = KINDS[section]
    for key, item in table.items():
        if key not in kinds:
            raise InputError(f"{where}: unknown key {key!r} in [[{section}]] {number} (allowed: {', '.join(kinds)})")
        check_kind(f"[[{section}]] {number} {key}", item, kinds[key])


def path_steps_from_toml(where: str, value: Any) -> list[PathStep]:
    """The ``[[path.step]]`` tables of a scene's ``[path]`` section (kinds checked; names checked later by
    :meth:`Scene.validate`)."""
    if not isinstance(value, dict):
        raise InputError(f"{where}: [path] must be a table holding [[path.step]] tables")
    for key in value:
        if key != "step":
            raise InputError(f"{where}: unknown key {key!r} in [path] (allowed: step, as [[path.step]] tables)")
    tables = value.get("step", [])
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise InputError(f"{where}: path.step = {tables!r}: must be an array of tables ([[path.step]])")
    if not tables:
        raise InputError(f"{where}: [path] has no [[path.step]] table")
    steps = []
    for i, table in enumerate(tables, 1):
        check_table(where, "path.step", i, table)
        steps.append(PathStep(**{k: (dict(v) if isinstance(v, dict) else v) for k, v in table.items()}))
    return steps


@dataclass
class PairSection:
    """One ``[[contact_pair]]`` table: slave and master surfaces (boundary names), friction and search distance
    (:class:`fenics_coulomb.model.pairs.ContactPair`)."""

    slave: list[str] = field(default_factory=list)
    master: list[str] = field(default_factory=list)
    #: None: the scene's ``[friction] coefficient``.
    friction: float | None = None
    #: None: 0.1 × the master surface's bounding-box diagonal.
    search_distance: float | None = None
    name: str | None = None
    #: "mortar" (dual mortar, the default) or "node-to-surface".
    method: str = "mortar"


def pairs_from_toml(where: str, value: Any) -> list[PairSection]:
    """The ``[[contact_pair]]`` tables (kinds checked; a single name is a one-element list)."""
    if not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
        raise InputError(f"{where}: contact_pair = {value!r}: must be an array of tables ([[contact_pair]])")
    pairs = []
    for i, table in enumerate(value, 1):
        check_table(where, "contact_pair", i, table)
        table = {k: ([v] if k in ("slave", "master") and isinstance(v, str) else v) for k, v in table.items()}
        for key in ("slave", "master"):
            if not table.get(key):
                raise InputError(f"{where}: [[contact_pair]] {i} needs a {key} surface (a boundary name)")
        pairs.append(PairSection(**table))
    return pairs


#: The residual reduction of nearly incompressible bodies when none is given (:meth:`Scene.with_scene_defaults`).
NEARLY_INCOMPRESSIBLE_RTOL = 1e-8

#: Command-line names of the scene's settings → (section, key); section None is the scene itself.
FLAGS: dict[str, tuple[str | None, str]] = {
    "lev": ("body", "lev"), "gap": ("body", "gap"), "load": ("load", "case"), "load_scale": ("load", "scale"),
    "young": ("material", "young"), "poisson": ("material", "poisson"), "friction": ("friction", "coefficient"),
    "start": (None, "start"), "sliding": ("contact", "sliding"),
    **{name: ("solver", name) for name in SolverSettings.__dataclass_fields__ if name != "start"},
}

SECTIONS: dict[str, Any] = {"body": BodySection, "material": MaterialSection, "friction": FrictionSection,
                            "contact": ContactSection,
                            "load": LoadSection, "solver": SolverSettings, "boundaries": None, "tractions": None,
                            "obstacle": list, "prescribed": None, "roller": None, "path": list, "bodies": None,
                            "contact_pair": list}


@dataclass
class Scene:
    """A contact scene: one dataclass per TOML section (see the module docstring)."""

    name: str = "cuboid"
    body: BodySection = field(default_factory=BodySection)
    boundaries: dict[str, int] = field(default_factory=dict)
    material: MaterialSection = field(default_factory=MaterialSection)
    friction: FrictionSection = field(default_factory=FrictionSection)
    contact: ContactSection = field(default_factory=ContactSection)
    load: LoadSection = field(default_factory=LoadSection)
    tractions: dict[str, list[float]] | None = None
    solver: SolverSettings = field(default_factory=SolverSettings)
    #: The start: a rule of :data:`~fenics_coulomb.settings.START_RULES` (the solver's ``start``, set from this one
    #: by the builder) or an earlier run's solution.xdmf.
    start: str = "auto"
    #: The solver settings (and ``start``) the user gave, in the scene file or as flags: the material's
    #: defaults (:meth:`with_scene_defaults`) never override them.
    given: frozenset[str] = frozenset()
    #: The rigid obstacles (``[[obstacle]]``); empty: the paper's plane x3 = 0.
    obstacles: list[Obstacle] = field(default_factory=list)
    #: ``[prescribed]``: boundary name → its displacement, per component a number or "free" (not held; at least one
    #: held). Only the held components carry a Dirichlet condition (and a reaction).
    prescribed: dict[str, list[float | str]] = field(default_factory=dict)
    #: ``[roller]``: boundary name → the components held at 0 (0 = x1, 1 = x2, 2 = x3).
    roller: dict[str, list[int]] = field(default_factory=dict)
    #: ``[[path.step]]``: the steps of a quasi-static load path; empty: one static solve.
    path: list[PathStep] = field(default_factory=list)
    #: ``[bodies]``: body name → cell tag of a mesh with several volumes.
    bodies: dict[str, int] = field(default_factory=dict)
    #: ``[material.NAME]``: body name → its material (the others take ``[material]``).
    materials: dict[str, MaterialSection] = field(default_factory=dict)
    #: ``[[contact_pair]]``: two elastic bodies in contact (replaces ``contact`` and ``[[obstacle]]``).
    contact_pairs: list[PairSection] = field(default_factory=list)

    # -- construction ------------------------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        """Read a scene file; raise InputError naming any unreadable file, bad key or bad value."""
        path = Path(path)
        where = f"scene file {str(path)!r}"
        text = read_scene_text(path)
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as err:
            raise InputError(f"{where} does not parse: {err}") from None
        except RecursionError:  # tomllib recurses per level of nested arrays or inline tables
            raise InputError(f"{where} does not parse: its arrays or tables are nested too deeply") from None
        sections: dict[str, Any] = {}
        for section, value in data.items():
            if section not in SECTIONS:
                raise InputError(f"{where}: unknown section [{section}] (allowed: {', '.join(SECTIONS)})")
            if section == "obstacle":
                value = [_surface_file_beside(table, path) for table in value] if isinstance(value, list) else value
                kinds = KINDS[section]
                for i, table in enumerate(value if isinstance(value, list) else []):
                    for key, item in (table.items() if isinstance(table, dict) else ()):
                        if key in kinds:
                            check_kind(f"[[obstacle]] {i + 1} {key}", item, kinds[key])
                sections[section] = obstacles_from_list(value)
                continue
            if section == "path":
                sections[section] = path_steps_from_toml(where, value)
                continue
            if section == "contact_pair":
                sections[section] = pairs_from_toml(where, value)
                continue
            if section == "material" and isinstance(value, dict):
                per_body = {k: v for k, v in value.items() if isinstance(v, dict)}
                for body_name, table in per_body.items():
                    for key, item in table.items():
                        if key not in KINDS["material"]:
                            raise InputError(f"{where}: unknown key {key!r} in [material.{body_name}] (allowed: "
                                             f"{', '.join(KINDS['material'])})")
                        check_kind(f"[material.{body_name}] {key}", item, KINDS["material"][key])
                sections["materials"] = {k: MaterialSection(**v) for k, v in per_body.items()}
                value = {k: v for k, v in value.items() if not isinstance(v, dict)}
            if not isinstance(value, dict):
                raise InputError(f"{where}: [{section}] must be a table")
            kinds = KINDS[section]
            for key, item in value.items():
                if key in kinds or "*" in kinds:
                    check_kind(f"[{section}] {key}", item, kinds.get(key, kinds.get("*", "")))
            kind = SECTIONS[section]
            if kind is None:
                sections[section] = dict(value)
                continue
            allowed = [f.name for f in fields(kind)] + (["start"] if section == "solver" else [])
            for key in value:
                if key not in allowed:
                    raise InputError(f"{where}: unknown key {key!r} in [{section}] (allowed: {', '.join(allowed)})")
            sections[section] = {k: v for k, v in value.items() if k != "start"}
        start = data.get("solver", {}).get("start", "auto")
        if "tractions" in data and "case" in data.get("load", {}):
            raise InputError(f"{where}: give either [load] case or [tractions], not both")
        load = sections.get("load", {})
        if "tractions" in data:
            load = {**load, "case": None}
        body = sections.get("body", {})
        if "contact_pair" in sections and "contact" not in body:
            body = {**body, "contact": []}  # two bodies: the pairs name the contact surfaces
        mesh = body.get("mesh")
        if isinstance(mesh, str) and not Path(mesh).is_absolute():
            candidate = path.parent / mesh
            body = {**body, "mesh": str(candidate if candidate.exists() else Path(mesh))}
        try:
            scene = cls(
                name=body.get("name") or path.stem, body=BodySection(**body), boundaries=sections.get("boundaries", {}),
                material=MaterialSection(**sections.get("material", {})),
                friction=FrictionSection(**sections.get("friction", {})), load=LoadSection(**load),
                contact=ContactSection(**sections.get("contact", {})),
                tractions=sections.get("tractions"), solver=SolverSettings(**sections.get("solver", {})),
                start=start, given=frozenset(data.get("solver", {})) if isinstance(data.get("solver"), dict)
                else frozenset(), obstacles=sections.get("obstacle", []), prescribed=sections.get("prescribed", {}),
                roller=sections.get("roller", {}), path=sections.get("path", []), bodies=sections.get("bodies", {}),
                materials=sections.get("materials", {}), contact_pairs=sections.get("contact_pair", []),
            )
        except TypeError as err:  # unreachable for checked keys; kept as a one-line error
            raise InputError(f"{where}: {err}") from None
        scene.validate()
        return scene

    def override(self, **flags: Any) -> Scene:
        """Return a copy with the given (non-None) values replaced; the names are :data:`FLAGS`."""
        unknown = [key for key, value in flags.items() if value is not None and key not in FLAGS]
        if unknown:
            raise InputError(f"unknown scene setting {unknown[0]!r}")
        solver = {FLAGS[key][1]: value for key, value in flags.items()
                  if value is not None and FLAGS[key][0] == "solver"}
        scene = dataclasses.replace(
            self, body=dataclasses.replace(self.body), material=dataclasses.replace(self.material),
            friction=dataclasses.replace(self.friction), load=dataclasses.replace(self.load),
            contact=dataclasses.replace(self.contact),
            solver=dataclasses.replace(self.solver, **solver) if solver else self.solver)  # frozen: shared
        for key, value in flags.items():
            if value is None:
                continue
            section, attr = FLAGS[key]
            if section != "solver":  # the solver's values are validated by SolverSettings above
                setattr(scene if section is None else getattr(scene, section), attr, value)
            if section in (None, "solver"):
                scene.given = scene.given | {attr}
            if key == "load":
                scene.tractions = None
        scene.validate()
        return scene

    # -- validation (pure, identical on every rank) ------------------------------------------------
    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        if not isinstance(self.boundaries, dict):
            raise InputError(f"boundaries = {self.boundaries!r}: must be a table of names = integer tags")
        self.body.validate()
        if self.body.shape == "cuboid":
            names: dict[str, Any] = FACE_NAMES
            where = "does not exist on the cuboid (it has " + ", ".join(FACE_NAMES) + ")"
        else:
            for name, tag in self.boundaries.items():
                if isinstance(tag, bool) or not isinstance(tag, int):
                    raise InputError(f"boundary {name!r} = {tag!r}: the tag must be an integer")
            names = self.boundaries
            where = f"is not in [boundaries] ({', '.join(self.boundaries) or 'empty'})"
            if self.load.case is not None:
                raise InputError(f"load case {self.load.case!r} is defined for the cuboid only; give [tractions]")
        for name in (*self.body.clamped, *self.body.contact, *(self.tractions or {}), *self.prescribed,
                     *self.roller):
            if name not in names:
                raise InputError(f"boundary {name!r} {where}")
        if not (self.body.clamped or self.prescribed or self.roller):
            raise InputError("no Dirichlet boundary: name clamped, [prescribed] or [roller] boundaries "
                             "(rigid motions)")
        for name, value in self.prescribed.items():
            check_kind(f"prescribed displacement on {name!r}", value, "prescription")
        for name, value in self.roller.items():
            if (not isinstance(value, list) or not value or len(set(map(repr, value))) != len(value)
                    or any(isinstance(c, bool) or c not in (0, 1, 2) for c in value)):
                raise InputError(f"roller on {name!r} = {value!r}: a list of distinct components 0, 1, 2")
        self.material.validate()
        self._validate_bodies(names, where)
        self.friction.validate()
        self.contact.validate()
        self.load.validate()
        if self.tractions is not None and not isinstance(self.tractions, dict):
            raise InputError(f"tractions = {self.tractions!r}: must be a table of names = [3 numbers]")
        for name, value in (self.tractions or {}).items():
            if not isinstance(value, list) or len(value) != 3:
                raise InputError(f"traction on {name!r} = {value!r}: must be 3 numbers or expressions in x1, x2, "
                                 "x3 (GPa)")
            if any(isinstance(c, str) for c in value):
                for c in value:
                    if isinstance(c, str):
                        parse_point_expression(c, f"traction expression on {name!r}")
                    else:
                        _number(f"traction on {name!r}", c)
            else:
                _vector(f"traction on {name!r}", value)
        # expressions are bounded by their evaluation (non-finite values are refused where interpolated)
        largest = max([abs(float(c)) for v in (self.tractions or {}).values() for c in v if not isinstance(c, str)]
                      + [1.0]) * abs(float(self.load.scale))
        if largest > MAX_LOAD or max(abs(float(c)) for c in self.load.body_force) > MAX_LOAD:
            raise InputError(f"load scale = {self.load.scale!r}: tractions and body forces (times the scale) must "
                             f"stay below {MAX_LOAD:g} GPa in magnitude")
        self._validate_path(names, where)
        check_kind("start", self.start, "str")
        if not (self.start in START_RULES or Path(self.start).suffix in (".xdmf", ".h5")):
            raise InputError(f"start {self.start!r}: 'auto', 'zero', 'undeformed' or a solution.xdmf of an earlier "
                             "run")
        if self.start not in START_RULES and not Path(self.start).with_suffix(".h5").is_file():
            raise InputError(f"start file {self.start!r} (and its .h5) does not exist")
        # [solver]: a SolverSettings is validated where it is constructed (its fields' rules)

    def _validate_bodies(self, names: dict[str, Any], where: str) -> None:
        """Check ``[bodies]``, ``[material.NAME]`` and ``[[contact_pair]]``."""
        for name, tag in self.bodies.items():
            if isinstance(tag, bool) or not isinstance(tag, int):
                raise InputError(f"body {name!r} = {tag!r}: the cell tag must be an integer")
        for name, material in self.materials.items():
            if name not in self.bodies:
                bodies = ", ".join(self.bodies) or "empty"
                raise InputError(f"[material.{name}]: {name!r} is not in [bodies] ({bodies})")
            material.validate()
        if not self.contact_pairs:
            return
        if self.body.shape != "mesh":
            raise InputError("[[contact_pair]] needs a mesh body (shape = 'mesh') with the bodies as volumes")
        if self.obstacles and not self.body.contact:
            raise InputError("[[obstacle]] with [[contact_pair]]: name the obstacles' contact boundary in [body] "
                             "contact")
        if self.body.contact and not self.obstacles:
            raise InputError(f"[body] contact = {self.body.contact!r} with [[contact_pair]]: the pairs name their own "
                             "surfaces; a contact boundary is for [[obstacle]]s")
        for i, pair in enumerate(self.contact_pairs, 1):
            for name in (*pair.slave, *pair.master):
                if name not in names:
                    raise InputError(f"[[contact_pair]] {i}: boundary {name!r} {where}")
            if pair.friction is not None and not (math.isfinite(pair.friction) and pair.friction >= 0):
                raise InputError(f"[[contact_pair]] {i} friction = {pair.friction!r}: must be finite and >= 0")
            if pair.search_distance is not None and not (math.isfinite(pair.search_distance)
                                                          and pair.search_distance > 0):
                raise InputError(f"[[contact_pair]] {i} search_distance = {pair.search_distance!r}: must be > 0")
            check_method(pair.method, f"[[contact_pair]] {i}")

    def _validate_path(self, names: dict[str, Any], where: str) -> None:
        """Check the ``[[path.step]]`` tables: kinds, boundary and obstacle names, values, substeps."""
        if not isinstance(self.path, list) or not all(isinstance(s, PathStep) for s in self.path):
            raise InputError(f"path = {self.path!r}: must be a list of [[path.step]] tables")
        named = [o.name for o in self.obstacles if getattr(o, "name", None)]
        kinds = KINDS["path.step"]
        solves = 0
        for i, step in enumerate(self.path, 1):
            at = f"[[path.step]] {i}"
            for key in kinds:
                value = getattr(step, key)
                if not (key == "body_force" and value is None):
                    check_kind(f"{at} {key}", value, kinds[key])
            if isinstance(step.substeps, bool) or step.substeps < 1:
                raise InputError(f"{at} substeps = {step.substeps!r}: must be an integer >= 1")
            solves += step.substeps
            for name, value in step.tractions.items():
                if name not in names:
                    raise InputError(f"{at} tractions: boundary {name!r} {where}")
                check_kind(f"{at} traction on {name!r}", value, "traction")
                for c in value:
                    if isinstance(c, str):
                        parse_point_expression(c, f"{at} traction expression on {name!r}")
            for name, value in step.prescribed.items():
                if name not in self.prescribed:
                    raise InputError(
                        f"{at} prescribed: boundary {name!r} is not in the scene's [prescribed] "
                        f"({', '.join(self.prescribed) or 'empty'}): the Dirichlet boundaries cannot change "
                        "along a path; give it its initial value in [prescribed]")
                check_kind(f"{at} prescribed displacement on {name!r}", value, "prescription")
                if held_components(value) != held_components(self.prescribed[name]):
                    raise InputError(f"{at} prescribed displacement on {name!r} = {value!r}: must leave the same "
                                     f"components free as [prescribed] {name} = {self.prescribed[name]!r} (the held "
                                     "components cannot change along a path)")
            for name, value in step.move.items():
                if name not in named:
                    raise InputError(f"{at} move: no obstacle named {name!r} (named obstacles: "
                                     f"{', '.join(named) or 'none'}; give the [[obstacle]] a name to move it)")
                check_kind(f"{at} move of {name!r}", value, "vector")
            for name, value in step.rotate.items():
                if name not in named:
                    raise InputError(f"{at} rotate: no obstacle named {name!r} (named obstacles: "
                                     f"{', '.join(named) or 'none'}; give the [[obstacle]] a name to rotate it)")
                _rotation(value, f"{at} rotate of {name!r}")
            largest = max([abs(float(c)) for v in step.tractions.values() for c in v if not isinstance(c, str)]
                          + [1.0]) * abs(float(self.load.scale))
            if largest > MAX_LOAD or max(abs(float(c)) for c in (step.body_force or [0.0])) > MAX_LOAD:
                raise InputError(f"{at}: tractions (times the load scale {self.load.scale!r}) and body forces must "
                                 f"stay below {MAX_LOAD:g} GPa in magnitude")
        if solves > MAX_PATH_SOLVES:
            raise InputError(f"[[path.step]]: {solves} solves (steps times substeps): at most {MAX_PATH_SOLVES}")

    # -- derived data ------------------------------------------------------------------------------
    def scaled_traction(self, name: str, value: list[Any]) -> tuple[Any, Any, Any]:
        """A traction of ``[tractions]`` or a path step times the load scale: constant components as numbers,
        expression components as compiled functions of points x (shape (3, m))."""
        s = float(self.load.scale)

        def component(c: Any) -> Any:
            if isinstance(c, str):
                f = parse_point_expression(c, f"traction expression on {name!r}")

                def scaled(x: Any) -> Any:
                    return s * f(x)

                scaled.__name__ = c if s == 1.0 else f"{s:g}*({c})"
                return scaled
            return s * float(c)

        return tuple(component(c) for c in value)  # type: ignore[return-value]

    def traction_table(self) -> dict[str, tuple[Any, Any, Any]]:
        """Tractions (GPa) per boundary name: constant components scaled, expression components as compiled
        functions of points x (shape (3, m)) with the scale applied."""
        if self.tractions is None:
            return paper_tractions(self.load.case, self.load.scale) if self.load.case is not None else {}
        return {k: self.scaled_traction(k, v) for k, v in self.tractions.items()}

    @property
    def label(self) -> str:
        """A short label for figures and logs."""
        if self.name != "cuboid":
            return self.name
        return f"{self.body.gap}/{self.load.case or 'tractions'}, lev {self.body.lev}"

    def with_scene_defaults(self) -> Scene:
        """The scene with the defaults its material calls for (a copy; what the user gave is kept): a nearly
        incompressible body (the largest ν of the scene ≥
        :data:`~fenics_coulomb.scd.preconditioner.NEARLY_INCOMPRESSIBLE_POISSON`) is solved to ``rtol`` =
        :data:`NEARLY_INCOMPRESSIBLE_RTOL` unless ``rtol`` or ``accuracy`` is given. The start is the solver's
        (:attr:`~fenics_coulomb.settings.SolverSettings.start`, "auto" unless the scene names one).

        Still needed with the start rule (it is a matter of the material, not of the start): the graded sphere
        block of docs/robustness at ν = 0.499 (1 rank; the rule takes the undeformed body) balances its forces to
        3.1e-6 (nodal equilibrium 1.4e-5) at rtol 1e-7 and to 7.1e-8 (1.2e-6) at 1e-8, for one more Newton step
        (10 / 305 Krylov against 9 / 270); at ν = 0.49 to 2.2e-7 against 1.0e-8 (15 / 270 against 14 / 251).
        The paper's cuboid at ν = 0.499, lev 7 (2 ranks, the paper's start, nested) balances to 6.8e-10 already
        at 1e-7 (9 / 376 against 10 / 429).
        """
        poisson = max([float(self.material.poisson)] + [float(m.poisson) for m in self.materials.values()])
        if poisson < NEARLY_INCOMPRESSIBLE_POISSON:
            return self
        if {"rtol", "accuracy"} & self.given:
            return dataclasses.replace(self)
        return dataclasses.replace(self, solver=dataclasses.replace(
            self.solver, rtol=min(self.solver.rtol, NEARLY_INCOMPRESSIBLE_RTOL)))

    def as_dict(self) -> dict[str, Any]:
        """The scene as plain data (for summary.json)."""
        data = asdict(self)
        data["given"] = sorted(self.given)
        data["obstacles"] = [{"type": o.kind, **dataclasses.asdict(o)} for o in self.obstacles]
        return data
