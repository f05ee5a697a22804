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

The sections' dataclasses and typed keys: :mod:`fenics_coulomb.scenes.sections` (their names are also this
module's); here the scene, its file and its cross-section rules.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from fenics_coulomb.errors import InputError
from fenics_coulomb.model import surface as _surface  # noqa: F401  (its register_obstacle call: type = "surface")
from fenics_coulomb.model.pairs.registry import check_method
from fenics_coulomb.model.obstacles import Obstacle, _rotation, obstacles_from_list
from fenics_coulomb.scd.preconditioner import NEARLY_INCOMPRESSIBLE_POISSON
from fenics_coulomb.scenes.cuboid import FACE_NAMES, paper_tractions
from fenics_coulomb.scenes.expression import parse_point_expression
from fenics_coulomb.scenes.sections import (KINDS, MAX_SCENE_BYTES, YOUNG_RANGE, MAX_LOAD, MAX_LEV, FREE, OPTIONAL,
                                            MAX_PATH_SOLVES, FLAGS, held_components, check_kind, check_kinds,
                                            check_support_tables,
                                            check_gap_values, BodySection, MaterialSection, FrictionSection,
                                            ContactSection, LoadSection, PathStep, check_table, path_steps_from_toml,
                                            PairSection, pairs_from_toml, _number, _surface_file_beside, _vector)
from fenics_coulomb.settings import GAMMA_SCALE_RANGE, START_RULES, SolverSettings

__all__ = ["FREE", "KINDS", "NEARLY_INCOMPRESSIBLE_RTOL", "MAX_SCENE_BYTES", "YOUNG_RANGE", "GAMMA_SCALE_RANGE",
           "MAX_LOAD", "MAX_LEV", "check_kind", "OPTIONAL", "check_kinds", "read_scene_text", "check_gap_values",
           "BodySection", "MaterialSection", "FrictionSection", "ContactSection", "LoadSection", "MAX_PATH_SOLVES",
           "PathStep", "check_table", "path_steps_from_toml", "PairSection", "pairs_from_toml", "FLAGS", "SECTIONS",
           "Scene"]


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


#: The residual reduction of nearly incompressible bodies when none is given (:meth:`Scene.with_scene_defaults`).
NEARLY_INCOMPRESSIBLE_RTOL = 1e-8

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
        given = set(self.given)
        # rtol and accuracy set one residual reduction: the one given here replaces the scene's other
        if "rtol" in solver and "accuracy" not in solver and self.solver.accuracy is not None:
            solver["accuracy"] = None
            given.discard("accuracy")
        if "accuracy" in solver and "rtol" not in solver:
            solver["rtol"] = SolverSettings().rtol
            given.discard("rtol")
        scene = dataclasses.replace(
            self, given=frozenset(given), body=dataclasses.replace(self.body),
            material=dataclasses.replace(self.material),
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
            for table, given in (("[boundaries]", self.boundaries), ("[bodies]", self.bodies),
                                 ("[material.NAME]", self.materials)):
                if given:  # gmsh tags of a mesh body: the cuboid would ignore them (or fail on per-body materials)
                    raise InputError(f"{table} ({', '.join(map(str, given))}) is for a mesh body (shape = 'mesh'): "
                                     f"the cuboid is one body of one material with the faces "
                                     f"{', '.join(FACE_NAMES)}")
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
        check_support_tables(list(self.body.clamped), list(self.prescribed), list(self.roller))
        for name, value in self.prescribed.items():
            check_kind(f"prescribed displacement on {name!r}", value, "prescription")
        for name, components in self.roller.items():
            if (not isinstance(components, list) or not components
                    or len(set(map(repr, components))) != len(components)
                    or any(isinstance(c, bool) or c not in (0, 1, 2) for c in components)):
                raise InputError(f"roller on {name!r} = {components!r}: a list of distinct components 0, 1, 2")
        self.material.validate()
        self._validate_bodies(names, where)
        self.friction.validate()
        self.contact.validate()
        self.load.validate()
        if self.tractions is not None and not isinstance(self.tractions, dict):
            raise InputError(f"tractions = {self.tractions!r}: must be a table of names = [3 numbers]")
        for name, traction in (self.tractions or {}).items():
            if not isinstance(traction, list) or len(traction) != 3:
                raise InputError(f"traction on {name!r} = {traction!r}: must be 3 numbers or expressions in x1, x2, "
                                 "x3 (GPa)")
            if any(isinstance(c, str) for c in traction):
                for c in traction:
                    if isinstance(c, str):
                        parse_point_expression(c, f"traction expression on {name!r}")
                    else:
                        _number(f"traction on {name!r}", c)
            else:
                _vector(f"traction on {name!r}", traction)
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
        named = [str(o.name) for o in self.obstacles if getattr(o, "name", None)]
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

        return tuple(component(c) for c in value)

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
