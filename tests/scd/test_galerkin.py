"""GAMG's coarse operators that follow the Newton matrix (fenics_coulomb.scd.galerkin): the in-place surface update
against PETSc's full Galerkin products of the explicit Newton matrix, the row scaling, and the solution."""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from conftest import matrix_difference, solve_each

from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.errors import InputError
from fenics_coulomb.scd.galerkin import row_scaling
from fenics_coulomb.scd.newton_operator import NewtonOperator
from fenics_coulomb.model.frames import conjugate
from fenics_coulomb.scd.resolvent import classify
from fenics_coulomb.settings import SolverSettings


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
    return matrix_difference(X, Y)


def test_coarse_operators_are_the_galerkin_products_of_the_newton_matrix(problem_factory):
    """After every update (the solver's blocks at the start, random blocks, the solver's again, and A's) each
    coarse operator equals PETSc's full PtAP chain of the explicit Newton matrix on the same prolongators
    (1e-12), and the random rows make them differ from A's (> 1e-6)."""
    problem = problem_factory(4, "d3", "L2", pc="gamg", galerkin_coarse=True)
    solver = problem.solver
    assert solver._galerkin is not None
    diagonal = solver.A.getDiagonal()  # the scaling's aᵢ, read off ContactRows, against A's own diagonal
    assert np.allclose(solver._galerkin.diagonal, diagonal.getArray(readonly=True)[solver.cdofs].mean(axis=1),
                       rtol=1e-15, atol=0.0)
    diagonal.destroy()
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


@pytest.mark.serial  # rank-local (docs/testing.md)
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
    it satisfies equilibrium, Signorini, complementarity, the Coulomb cone and friction against the slip, and the
    update reaches it with fewer Krylov iterations."""
    (problem, galerkin), (_, plain) = solve_each(problem_factory, "galerkin_coarse", (True, False), 4, "d3", "L2",
                                                 pc="gamg", rtol=1e-12, friction=friction)
    assert problem.solver._galerkin is not None
    checks = physics_residuals(problem.model, galerkin.displacement)
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "reaction_balance"):
        assert checks[key] < 1e-9, (key, checks[key])
    assert checks["slip_direction"] < 1e-6
    assert galerkin.krylov_iterations < plain.krylov_iterations


def test_coarse_update_only_where_it_applies(problem_factory):
    """pc = "auto" takes the update exactly when it chooses GAMG (ILU on a small hexahedral mesh on 1 and 2
    ranks, GAMG from 3 on), and it is off by default."""
    solver = problem_factory(2, "d3", "L2", pc="auto", galerkin_coarse=True).solver
    assert solver.pc == ("gamg" if MPI.COMM_WORLD.size > 2 else "ilu")
    assert (solver._galerkin is not None) == (solver.pc == "gamg")
    assert problem_factory(2, "d3", "L2", pc="gamg").solver._galerkin is None


@pytest.mark.parametrize("pc, variant", [("ilu", "4a"), ("gamg-newton", "4a"), ("gamg", "4b"), ("lu", "4a")])
def test_coarse_update_rejected_where_it_cannot_apply(pc, variant):
    """Asking for the update with another preconditioner or with variant 4b is an InputError naming both."""
    with pytest.raises(InputError, match=f"pc = '{pc}' with variant '{variant}'"):
        SolverSettings(pc=pc, variant=variant, galerkin_coarse=True).validate()
