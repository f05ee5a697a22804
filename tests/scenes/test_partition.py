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
