"""What every gmsh script of meshes/ shares: a gmsh session for one model, and writing its volume mesh."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import gmsh

__all__ = ["add_physical_surfaces", "gmsh_session", "radial_size_field", "write_volume_mesh"]


@contextmanager
def gmsh_session(name: str) -> Iterator[None]:
    """gmsh initialized, quiet, with a new model ``name``; finalized on leaving (also on an error)."""
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(name)
        yield
    finally:
        gmsh.finalize()


def write_volume_mesh(path: Path | str, optimize: bool = False) -> None:
    """Generate the 3D mesh of the current model (``optimize``: then gmsh's tetrahedron optimizer) and write it
    to ``path`` in MSH 4.1, the format dolfinx.io.gmshio reads."""
    gmsh.model.mesh.generate(3)
    if optimize:
        gmsh.model.mesh.optimize()
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))


def add_physical_surfaces(groups: dict[str, list[int]], tags: dict[str, int]) -> None:
    """One physical surface group per name with surfaces (its tag from ``tags``, its name the key)."""
    for name, surfaces in groups.items():
        if surfaces:
            gmsh.model.addPhysicalGroup(2, surfaces, tags[name], name=name)


def radial_size_field(h0: float, growth: float, core: float, largest: float) -> None:
    """The element size h0 within the distance ``core`` of the origin, growing by ``growth`` per unit distance
    beyond it, at most ``largest``: gmsh's background field, the only size source."""
    field = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(field, "F",
                                    f"Min({largest}, {h0} + {growth}*Max(0, Sqrt(x*x + y*y + z*z) - {core}))")
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    for option in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
        gmsh.option.setNumber(f"Mesh.{option}", 0)
