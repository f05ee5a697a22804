"""What every gmsh script of meshes/ shares: a gmsh session for one model, and writing its volume mesh."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import gmsh

__all__ = ["gmsh_session", "write_volume_mesh"]


@contextmanager
def gmsh_session(name: str) -> Iterator[None]:
    """gmsh initialized, quiet, with a new model ``name``; finalized on leaving (also on an error)."""
    gmsh.initialize()
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
