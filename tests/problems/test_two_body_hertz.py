"""benchmarks/two_body_hertz.py on a coarse mesh (1 and 2 ranks): the gmsh hemisphere on the block is two
disjoint bodies with the tags of meshes/hemisphere_on_block.py; the frictionless two-body solve converges, obeys
the physics, balances the forces on the two bodies and is close to Hertz (the fine numbers are in
docs/two-bodies/hertz.md)."""

from __future__ import annotations


from mpi4py import MPI

import numpy as np
import pytest

from benchmarks.two_body_hertz import BODIES, TAGS, contact_radius, hertz, mesh, run  # noqa: E402

from fenics_coulomb.model.pairs.two_body import connected_bodies  # noqa: E402


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_contact_radius():
    """The outermost closed node interpolated halfway to the nearest open node beyond it."""
    r = np.array([0.0, 0.1, 0.2, 0.25, 0.3, 0.15])
    closed = np.array([True, True, True, False, False, False])
    assert contact_radius(r, closed) == (0.225, 0.2, 0.25)


def test_hemisphere_on_block_mesh():
    import dolfinx

    comm = MPI.COMM_WORLD
    msh, cell_tags, facet_tags = mesh(comm, 0.25)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    _, count = connected_bodies(V)
    assert count == 2
    assert set(np.unique(np.concatenate(comm.allgather(cell_tags.values)))) == set(BODIES.values())
    assert set(np.unique(np.concatenate(comm.allgather(facet_tags.values)))) == set(TAGS.values())
    # the slave surface lies on the sphere of radius 1 about (0, 0, 1), above the block's top x3 = 0
    for tag in (TAGS["curved"], TAGS["block_top"]):
        blocks = dolfinx.fem.locate_dofs_topological(V, 2, facet_tags.find(tag))
        x = V.tabulate_dof_coordinates()[blocks]
        if tag == TAGS["curved"]:
            assert np.allclose(np.linalg.norm(x - [0, 0, 1], axis=1), 1.0, atol=1e-6) and np.all(x[:, 2] >= 0)
        else:
            assert np.allclose(x[:, 2], 0.0)


def test_coarse_hertz():
    row = run(MPI.COMM_WORLD, 0.1, 0.03)
    assert row["converged"] and max(row["checks"].values()) < 1e-8 and row["balance"] < 1e-8
    assert row["P"] > 0 and row["closed_nodes"] > 5
    a_H, p0_H = hertz(row["P"])
    assert (a_H, p0_H) == (row["a_hertz"], row["p0_hertz"])
    assert abs(row["a_error"]) < 0.1 and abs(row["p0_fit_error"]) < 0.2
