"""Per-node γᵢ (fenics_coulomb.scd.node_gamma): the method with Γ = diag(γᵢ) is the paper's method with
the scalar γ' = 1 on the diagonally scaled problem (D⁻¹AD⁻¹, D⁻¹l, D = Γ^{1/2}); it converges to the same
solution; the default keeps the paper's scalar γ on the Section 7 cuboid and caps it on graded meshes."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import assembled, gather_by_coordinates, make_problem
from frame_scd import paper_direction

from fenics_coulomb.scd.node_gamma import node_gamma
from fenics_coulomb.scd.resolvent import SET_L, SET_M1, SET_M3M, SET_M3P


@pytest.mark.serial
@pytest.mark.parametrize("variant", ["4a", "4b"])
def test_node_gamma_step_is_the_papers_step_on_the_scaled_problem(variant):
    rng = np.random.default_rng(7)
    problem = make_problem(1, "d3", "L2", comm=MPI.COMM_SELF, variant=variant, pc="lu")
    try:
        solver, data = problem.solver, assembled(problem)
        A, rhs = data["K"], problem.model.rhs.getArray(readonly=True).copy()
        contact = data["cdofs"][:, 0] // 3
        m = contact.size
        assert np.allclose(problem.model.contact.frames, np.eye(3))  # the plane x3 = 0: identity frames
        seen = set()
        for _ in range(6):
            gammas = solver.gamma * rng.uniform(0.05, 20.0, m)
            solver.set_node_gamma(gammas)
            u = problem.model.shift.getArray(readonly=True) + 0.02 * rng.normal(size=A.shape[0])
            u[data["dirichlet"]] = 0.0
            r = A @ u - rhs
            it = solver.approximation_step(u, r)
            du = solver.newton_direction(it, 1e-13).du
            # the scaled problem: γ on every DOF off the contact nodes, γᵢ on theirs; the paper's step with γ' = 1
            g = np.full(A.shape[0], solver.gamma)
            g[data["cdofs"]] = gammas[:, None]
            Dinv = sp.diags(1.0 / np.sqrt(g))
            du_s, e_s, v_s, z_s, sets = paper_direction((Dinv @ A @ Dinv).tocsr(), Dinv @ rhs, np.sqrt(g) * u,
                                                         contact, 1.0, problem.model.friction, variant)
            assert np.allclose(np.sqrt(g) * it.e, e_s, rtol=1e-10, atol=1e-14 * np.abs(e_s).max())
            assert np.allclose(np.sqrt(gammas)[:, None] * it.v, v_s, rtol=1e-10, atol=1e-14)
            assert np.linalg.norm(du - du_s / np.sqrt(g)) <= 1e-8 * np.linalg.norm(du)
            seen.update(sets.tolist())
        assert {SET_L, SET_M1} <= seen and seen & {SET_M3P, SET_M3M}, seen
    finally:
        problem.destroy()


def test_node_gamma_converges_to_the_same_solution(problem_factory):
    """Γ with a 100-fold spread of γᵢ and the scalar γ give the same displacement (to the solver's accuracy)."""
    rng = np.random.default_rng(3)
    solutions = []
    for spread in (None, 100.0):
        problem = problem_factory(2, "d2", "L2", rtol=1e-12)
        if spread:
            m = problem.solver.cdofs.shape[0]
            problem.solver.set_node_gamma(problem.solver.gamma / spread ** rng.uniform(0.0, 1.0, m))
        _, result = problem.solve()
        assert result.converged
        assert result.node_gamma[0] < result.node_gamma[1] or not spread
        solutions.append(gather_by_coordinates(problem.V, result.displacement)[1])
    assert np.linalg.norm(solutions[1] - solutions[0]) <= 1e-8 * np.linalg.norm(solutions[0])


@pytest.mark.parametrize("lev", [1, 4])
def test_default_keeps_the_papers_gamma_on_the_cuboid(lev):
    """On the Section 7 cuboid every contact node's cap 0.5·λ_max(Aᵢᵢ) lies above 0.01·λ_max(A) (by a factor
    of about 4): γᵢ = γ, the paper's formulas run unchanged."""
    problem = make_problem(lev, "d1", "L1")
    try:
        lo, hi = problem.solver._node_gamma_range()
        assert lo == hi == problem.solver.gamma
    finally:
        problem.destroy()


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_node_gamma_rule():
    """γᵢ = min(γ, κ·λ_max(Aᵢᵢ)) from the symmetric 3×3 blocks; None keeps γ."""
    rng = np.random.default_rng(0)
    G = rng.normal(size=(5, 3, 3))
    blocks = np.einsum("iab,icb->iac", G, G) + np.eye(3)
    lam = np.array([np.linalg.eigvalsh(b)[-1] for b in blocks])
    gamma = float(np.median(0.5 * lam))
    assert np.allclose(node_gamma(gamma, blocks, 0.5), np.minimum(gamma, 0.5 * lam))
    assert np.array_equal(node_gamma(gamma, blocks, None), np.full(5, gamma))
