"""Scenes: a TOML description of a contact problem as pure data, parsed with :mod:`tomllib` (never ``eval``).

One small validated dataclass per TOML section; :func:`fenics_coulomb.builder.build_problem` turns a scene
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

    [[obstacle]]            # rigid obstacles (fenics_coulomb.obstacles); none: the plane x3 = 0
    type = "sphere"         # plane (point, normal) | sphere (center, radius) | cylinder (point, axis, radius)
    center = [1.0, 0.5, -0.5]
    radius = 0.5
    displacement = [0.0, 0.0, 0.01]   # rigid translation δ (an indentation may overlap the body)

    [solver]                # the fields of fenics_coulomb.settings.SolverSettings, and start
    variant = "4a"
    tol = 0.1
    rtol = 1e-12            # the paper's reduction (default 1e-8)
    pc = "auto"             # ilu below 50 000 unknowns, gamg above
    start = "zero"
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.io.gmshio
import dolfinx.mesh

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.expression import parse_gap_expression, parse_point_expression
from fenics_coulomb.materials import Material
from fenics_coulomb.model import validate_friction
from fenics_coulomb.obstacles import Obstacle, obstacles_from_list
from fenics_coulomb.scene import FACE_NAMES, GAP_PROFILES, LOAD_CASES, GapFunction, paper_tractions
from fenics_coulomb.settings import SolverSettings, rtol_for_accuracy  # noqa: F401  (re-exported)


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{name} = {value!r}: must be a finite number")
    return float(value)


def _vector(name: str, value: Any) -> list[float]:
    if not isinstance(value, list | tuple) or len(value) != 3:
        raise InputError(f"{name} = {value!r}: must be 3 numbers")
    return [_number(name, c) for c in value]


def read_gmsh(path: str, comm: MPI.Comm) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """Read a gmsh .msh file on rank 0 (quietly) and distribute it; return (mesh, facet tags)."""
    import gmsh

    message = ""
    if comm.rank == 0:
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.merge(path)
            if not gmsh.model.getEntities(3):
                message = f"mesh file {path!r} holds no volume (3D) entities"
        except Exception as err:  # gmsh raises plain Exceptions
            message = f"mesh file {path!r} cannot be read by gmsh: {err}"
        if message:
            gmsh.finalize()
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)
    msh, _, facet_tags = dolfinx.io.gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0,
                                                         gdim=3)
    if comm.rank == 0:
        gmsh.finalize()
    return msh, facet_tags


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
        if self.shape not in ("cuboid", "mesh"):
            raise InputError(f"body shape {self.shape!r}: choose 'cuboid' or 'mesh'")
        if isinstance(self.lev, bool) or not isinstance(self.lev, int) or self.lev < 0:
            raise InputError(f"lev = {self.lev!r}: must be an integer >= 0")
        if self.shape == "cuboid":
            self.gap_function()  # raises for an unknown name or a rejected expression
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
        self.material().validate()

    def material(self) -> Material:
        """The material, with the values checked to be numbers."""
        return Material(_number("young", self.young), _number("poisson", self.poisson))


@dataclass
class FrictionSection:
    """``[friction]``: the Coulomb coefficient F."""

    coefficient: float = 0.23

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        validate_friction(_number("friction", self.coefficient))


@dataclass
class LoadSection:
    """``[load]``: a load case of Section 7 (or None when ``[tractions]`` is given), its scale and a body force."""

    case: str | None = "L2"
    scale: float = 1.0
    body_force: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        if self.case is not None and self.case not in LOAD_CASES:
            raise InputError(f"load case {self.case!r}: choose one of {sorted(LOAD_CASES)}")
        _number("load scale", self.scale)
        _vector("body_force", self.body_force)


#: Command-line names of the scene's settings → (section, key); section None is the scene itself.
FLAGS: dict[str, tuple[str | None, str]] = {
    "lev": ("body", "lev"), "gap": ("body", "gap"), "load": ("load", "case"), "load_scale": ("load", "scale"),
    "young": ("material", "young"), "poisson": ("material", "poisson"), "friction": ("friction", "coefficient"),
    "start": (None, "start"),
    **{name: ("solver", name) for name in SolverSettings.__dataclass_fields__},
}

SECTIONS: dict[str, Any] = {"body": BodySection, "material": MaterialSection, "friction": FrictionSection,
                            "load": LoadSection, "solver": SolverSettings, "boundaries": None, "tractions": None,
                            "obstacle": list, "prescribed": None, "roller": None}


@dataclass
class Scene:
    """A contact scene: one dataclass per TOML section (see the module docstring)."""

    name: str = "cuboid"
    body: BodySection = field(default_factory=BodySection)
    boundaries: dict[str, int] = field(default_factory=dict)
    material: MaterialSection = field(default_factory=MaterialSection)
    friction: FrictionSection = field(default_factory=FrictionSection)
    load: LoadSection = field(default_factory=LoadSection)
    tractions: dict[str, list[float]] | None = None
    solver: SolverSettings = field(default_factory=SolverSettings)
    start: str = "zero"
    #: The rigid obstacles (``[[obstacle]]``); empty: the paper's plane x3 = 0.
    obstacles: list[Obstacle] = field(default_factory=list)
    #: ``[prescribed]``: boundary name → its displacement (all three components).
    prescribed: dict[str, list[float]] = field(default_factory=dict)
    #: ``[roller]``: boundary name → the components held at 0 (0 = x1, 1 = x2, 2 = x3).
    roller: dict[str, list[int]] = field(default_factory=dict)

    # -- construction ------------------------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        """Read a scene file; raise InputError naming any unreadable file, bad key or bad value."""
        path = Path(path)
        where = f"scene file {str(path)!r}"
        try:
            data = tomllib.loads(path.read_text())
        except OSError as err:
            raise InputError(f"{where}: {err.strerror or err}") from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
            raise InputError(f"{where} does not parse: {err}") from None
        sections: dict[str, Any] = {}
        for section, value in data.items():
            if section not in SECTIONS:
                raise InputError(f"{where}: unknown section [{section}] (allowed: {', '.join(SECTIONS)})")
            if section == "obstacle":
                sections[section] = obstacles_from_list(value)
                continue
            if not isinstance(value, dict):
                raise InputError(f"{where}: [{section}] must be a table")
            kind = SECTIONS[section]
            if kind is None:
                sections[section] = dict(value)
                continue
            allowed = [f.name for f in fields(kind)] + (["start"] if section == "solver" else [])
            for key in value:
                if key not in allowed:
                    raise InputError(f"{where}: unknown key {key!r} in [{section}] (allowed: {', '.join(allowed)})")
            sections[section] = {k: v for k, v in value.items() if k != "start"}
        start = data.get("solver", {}).get("start", "zero")
        if "tractions" in data and "case" in data.get("load", {}):
            raise InputError(f"{where}: give either [load] case or [tractions], not both")
        load = sections.get("load", {})
        if "tractions" in data:
            load = {**load, "case": None}
        body = sections.get("body", {})
        mesh = body.get("mesh")
        if isinstance(mesh, str) and not Path(mesh).is_absolute():
            candidate = path.parent / mesh
            body = {**body, "mesh": str(candidate if candidate.exists() else Path(mesh))}
        try:
            scene = cls(
                name=path.stem, body=BodySection(**body), boundaries=sections.get("boundaries", {}),
                material=MaterialSection(**sections.get("material", {})),
                friction=FrictionSection(**sections.get("friction", {})), load=LoadSection(**load),
                tractions=sections.get("tractions"), solver=SolverSettings(**sections.get("solver", {})),
                start=start, obstacles=sections.get("obstacle", []), prescribed=sections.get("prescribed", {}),
                roller=sections.get("roller", {}),
            )
        except TypeError as err:  # unreachable for checked keys; kept as a one-line error
            raise InputError(f"{where}: {err}") from None
        scene.validate()
        return scene

    def override(self, **flags: Any) -> Scene:
        """Return a copy with the given (non-None) values replaced; the names are :data:`FLAGS`."""
        scene = dataclasses.replace(
            self, body=dataclasses.replace(self.body), material=dataclasses.replace(self.material),
            friction=dataclasses.replace(self.friction), load=dataclasses.replace(self.load),
            solver=dataclasses.replace(self.solver))
        for key, value in flags.items():
            if value is None:
                continue
            if key not in FLAGS:
                raise InputError(f"unknown scene setting {key!r}")
            section, attr = FLAGS[key]
            setattr(scene if section is None else getattr(scene, section), attr, value)
            if key == "load":
                scene.tractions = None
        scene.validate()
        return scene

    # -- validation (pure, identical on every rank) ------------------------------------------------
    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
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
            if not isinstance(value, list) or len(value) != 3:
                raise InputError(f"prescribed displacement on {name!r} = {value!r}: must be 3 numbers")
            _vector(f"prescribed displacement on {name!r}", value)
        for name, value in self.roller.items():
            if (not isinstance(value, list) or not value or len(set(map(repr, value))) != len(value)
                    or any(isinstance(c, bool) or c not in (0, 1, 2) for c in value)):
                raise InputError(f"roller on {name!r} = {value!r}: a list of distinct components 0, 1, 2")
        self.material.validate()
        self.friction.validate()
        self.load.validate()
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
        if not (self.start in ("zero", "undeformed") or Path(self.start).suffix in (".xdmf", ".h5")):
            raise InputError(f"start {self.start!r}: 'zero', 'undeformed' or a solution.xdmf of an earlier run")
        if self.start not in ("zero", "undeformed") and not Path(self.start).with_suffix(".h5").is_file():
            raise InputError(f"start file {self.start!r} (and its .h5) does not exist")
        self.solver.validate()

    # -- derived data ------------------------------------------------------------------------------
    def traction_table(self) -> dict[str, tuple[Any, Any, Any]]:
        """Tractions (GPa) per boundary name: constant components scaled, expression components as compiled
        functions of points x (shape (3, m)) with the scale applied."""
        if self.tractions is None:
            return paper_tractions(self.load.case, self.load.scale) if self.load.case is not None else {}
        s = float(self.load.scale)

        def component(name: str, c: Any) -> Any:
            if isinstance(c, str):
                f = parse_point_expression(c, f"traction expression on {name!r}")
                return lambda x: s * f(x)
            return s * float(c)

        return {k: tuple(component(k, c) for c in v) for k, v in self.tractions.items()}  # type: ignore[misc]

    @property
    def label(self) -> str:
        """A short label for figures and logs."""
        if self.name != "cuboid":
            return self.name
        return f"{self.body.gap}/{self.load.case or 'tractions'}, lev {self.body.lev}"

    def as_dict(self) -> dict[str, Any]:
        """The scene as plain data (for summary.json)."""
        data = asdict(self)
        data["obstacles"] = [{"type": o.kind, **dataclasses.asdict(o)} for o in self.obstacles]
        return data
