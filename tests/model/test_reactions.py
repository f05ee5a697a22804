"""Reactions of supports that carry contact forces (issue 26): a two-body pair whose master body is driven.

Every node of the lower (master) block is prescribed: it is moved up across the gap and δ into the upper block,
whose top is clamped; there is no load. The support of the lower block must carry the whole contact force (its reaction
used to read ~1e-14: the residual K u − l of a rigidly moved body is zero, and the contact force the slave exerts on
the master nodes was left out), the two reactions must cancel, and the force on the master body must be the
opposite of the force on the slave body. Hand check of the magnitude: the upper block (E = 70, ν = 0.3,
0.5 × 0.5 × 0.25) compressed by δ between a clamped top and a frictional bottom is stiffer than in uniaxial
stress (E A δ / H) and softer than in uniaxial strain (M A δ / H, M the P-wave modulus; 10 % for the coarse
mesh's stiffness). Both reactions equal an assembly of our own (tests/model/reaction_reference.py): K u − l over
the held DOFs, minus the contact force on the lower block's master nodes."""

from __future__ import annotations


from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import pytest
from reaction_reference import assembled_reactions, held_dofs
from test_two_body import SLAVE, UPPER_TOP, elasticity

from fenics_coulomb import ContactPair, ContactProblem

from meshes.two_blocks import TAGS, two_blocks  # noqa: E402  (the mesh object, not test_two_body's wrapper)

GAP, DELTA = 1e-3, 3e-4  # the lower block moves up by the gap and then DELTA into the upper block
E, NU, AREA, HEIGHT = 70.0, 0.3, 0.25, 0.25


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_a_driven_master_bodys_support_carries_the_contact_force(friction):
    blocks = two_blocks(MPI.COMM_WORLD, gap=GAP)  # apart: the lower block's nodes are those with x3 <= 0
    msh, ft = blocks.mesh, blocks.facet_tags
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    lower = dolfinx.fem.locate_dofs_geometrical(V, lambda x: x[2] <= 1e-9)
    top = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP))
    drive = dolfinx.fem.dirichletbc(np.array([0.0, 0.0, GAP + DELTA]), lower, V)
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), top, V)
    pair = ContactPair(ft, slave=SLAVE, master=TAGS["lower_top"], friction=friction)
    with ContactProblem(elasticity(V, E, NU), None, [drive, clamp], contact_pairs=[pair],
                        settings={"rtol": 1e-10}, petsc_options_prefix="driven_") as problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result, reactions={"lower": drive, "top": clamp})
        # our own assembly: K u − l over the held DOFs, minus the contact force the slave nodes exert on the
        # lower block's (prescribed) master nodes
        n = V.dofmap.index_map.size_local
        ours = assembled_reactions(elasticity(V, E, NU), None, result.displacement,
                                   {"lower": held_dofs(V, lower), "top": held_dofs(V, top)}, MPI.COMM_WORLD,
                                   minus=np.asarray(result.master_force).reshape(-1, 3)[:n])
    r_lower, r_top = report.reactions["lower"], report.reactions["top"]
    (forces,) = report.pair_forces
    on_slave, on_master = np.array(forces["force_on_slave_body"]), np.array(forces["force_on_master_body"])
    # the slave (upper) block is pushed up, the master (lower) one down; the lower support pushes up
    assert on_slave[2] > 0 and np.allclose(on_master, -on_slave, rtol=1e-8, atol=1e-12)
    assert np.allclose(r_lower, on_slave, rtol=1e-8, atol=1e-12)
    for name in ("lower", "top"):
        assert np.allclose(report.reactions[name], ours[name], rtol=0, atol=1e-10 * np.linalg.norm(r_lower)), name
    assert np.allclose(r_lower + r_top + report.applied_load, 0.0, atol=1e-8 * np.linalg.norm(r_lower))
    M = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
    assert E * AREA * DELTA / HEIGHT <= r_lower[2] <= 1.1 * M * AREA * DELTA / HEIGHT, r_lower
