"""The sections of a scene: one small validated dataclass per TOML section (``[body]``, ``[material]``,
``[friction]``, ``[contact]``, ``[load]``, ``[[path.step]]``, ``[[contact_pair]]``), the typed keys of every section
(:data:`KINDS`, :func:`check_kind`) and the ranges; every message names its key. The scene that holds them and its
cross-section rules: :mod:`fenics_coulomb.scenes.scene`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np


from fenics_coulomb.errors import InputError
from fenics_coulomb.model.arguments import check_sliding, validate_friction
from fenics_coulomb.model.materials import Material
from fenics_coulomb.scenes.cuboid import GAP_PROFILES, LOAD_CASES, GapFunction
from fenics_coulomb.scenes.expression import parse_gap_expression
from fenics_coulomb.settings import SolverSettings, setting_kinds

__all__ = ["KINDS", "MAX_SCENE_BYTES", "YOUNG_RANGE", "MAX_LOAD", "MAX_LEV", "FREE", "OPTIONAL", "MAX_PATH_SOLVES",
           "FLAGS", "held_components", "check_kind", "check_kinds", "check_gap_values", "BodySection",
           "MaterialSection", "FrictionSection", "ContactSection", "LoadSection", "PathStep", "check_table",
           "path_steps_from_toml", "PairSection", "pairs_from_toml", "check_support_tables"]


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


def check_support_tables(clamped: Sequence[str], prescribed: Sequence[str], roller: Sequence[str]) -> None:
    """InputError for a boundary named in two support tables: its conditions and reaction were one table's (a
    clamped face also a roller kept the reaction of neither; a prescribed face also clamped lost its motion)."""
    tables = (("[body] clamped", list(clamped)), ("[prescribed]", list(prescribed)), ("[roller]", list(roller)))
    for i, (first, a) in enumerate(tables):
        for second, b in tables[i + 1:]:
            both = [name for name in a if name in b]
            if both:
                raise InputError(f"boundary {both[0]!r} is in {first} and in {second}: name each boundary in one "
                                 "support table (a roller's or a free component's hold is a [prescribed] value with "
                                 "\"free\" entries)")


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
        check_sliding(self.sliding)


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
        fields_of_step: dict[str, Any] = {k: (dict(v) if isinstance(v, dict) else v) for k, v in table.items()}
        steps.append(PathStep(**fields_of_step))
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


#: Command-line names of the scene's settings → (section, key); section None is the scene itself.
FLAGS: dict[str, tuple[str | None, str]] = {
    "lev": ("body", "lev"), "gap": ("body", "gap"), "load": ("load", "case"), "load_scale": ("load", "scale"),
    "young": ("material", "young"), "poisson": ("material", "poisson"), "friction": ("friction", "coefficient"),
    "start": (None, "start"), "sliding": ("contact", "sliding"),
    **{name: ("solver", name) for name in SolverSettings.__dataclass_fields__ if name != "start"},
}
