"""An initial overlap of two bodies is an interference (1 and 2 ranks).

The brute force is the closed form of the two-body patch test (benchmarks/two_body_patch.py): two blocks of one
footprint on rollers, ν = 0, the upper one placed δ INTO the lower one (no load, its top held at u₃ = 0). The
uniaxial strain state that separates them is the one of a prescribed closure δ: the uniform contact pressure
p = δ/(H₁/M₁ + H₂/M₂). Dual mortar passes it to round-off on non-matching meshes, as it does for the pressed
blocks; the overlap is measured, logged and resolved, not refused.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

from benchmarks.two_body_patch import MATERIALS, elasticity, exact_pressure, rollers
from fenics_coulomb import ContactPair, ContactProblem
from fenics_coulomb.model.forces import contact_areas
from meshes.two_blocks import TAGS, two_blocks


@pytest.mark.parametrize(("cell", "n_upper"), [("hexahedron", (5, 5, 2)), ("tetrahedron", (5, 5, 2))])
def test_interference_of_two_blocks_is_the_patch_test(cell, n_upper):
    """Overlap δ = 1e-3: every slave node a contact node, the nodal pressures the closed form's to 1e-9, no
    tangential force, the separated state (no overlap left: every gap 0 within the solve's accuracy)."""
    comm = MPI.COMM_WORLD
    delta = 1e-3
    blocks = two_blocks(comm, lower=(1.0, 1.0, 0.5), n_lower=(4, 4, 2), upper_origin=(0.0, 0.0),
                        upper=(1.0, 1.0, 0.5), n_upper=n_upper, gap=-delta, cell_type=cell)
    V = dolfinx.fem.functionspace(blocks.mesh, ("Lagrange", 1, (3,)))
    pair = ContactPair(blocks.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], friction=0.3)
    with ContactProblem(elasticity(V, blocks.cell_tags, MATERIALS), None, rollers(V, blocks.facet_tags, 0.0),
                        contact_pairs=[pair], settings={"rtol": 1e-12, "tol": 1e-14},
                        petsc_options_prefix="interference_") as problem:
        _, result = problem.solve()
        assert result.converged
        model = problem.model
        assert result.p == (n_upper[0] + 1) * (n_upper[1] + 1)  # every slave node
        areas = contact_areas(model)
        areas[np.isfinite(model.pairing.area)] = model.pairing.area[np.isfinite(model.pairing.area)]
        p = exact_pressure(delta, MATERIALS)
        normal = np.einsum("ij,ij->i", result.contact_force, model.contact.normals)
        tangential = np.linalg.norm(result.contact_force - normal[:, None] * model.contact.normals, axis=1)
        error = comm.allreduce(float(np.abs(normal / areas / p - 1).max(initial=0.0)), op=MPI.MAX)
        slip = comm.allreduce(float((tangential / (p * areas)).max(initial=0.0)), op=MPI.MAX)
        gap = comm.allreduce(float(np.abs(result.gap).max(initial=0.0)), op=MPI.MAX)
    assert error <= 1e-9 and slip <= 1e-9
    assert gap <= 1e-9 * delta
