"""Springs in the bilinear form (``k·inner(u, v)·ds``) as supports of a contact pair's body.

A body held by springs and by no Dirichlet condition was refused when it took part in a contact pair ("body 1 ...
has no boundary conditions that remove its rigid motions", InputError): the free rigid motions came from the
Dirichlet DOFs alone. The one-body case was mended before (tests/problems/test_rigid_approach.py). Checked here:
the upper block of the two-block pair held by a spring on its top face, pressed down and sideways, is accepted and
agrees with the independent Alart–Curnier solver (the same stiffness with its spring, the coupling from a pairing
computed in the test); the springs count as supports in the reaction balance; a spring too weak to hold any motion
above round-off is still refused.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import pytest
import ufl
from test_two_body import (LOWER_BOTTOM, MASTER, SLAVE, TIGHT, UPPER_TOP, assert_physics, elasticity, flat_coupling,
                           owned, prescribed, two_blocks)

from fenics_coulomb import ContactProblem
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.checks import physics_residuals, unconstrained_residual
from fenics_coulomb.model.pairs import ContactPair


def spring_held_blocks(comm: MPI.Comm, k: float, load=(0.002, 0.0, -0.05), young=(70.0, 70.0)):
    """The lower block clamped at its bottom; the upper block held by springs of stiffness ``k`` per area on its
    top face (no Dirichlet condition) and loaded there by the traction ``load``; ``young``: (lower, upper) E, ν 0.3:
    V, facet tags, a, L, bcs."""
    msh, ft = two_blocks(comm, lower=(5, 3, 2), upper=(4, 4, 3))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=ft)
    a = elasticity(V, young[0], 0.3, upper=(young[1], 0.3)) + k * ufl.inner(u, v) * ds(UPPER_TOP)
    L = ufl.inner(dolfinx.fem.Constant(msh, np.asarray(load, dtype=np.float64)), v) * ds(UPPER_TOP)
    bcs = [dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)]
    return V, ft, a, L, bcs


@pytest.mark.serial
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_a_pair_body_held_by_springs_agrees_with_brute_force(friction):
    """Accepted (no body held by contact alone); the SCD solve and the Alart–Curnier solver on K with the spring,
    the assembled load and the coupling of the vertical projection agree to 1e-7; the springs take the sideways
    load that friction does not, and the reaction balance counts them."""
    import scipy.sparse as sp
    from brute_force import solve_contact

    V, ft, a, L, bcs = spring_held_blocks(MPI.COMM_SELF, k=5.0)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=friction, method="node-to-surface")
    with ContactProblem(a, L, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="springs_",
                        sliding="small") as problem:
        model = problem.model
        assert model.coupling.held_by_contact == []
        _, result = problem.solve()
        assert result.converged
        assert_physics(problem, result)
        checks = physics_residuals(model, result.relative_displacement)
        assert checks["free_balance"] == 0.0 and checks["reaction_balance"] < 1e-8
        ip, ix, vals = model.A_free.getValuesCSR()
        K = sp.csr_matrix((vals, ix, ip), shape=model.A_free.getSize())
        load = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(L))
        f = load.getArray(readonly=True).copy()
        load.destroy()
        slave, G, gaps = flat_coupling(V, 1e-3)
        assert np.array_equal(slave, model.pairing.blocks)
        D, values = prescribed(V, bcs)
        sol = solve_contact(K, f, np.arange(3 * slave.size).reshape(-1, 3), gaps, friction, coupling=G,
                            dirichlet=(D, values))
        u = owned(problem)
        assert np.linalg.norm(sol.u - u) <= 1e-7 * np.linalg.norm(u)
        assert np.abs(sol.force - result.contact_force).max() <= 1e-7 * np.abs(sol.force).max()
        # the springs' resultant Σ K u (the elastic part sums to round-off): they carry load, so the support counts
        springs = unconstrained_residual(model, u).sum(axis=0) + f.reshape(-1, 3).sum(axis=0)
        assert np.linalg.norm(springs) > 1e-3 * np.linalg.norm(f.reshape(-1, 3).sum(axis=0))
        # the balance checks something: half the solution is far from it (it summed the residual over every node
        # and met the load for any u)
        assert physics_residuals(model, 0.5 * result.relative_displacement)["reaction_balance"] > 0.1


def test_a_pair_body_held_by_springs_on_ranks():
    """The same accepted on every rank count, converged with the physics checks passing (1 and 2 ranks)."""
    V, ft, a, L, bcs = spring_held_blocks(MPI.COMM_WORLD, k=5.0)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3)
    with ContactProblem(a, L, bcs, contact_pairs=[pair], petsc_options_prefix="springs_ranks_") as problem:
        assert problem.model.coupling.held_by_contact == []
        _, result = problem.solve()
        assert result.converged
        checks = problem.checks(result)
        assert checks["free_balance"] == 0.0 and checks["reaction_balance"] < 1e-6


@pytest.mark.parametrize("lower", [0.07, 7e3])
def test_a_soft_body_on_soft_springs_is_held_whatever_its_partner(lower):
    """The upper block E = 0.07 on springs k = 7e-5 (k/E = 1e-3) holds its motions whatever the lower block's
    stiffness: the threshold came from the mean diagonal of both bodies, so a lower block of E = 7000 raised it past
    the springs' energy and the upper block was refused. Each body's own diagonal now."""
    V, ft, a, L, bcs = spring_held_blocks(MPI.COMM_WORLD, k=7e-5, load=(0.0, 0.0, -5e-5), young=(lower, 0.07))
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3)
    with ContactProblem(a, L, bcs, contact_pairs=[pair], petsc_options_prefix="springs_soft_") as problem:
        assert problem.model.coupling.held_by_contact == []
        assert problem.solve()[1].converged


def test_a_spring_too_weak_to_hold_is_no_support():
    """Springs whose energy under a rigid motion is round-off of the stiffness (k = 1e-9 against E = 70) hold
    nothing: the upper block is refused as before, naming it."""
    V, ft, a, L, bcs = spring_held_blocks(MPI.COMM_WORLD, k=1e-9)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3)
    with pytest.raises(InputError, match="body 1 .* rigid motions"):
        ContactProblem(a, L, bcs, contact_pairs=[pair], petsc_options_prefix="springs_weak_")
