"""The deterministic partitioner (fenics_coulomb.scenes.partition): balance, repeatability and ghost layers."""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import pytest

from fenics_coulomb.scenes.meshes import read_gmsh
from fenics_coulomb.scenes.partition import recursive_bisection
from fenics_coulomb.scenes.cuboid import create_cuboid

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.serial
@pytest.mark.parametrize("nparts", [1, 2, 3, 5, 16])
def test_bisection_balanced_and_repeatable(nparts: int) -> None:
    rng = np.random.default_rng(7)
    points = rng.random((1000, 3)) * [2.0, 1.0, 1.0]
    parts = recursive_bisection(points, nparts)
    counts = np.bincount(parts, minlength=nparts)
    assert counts.sum() == 1000 and len(counts) == nparts
    assert counts.max() - counts.min() <= max(1, int(np.ceil(np.log2(nparts))))
    assert np.array_equal(parts, recursive_bisection(points.copy(), nparts))
    if nparts == 2:  # the first cut is across the longest side (x1 in (0, 2)) at the median
        assert points[parts == 0, 0].max() <= points[parts == 1, 0].min()


def owned_cells(msh: dolfinx.mesh.Mesh) -> np.ndarray:
    n = msh.topology.index_map(msh.topology.dim).size_local
    return np.asarray(msh.topology.original_cell_index[:n])


def test_cuboid_partition_repeats_and_is_ghosted() -> None:
    comm = MPI.COMM_WORLD
    a, b = create_cuboid(comm, 3, "d1"), create_cuboid(comm, 3, "d1")
    assert np.array_equal(owned_cells(a.mesh), owned_cells(b.mesh))
    msh = a.mesh
    tdim = msh.topology.dim
    cells = owned_cells(msh)
    counts = comm.allgather(len(cells))
    assert max(counts) - min(counts) <= 1 and sum(counts) == 12 * 6 * 6
    # shared_facet ghosting: every facet of an owned cell is on the box boundary or has two local cells
    msh.topology.create_connectivity(tdim, tdim - 1)
    msh.topology.create_connectivity(tdim - 1, tdim)
    c2f, f2c = msh.topology.connectivity(tdim, tdim - 1), msh.topology.connectivity(tdim - 1, tdim)
    facets = np.unique(c2f.array[: c2f.offsets[len(cells)]])
    ncells = np.diff(f2c.offsets)[facets]
    # the facet tags cover the whole boundary (left/right/bottom/top/sides)
    boundary = np.isin(facets, a.facet_tags.indices)
    assert np.all((ncells == 2) | ((ncells == 1) & boundary))
    assert comm.size == 1 or msh.topology.index_map(tdim).num_ghosts > 0


def test_gmsh_partition_repeats() -> None:
    comm = MPI.COMM_WORLD
    m1, _ = read_gmsh(str(ROOT / "meshes" / "roller.msh"), comm)
    m2, _ = read_gmsh(str(ROOT / "meshes" / "roller.msh"), comm)
    assert np.array_equal(owned_cells(m1), owned_cells(m2))
    assert np.array_equal(m1.geometry.x, m2.geometry.x)
    counts = comm.allgather(len(owned_cells(m1)))
    assert max(counts) - min(counts) <= 1


def test_partitioners_refuse_what_they_cannot_use() -> None:
    """box_partitioner and create_partitioner checked nothing (a review): n = (0, 4, 2) or (4.7, 4, 2), corners with a
    NaN, 2D points, a ghost mode that is no GhostMode were taken (or failed deep inside, IndexError, nanobind
    TypeError); each is an InputError naming the value now, and the partitioners made from valid input work."""
    from fenics_coulomb import InputError, box_partitioner, create_partitioner

    corners = [np.zeros(3), np.ones(3)]
    for n, match in [((0, 4, 2), "n = "), ((4.7, 4, 2), "n = "), ("442", "n = "), ((4, 4), "n = "),
                     ((True, 4, 2), "n = ")]:
        with pytest.raises(InputError, match=f"box_partitioner: {match}"):
            box_partitioner(corners, n)
    for points in ([[0, 0, 0]], [[0, 0, np.nan], [1, 1, 1]], [[0, 0], [1, 1]], [[0, 0, 0], [1, 0, 1]]):
        with pytest.raises(InputError, match="box_partitioner: points = "):
            box_partitioner(points, (2, 2, 2))
    with pytest.raises(InputError, match="box_partitioner: ghost_mode = 'shared'"):
        box_partitioner(corners, (2, 2, 2), ghost_mode="shared")
    comm = MPI.COMM_WORLD
    with pytest.raises(InputError, match="create_partitioner: comm = NoneType"):
        create_partitioner(None, np.zeros((1, 3)))
    for x in (None, np.zeros(3), np.full((2, 3), np.nan), np.zeros((2, 4))):
        with pytest.raises(InputError, match="create_partitioner: x: "):
            create_partitioner(comm, x)
    msh = dolfinx.mesh.create_box(comm, corners, [4, 4, 2], dolfinx.mesh.CellType.hexahedron,
                                  ghost_mode=dolfinx.mesh.GhostMode.shared_facet,
                                  partitioner=box_partitioner(corners, (4, 4, 2)))
    assert msh.topology.index_map(3).size_global == 32
