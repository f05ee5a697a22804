"""Scenes: a TOML description of a contact problem, parsed with :mod:`tomllib` (never ``eval``).

Precedence: built-in defaults < scene file < command-line flags. Example (``demos/scenes/d3_L2.toml``)::

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

    [solver]
    variant = "4a"
    tol = 0.1
    rtol = 1e-12            # the paper's reduction (default 1e-8)
    pc = "auto"              # ilu on hexahedra below 50 000 unknowns on <= 2 ranks, gamg otherwise
    start = "zero"
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.io.gmshio
import dolfinx.mesh
import numpy as np

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.expression import parse_gap_expression
from fenics_coulomb.model import Material, validate_friction
from fenics_coulomb.newton import SolverSettings
from fenics_coulomb.partition import create_partitioner
from fenics_coulomb.scene import FACE_NAMES, GAP_PROFILES, LOAD_CASES, Body, GapFunction, create_cuboid, paper_tractions

SECTIONS: dict[str, tuple[str, ...]] = {
    "body": ("shape", "lev", "gap", "mesh", "clamped", "contact", "name"),
    "boundaries": (),  # free names → tags (mesh bodies)
    "material": ("young", "poisson"),
    "friction": ("coefficient",),
    "load": ("case", "scale", "body_force"),
    "tractions": (),  # free names → 3-vectors
    "solver": ("variant", "tol", "rtol", "pc", "start", "max_it", "gamma_scale", "predictor", "accuracy",
               "line_search_steps", "adaptive_tol"),
}


#: Bound on the measured ratio (relative displacement error)/rtol over docs/tradeoff (all pc, tol, forcing
#: rules and levels): about twice the largest seen, 189 (ILU, fixed tol 0.5, lev 6; 86 with Eisenstat–Walker).
ERROR_PER_RTOL = 400.0


def rtol_for_accuracy(accuracy: float) -> float:
    """The residual reduction that gives a relative displacement error <= ``accuracy`` (the solver's error,
    not the discretization's), from the measured speed–accuracy table docs/tradeoff."""
    return max(accuracy / ERROR_PER_RTOL, 1e-15)


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
    # The deterministic partitioner, from the coordinates gmsh holds on rank 0 (the rows model_to_mesh gives
    # create_mesh): the same file on the same ranks gives the same partition in every run.
    x = dolfinx.io.gmshio.extract_geometry(gmsh.model) if comm.rank == 0 else np.zeros((0, 3))
    msh, _, facet_tags = dolfinx.io.gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0,
                                                         gdim=3, partitioner=create_partitioner(comm, x))
    if comm.rank == 0:
        gmsh.finalize()
    return msh, facet_tags


@dataclass
class Scene:
    """A contact scene; see the module docstring for the TOML layout."""

    name: str = "cuboid"
    shape: str = "cuboid"
    lev: int = 4
    gap: str = "d3"
    mesh: str | None = None
    boundaries: dict[str, int] = field(default_factory=dict)
    clamped: list[str] = field(default_factory=lambda: ["left"])
    contact: list[str] = field(default_factory=lambda: ["bottom"])
    young: float = 70.0
    poisson: float = 0.334
    friction: float = 0.23
    load: str | None = "L2"
    tractions: dict[str, list[float]] | None = None
    load_scale: float = 1.0
    body_force: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    variant: str = "4a"
    tol: float = 0.1
    rtol: float = SolverSettings.rtol
    pc: str = SolverSettings.pc
    start: str = "zero"
    max_it: int = 100
    gamma_scale: float = SolverSettings.gamma_scale
    predictor: bool = False
    accuracy: float | None = None
    line_search_steps: int = SolverSettings.line_search_steps
    adaptive_tol: bool = SolverSettings.adaptive_tol

    # -- construction ------------------------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        """Read a scene file; raise InputError naming any unreadable file, bad key or bad value."""
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text())
        except OSError as err:
            raise InputError(f"scene file {str(path)!r}: {err.strerror or err}") from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
            raise InputError(f"scene file {str(path)!r} does not parse: {err}") from None
        scene = cls(name=path.stem)
        for section, value in data.items():
            if section not in SECTIONS:
                raise InputError(f"scene file {str(path)!r}: unknown section [{section}] "
                                 f"(allowed: {', '.join(SECTIONS)})")
            if not isinstance(value, dict):
                raise InputError(f"scene file {str(path)!r}: [{section}] must be a table")
            allowed = SECTIONS[section]
            for key in value:
                if allowed and key not in allowed:
                    raise InputError(f"scene file {str(path)!r}: unknown key {key!r} in [{section}] "
                                     f"(allowed: {', '.join(allowed)})")
        body = data.get("body", {})
        mapping = {"shape": "shape", "lev": "lev", "gap": "gap", "mesh": "mesh", "clamped": "clamped",
                   "contact": "contact", "name": "name"}
        for key, attr in mapping.items():
            if key in body:
                setattr(scene, attr, body[key])
        if scene.mesh is not None and not Path(scene.mesh).is_absolute():
            candidate = path.parent / scene.mesh
            scene.mesh = str(candidate if candidate.exists() else Path(scene.mesh))
        scene.boundaries = dict(data.get("boundaries", {}))
        material = data.get("material", {})
        scene.young = material.get("young", scene.young)
        scene.poisson = material.get("poisson", scene.poisson)
        scene.friction = data.get("friction", {}).get("coefficient", scene.friction)
        load = data.get("load", {})
        if "tractions" in data:
            scene.tractions = dict(data["tractions"])
            scene.load = None
        if "case" in load:
            if "tractions" in data:
                raise InputError(f"scene file {str(path)!r}: give either [load] case or [tractions], not both")
            scene.load = load["case"]
        scene.load_scale = load.get("scale", scene.load_scale)
        scene.body_force = load.get("body_force", scene.body_force)
        for key, value in data.get("solver", {}).items():
            setattr(scene, key, value)
        scene.validate()
        return scene

    def override(self, **flags: Any) -> Scene:
        """Return a copy with the given (non-None) values replaced (command-line flags)."""
        values = asdict(self)
        for key, value in flags.items():
            if value is None:
                continue
            if key not in values:
                raise InputError(f"unknown scene setting {key!r}")
            values[key] = value
            if key == "load":
                values["tractions"] = None
        scene = Scene(**values)
        scene.validate()
        return scene

    # -- validation (pure, identical on every rank) ------------------------------------------------
    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        def number(name: str, value: Any) -> float:
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise InputError(f"{name} = {value!r}: must be a finite number")
            return float(value)

        if self.shape not in ("cuboid", "mesh"):
            raise InputError(f"body shape {self.shape!r}: choose 'cuboid' or 'mesh'")
        if isinstance(self.lev, bool) or not isinstance(self.lev, int) or self.lev < 0:
            raise InputError(f"lev = {self.lev!r}: must be an integer >= 0")
        if self.shape == "cuboid":
            self.gap_function()  # raises for an unknown name or a rejected expression
            for name in (*self.clamped, *self.contact, *(self.tractions or {})):
                if name not in FACE_NAMES:
                    raise InputError(f"boundary {name!r} does not exist on the cuboid "
                                     f"(it has {', '.join(FACE_NAMES)})")
        else:
            if not self.mesh:
                raise InputError("body shape 'mesh' needs mesh = \"path/to/file.msh\"")
            if not Path(self.mesh).is_file():
                raise InputError(f"mesh file {self.mesh!r} does not exist")
            for name, tag in self.boundaries.items():
                if isinstance(tag, bool) or not isinstance(tag, int):
                    raise InputError(f"boundary {name!r} = {tag!r}: the tag must be an integer")
            for name in (*self.clamped, *self.contact, *(self.tractions or {})):
                if name not in self.boundaries:
                    raise InputError(f"boundary {name!r} is not in [boundaries] "
                                     f"({', '.join(self.boundaries) or 'empty'})")
            if self.load is not None:
                raise InputError(f"load case {self.load!r} is defined for the cuboid only; give [tractions]")
        if not isinstance(self.clamped, list) or not self.clamped:
            raise InputError(f"clamped = {self.clamped!r}: name at least one boundary (rigid motions)")
        if not isinstance(self.contact, list):
            raise InputError(f"contact = {self.contact!r}: must be a list of boundary names")
        Material(number("young", self.young), number("poisson", self.poisson)).validate()
        validate_friction(number("friction", self.friction))
        if self.load is not None and self.load not in LOAD_CASES:
            raise InputError(f"load case {self.load!r}: choose one of {sorted(LOAD_CASES)}")
        number("load scale", self.load_scale)
        for name, value in (self.tractions or {}).items():
            if not isinstance(value, list) or len(value) != 3:
                raise InputError(f"traction on {name!r} = {value!r}: must be 3 numbers (GPa)")
            for c in value:
                number(f"traction on {name!r}", c)
        if not isinstance(self.body_force, list) or len(self.body_force) != 3:
            raise InputError(f"body_force = {self.body_force!r}: must be 3 numbers")
        for c in self.body_force:
            number("body_force", c)
        if not (self.start in ("zero", "undeformed") or Path(self.start).suffix in (".xdmf", ".h5")):
            raise InputError(f"start {self.start!r}: 'zero', 'undeformed' or a solution.xdmf of an earlier run")
        if self.start not in ("zero", "undeformed") and not Path(self.start).with_suffix(".h5").is_file():
            raise InputError(f"start file {self.start!r} (and its .h5) does not exist")
        if self.accuracy is not None:
            acc = number("accuracy", self.accuracy)
            if not 1e-13 <= acc < 1.0:
                raise InputError(f"accuracy = {acc!r}: a relative displacement error in [1e-13, 1)")
        if not isinstance(self.adaptive_tol, bool):
            raise InputError(f"adaptive_tol = {self.adaptive_tol!r}: must be true or false")
        if not isinstance(self.predictor, bool):
            raise InputError(f"predictor = {self.predictor!r}: must be true or false")
        self.settings().validate()

    # -- derived objects ---------------------------------------------------------------------------
    def gap_function(self) -> GapFunction:
        """The gap profile: a named one or a safe expression."""
        if self.gap in GAP_PROFILES:
            return GAP_PROFILES[self.gap]
        if not isinstance(self.gap, str):
            raise InputError(f"gap = {self.gap!r}: a profile name or an expression in x1, x2")
        if self.gap.isidentifier() and self.gap not in ("x1", "x2"):
            raise InputError(f"gap profile {self.gap!r}: choose one of {sorted(GAP_PROFILES)} or an expression")
        return parse_gap_expression(self.gap)

    def traction_table(self) -> dict[str, tuple[float, float, float]]:
        """Tractions (GPa) per boundary name, scaled."""
        if self.tractions is None:
            return paper_tractions(self.load, self.load_scale) if self.load is not None else {}
        s = float(self.load_scale)
        return {k: (s * float(v[0]), s * float(v[1]), s * float(v[2])) for k, v in self.tractions.items()}

    def settings(self) -> SolverSettings:
        """Solver settings of the scene; ``accuracy``, when given, sets rtol (see :func:`rtol_for_accuracy`)."""
        rtol = self.rtol if self.accuracy is None else rtol_for_accuracy(self.accuracy)
        return SolverSettings(variant=self.variant, tol=self.tol, rtol=rtol, pc=self.pc,
                              max_iterations=self.max_it, gamma_scale=self.gamma_scale,
                              line_search_steps=self.line_search_steps, adaptive_tol=self.adaptive_tol)

    def build_body(self, comm: MPI.Comm) -> Body:
        """Create the mesh and boundary tags (collective)."""
        if self.shape == "cuboid":
            gap: str | GapFunction = self.gap if self.gap in GAP_PROFILES else self.gap_function()
            body = create_cuboid(comm, self.lev, gap)
            body.dirichlet = list(self.clamped)
            body.contact = list(self.contact)
            return body
        assert self.mesh is not None  # validate() requires it for shape = "mesh"
        msh, facet_tags = read_gmsh(self.mesh, comm)
        present = np.unique(facet_tags.values)
        present = np.unique(np.concatenate(comm.allgather(present)))
        missing = [f"{n} = {t}" for n, t in self.boundaries.items() if t not in present]
        check_all(comm, not missing, f"mesh {self.mesh!r} has no facets tagged {', '.join(missing)}")
        cells = msh.topology.index_map(msh.topology.dim).size_global
        return Body(mesh=msh, facet_tags=facet_tags, boundaries=dict(self.boundaries),
                    dirichlet=list(self.clamped), contact=list(self.contact),
                    description=f"mesh {Path(self.mesh).name} ({cells} cells)")

    def as_dict(self) -> dict[str, Any]:
        """The scene as plain data (for summary.json)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
