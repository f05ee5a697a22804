"""GAMG's coarse operators that follow the Newton matrix (fenics_coulomb.galerkin): the in-place surface update
against PETSc's full Galerkin products of the explicit Newton matrix, the row scaling, and the solution."""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from conftest import gather_by_coordinates

from fenics_coulomb.galerkin import row_scaling
from fenics_coulomb.newton_operator import NewtonOperator
from fenics_coulomb.obstacles import conjugate
from fenics_coulomb.resolvent import classify


def _levels(pc: PETSc.PC) -> list[PETSc.Mat]:
    return [pc.getMGSmoother(level).getOperators()[0] for level in range(pc.getMGLevels() - 1)]


def _galerkin_chain(pc: PETSc.PC, fine: PETSc.Mat) -> list[PETSc.Mat]:
    """P_lᵀ ... P_{L−1}ᵀ fine P_{L−1} ... P_l for every coarse level l (coarsest first), by full PtAP."""
    products = []
    for level in range(pc.getMGLevels() - 1, 0, -1):
        fine = fine.ptap(pc.getMGInterpolation(level))
        products.append(fine)
    return products[::-1]


def _relative_difference(X: PETSc.Mat, Y: PETSc.Mat) -> float:
    D = X.copy()
    D.axpy(-1.0, Y, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    value = D.norm(PETSc.NormType.FROBENIUS) / Y.norm(PETSc.NormType.FROBENIUS)
    D.destroy()
    return value


def test_coarse_operators_are_the_galerkin_products_of_the_newton_matrix(problem_factory):
    """After every update (the solver's blocks at the start, random blocks, the solver's again, and A's) each
    coarse operator equals PETSc's full PtAP chain of the explicit Newton matrix on the same prolongators
    (1e-12), and the random rows make them differ from A's (> 1e-6)."""
    problem = problem_factory(4, "d3", "L2", pc="gamg", galerkin_coarse=True)
    solver = problem.solver
    assert solver._galerkin is not None
    with solver.petsc_options():
        solver.ksp.setUp()
    pc = solver.ksp.getPC()
    assert pc.getMGLevels() >= 3  # a deeper level than the surface product is exercised
    of_A = [op.copy() for op in _levels(pc)]
    explicit = NewtonOperator(solver.A, solver.rows, solver.cdofs, False, "test_galerkin_")
    rng = np.random.default_rng(17 + MPI.COMM_WORLD.rank)
    it = solver.start(None)
    sets = classify(it.v, it.z, solver.model.friction)
    m = solver.cdofs.shape[0]
    assert MPI.COMM_WORLD.allreduce(m) > 0
    own = solver.step.rows(it.v, it.z, sets, solver.model.friction, solver.gamma)
    own = conjugate(solver.frames, own[0]), conjugate(solver.frames, own[1])
    random = rng.standard_normal((m, 3, 3)), rng.standard_normal((m, 3, 3))
    identity = np.broadcast_to(np.eye(3), (m, 3, 3)).copy(), np.zeros((m, 3, 3))
    try:
        for left, right in (own, random, own, random, identity):
            solver._galerkin.update(pc, left, right)
            explicit.update(left, right)
            expected = _galerkin_chain(pc, explicit.M)
            for op, ref in zip(_levels(pc), expected, strict=True):
                assert _relative_difference(op, ref) <= 1e-12
            if left is random[0]:
                assert _relative_difference(_levels(pc)[-1], of_A[-1]) > 1e-6
            for ref in expected:
                ref.destroy()
        for op, ref in zip(_levels(pc), of_A, strict=True):  # back to A's hierarchy
            assert _relative_difference(op, ref) <= 1e-12
    finally:
        explicit.destroy()
        for op in of_A:
            op.destroy()


def test_row_scaling_gives_the_rows_the_size_of_the_diagonal():
    """Open rows keep their size, constrained rows (stick, the normal row of a slip) are scaled by a/γ, and a
    sliding node's tangential rows by a/(a C_jj + γ b P_jj): the scaled row's diagonal is a on every row."""
    gamma, a = 0.05, np.array([2.0, 3.0, 4.0])
    slip_n = np.array([0.6, 0.8])
    sa, sb = 0.3, 0.7
    C = sa * np.eye(2) + sb * np.outer(slip_n, slip_n)
    P = np.eye(2) - np.outer(slip_n, slip_n)
    left = np.zeros((3, 3, 3))
    right = np.zeros((3, 3, 3))
    left[0] = np.eye(3)                                   # open
    right[1] = gamma * np.eye(3)                          # stick
    left[2, :2, :2] = C                                   # slip (rows of W*ᵀ, γ U*ᵀ)
    left[2, :2, 2] = 0.23 * slip_n
    right[2, :2, :2] = gamma * sb * P
    right[2, 2, 2] = gamma
    s = row_scaling(left, right, a)
    assert np.allclose(s[0], 1.0)
    assert np.allclose(s[1], a[1] / gamma)
    expected = a[2] / (a[2] * np.diag(C) + gamma * sb * np.diag(P))
    assert np.allclose(s[2, :2], expected) and np.isclose(s[2, 2], a[2] / gamma)
    diag = a[:, None] * np.einsum("ijj->ij", left) + np.einsum("ijj->ij", right)
    assert np.allclose(s * diag, a[:, None])


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_galerkin_coarse_solution_equals_the_plain_gamg_solution(friction, problem_factory):
    """With and without the coarse update (and its row scaling) the solution is the same (1e-8 at rtol 1e-12),
    and the update reaches it with fewer Krylov iterations."""
    results, solutions = [], []
    for galerkin in (True, False):
        problem = problem_factory(4, "d3", "L2", pc="gamg", rtol=1e-12, friction=friction,
                                  galerkin_coarse=galerkin)
        assert (problem.solver._galerkin is not None) == galerkin
        _, result = problem.solve()
        assert result.converged
        results.append(result)
        solutions.append(gather_by_coordinates(problem.V, result.displacement))
    (x1, u1), (x2, u2) = solutions
    assert np.allclose(x1, x2)
    assert np.linalg.norm(u1 - u2) <= 1e-8 * np.linalg.norm(u2)
    assert results[0].krylov_iterations < results[1].krylov_iterations


@pytest.mark.parametrize("pc, variant", [("ilu", "4a"), ("gamg-newton", "4a"), ("gamg", "4b"), ("lu", "4a")])
def test_no_coarse_update_where_it_does_not_apply(pc, variant, problem_factory):
    """Only GAMG on A with variant 4a gets the coarse update (and the row scaling), and only when asked."""
    assert problem_factory(2, "d3", "L2", pc=pc, variant=variant, galerkin_coarse=True).solver._galerkin is None
    assert problem_factory(2, "d3", "L2", pc="gamg").solver._galerkin is None  # off by default
