"""A gmsh file whose physical surface holds elements that are not faces of its volume elements is refused.

DOLFINx's reader drops such elements from the facet tags without a word, so a boundary condition on that surface
misses them. Found in meshes/sphere_on_block_half.py: the upper body's structured core meshed as a transfinite
volume, whose symmetry face's transfinite triangles had the other diagonals than the core's tetrahedra, so its
380 facets at x2 = 0 (of 1171 in the upper body's "sym_y") were untagged and the half model's roller left the
cap's symmetry plane free under the contact (docs/verification §6). Reproduced here on a unit cube: one face's
transfinite arrangement "Right" against the volume's tetrahedra.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb.errors import InputError
from fenics_coulomb.scenes.meshes import read_gmsh_tags


def _cube(path: str, arrangement: str) -> None:
    """A transfinite unit cube (2 cells per edge, tetrahedra), every face a physical surface (tag = its entity);
    face 1 triangulated with ``arrangement``."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        box = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        for _, curve in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(curve, 3)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface, arrangement if surface == 1 else "Left")
            gmsh.model.addPhysicalGroup(2, [surface], surface, name=f"face{surface}")
        gmsh.model.mesh.setTransfiniteVolume(box)
        gmsh.model.addPhysicalGroup(3, [box], 1)
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(path)
    finally:
        gmsh.finalize()


def _read(arrangement: str) -> tuple[object, object, object]:
    comm = MPI.COMM_WORLD
    with tempfile.TemporaryDirectory() as tmp:
        path = comm.bcast(str(Path(tmp) / "cube.msh") if comm.rank == 0 else None)
        if comm.rank == 0:
            _cube(path, arrangement)
        try:
            return read_gmsh_tags(path, comm)
        finally:
            comm.barrier()  # rank 0's directory lives until every rank has read the file


def test_matching_surfaces_are_all_tagged() -> None:
    """Every face consistent: each physical face's 8 triangles are tagged (6 faces, 48 facets)."""
    _, _, facet_tags = _read("Left")
    counts = MPI.COMM_WORLD.allreduce(np.bincount(facet_tags.values[: _owned(facet_tags)], minlength=7))
    assert list(counts[1:]) == [8] * 6


def _owned(tags: object) -> int:
    """The number of tagged facets the rank owns (tags are sorted by facet index; owned facets come first)."""
    n = tags.topology.index_map(2).size_local  # type: ignore[attr-defined]
    return int(np.searchsorted(tags.indices, n))  # type: ignore[attr-defined]


def test_unmatched_surface_is_refused() -> None:
    """Face 1's triangles are not the tetrahedra's faces: refused on every rank, naming the surface (before the
    check the file was read without a word)."""
    with pytest.raises(InputError, match=r"8 of the 8 elements of physical surface 1 'face1'"):
        _read("Right")
