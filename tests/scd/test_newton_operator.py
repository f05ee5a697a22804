"""The matrix-free Newton operator M x = D(A x) + C x against the assembled Newton matrix."""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from conftest import gather_by_coordinates, solve_each

from fenics_coulomb.scd.newton_operator import NewtonOperator
from fenics_coulomb.scd.resolvent import classify


def _random_vec(A: PETSc.Mat, rng: np.random.Generator) -> PETSc.Vec:
    x = A.createVecRight()
    x.array[:] = rng.standard_normal(x.getLocalSize())
    return x


@pytest.mark.parametrize("variant", ["4a", "4b"])
def test_shell_equals_assembled_newton_matrix(variant, problem_factory):
    """mult and multTranspose of the shell equal those of the explicit matrix (rows from the solver's own
    blocks at the start iterate, and random blocks), to 1e-12 relative."""
    problem = problem_factory(2, "d3", "L2", pc="gamg", variant=variant)
    solver = problem.solver
    assert solver.operator.matrix_free and solver.M.getType() == "python"
    explicit = NewtonOperator(solver.A, solver.rows, solver.cdofs, False, "test_explicit_")
    assert explicit.M.getType() != "python"
    rng = np.random.default_rng(MPI.COMM_WORLD.rank)
    it = solver.start(None)
    sets = classify(it.v, it.z, solver.model.friction)
    m = solver.cdofs.shape[0]
    blocks = [solver.step.rows(it.v, it.z, sets, solver.model.friction, solver.gamma),
              (rng.standard_normal((m, 3, 3)), rng.standard_normal((m, 3, 3)))]
    assert MPI.COMM_WORLD.allreduce(m) > 0
    try:
        for left, right in blocks:
            solver.operator.update(left, right)
            explicit.update(left, right)
            for _ in range(3):
                x = _random_vec(solver.A, rng)
                y1, y2 = solver.A.createVecLeft(), solver.A.createVecLeft()
                for apply in ("mult", "multTranspose"):
                    getattr(solver.M, apply)(x, y1)
                    getattr(explicit.M, apply)(x, y2)
                    scale = y2.norm()
                    y1.axpy(-1.0, y2)
                    assert y1.norm() <= 1e-12 * scale, apply
                for v in (x, y1, y2):
                    v.destroy()
            if left is blocks[0][0]:
                continue
            # the random rows really differ from A's
            x = _random_vec(solver.A, rng)
            y1, y2 = solver.A.createVecLeft(), solver.A.createVecLeft()
            solver.M.mult(x, y1)
            solver.A.mult(x, y2)
            y1.axpy(-1.0, y2)
            assert y1.norm() > 1e-6 * y2.norm()
            for v in (x, y1, y2):
                v.destroy()
        solver.operator.set_stiffness()
        x = _random_vec(solver.A, rng)
        y1, y2 = solver.A.createVecLeft(), solver.A.createVecLeft()
        solver.M.mult(x, y1)
        solver.A.mult(x, y2)
        y1.axpy(-1.0, y2)
        assert y1.norm() <= 1e-14 * y2.norm()
        for v in (x, y1, y2):
            v.destroy()
    finally:
        explicit.destroy()


@pytest.mark.parametrize("pc, matrix_free", [("gamg", True), ("gamg", False), ("ilu", True), ("lu", True),
                                             ("hypre", True)])
def test_shell_only_when_the_preconditioner_is_built_on_A(pc, matrix_free, problem_factory):
    """The Newton matrix is a shell exactly when the preconditioner does not read it (and it is asked for)."""
    solver = problem_factory(1, "d3", "L2", pc=pc, matrix_free=matrix_free).solver
    shell = pc == "gamg" and matrix_free
    assert (solver.M.getType() == "python") == shell
    assert solver.M.getOptionsPrefix() == solver.prefix
    operators = solver.ksp.getOperators()
    assert operators[0].handle == solver.M.handle


@pytest.mark.parametrize("variant", ["4a", "4b"])
@pytest.mark.parametrize("lev", [2, 3])
def test_matrix_free_solve_equals_explicit(variant, lev, problem_factory):
    """With pc gamg the matrix-free and the explicit Newton matrix give the same solution (1e-8) and the same
    Newton and Krylov counts."""
    (_, free), (_, explicit) = solve_each(problem_factory, "matrix_free", (True, False), lev, "d3", "L2", pc="gamg",
                                          variant=variant, rtol=1e-12)
    assert free.iterations == explicit.iterations


@pytest.mark.parametrize("variant", ["4a", "4b"])
def test_nested_iteration_reaches_the_direct_solution(variant, problem_factory):
    """Solving lev 1 and 2 loosely and starting lev 3 from the interpolated solution gives the solution of
    the direct start (1e-7), with no more fine-level Newton steps."""
    from fenics_coulomb.scenes.nested import solve_nested

    direct = problem_factory(3, "d3", "L2", variant=variant, rtol=1e-12)
    _, ref = direct.solve()
    # LU on the coarse levels: 4b with block-Jacobi ILU stalls at lev 1 on 2 ranks (also without nesting)
    coarse = [problem_factory(lev, "d3", "L2", variant=variant, rtol=1e-4, pc="lu") for lev in (1, 2)]
    fine = problem_factory(3, "d3", "L2", variant=variant, rtol=1e-12)
    _, result, nested = solve_nested([*coarse, fine])
    assert ref.converged and result.converged and len(nested.levels) == 3
    # compare by coordinates: the two fine meshes may be partitioned differently on 2 ranks
    x1, u1 = gather_by_coordinates(direct.V, ref.displacement)
    x2, u2 = gather_by_coordinates(fine.V, result.displacement)
    assert np.allclose(x1, x2)
    assert np.linalg.norm(u2 - u1) <= 1e-7 * np.linalg.norm(u1)
    assert result.counts == ref.counts
    assert result.iterations <= ref.iterations


def test_cli_nested_and_matrix_free_flags(mpi_tmp_path):
    """The command line's --nested 1 (lev 1 first) and --no-matrix-free reach the solution of the plain run
    (1e-7), and a --nested whose coarsest level would be below lev 0 is rejected with exit 2."""
    from conftest import read_solution

    from fenics_coulomb.cli import EXIT_INPUT, main

    common = ["--lev", "3", "--pc", "gamg", "--rtol", "1e-12", "--quiet", "--no-plots"]
    assert main([*common, "--out", str(mpi_tmp_path / "plain")]) == 0
    assert main([*common, "--nested", "1", "--no-matrix-free", "--out", str(mpi_tmp_path / "nested")]) == 0
    if MPI.COMM_WORLD.rank == 0:
        x1, u1 = read_solution(mpi_tmp_path / "plain")
        x2, u2 = read_solution(mpi_tmp_path / "nested")
        assert np.allclose(x1, x2)
        assert np.linalg.norm(u1 - u2) <= 1e-7 * np.linalg.norm(u1)
    assert main(["--lev", "1", "--nested", "1", "--out", str(mpi_tmp_path / "bad")]) == EXIT_INPUT


@pytest.mark.parametrize("variant", ["4a", "4b"])
def test_matrix_free_sees_the_obstacle_frames(variant, problem_factory):
    """A sphere indenting the body beside a tilted floor (non-identity per-node frames, rotated blocks
    R B Rᵀ / R C Rᵀ): the matrix-free shell and the explicit rows give the same solution (1e-8) and the same
    Newton iterations, and the sphere carries part of the load."""
    import dataclasses

    from fenics_coulomb.scenes.scene import Scene
    from fenics_coulomb.model.obstacles import Plane, Sphere

    obstacles = [Sphere(center=[1.0, 0.5, -10.0], radius=10.0, displacement=[0.002, 0.001, 0.012]),
                 Plane(point=[0.0, 0.0, -0.01], normal=[0.01, -0.005, 1.0], name="floor")]
    results, solutions = [], []
    for matrix_free in (True, False):
        scene = Scene().override(lev=2, gap="d3", load="L2", pc="gamg", variant=variant, rtol=1e-12,
                                 matrix_free=matrix_free)
        problem = problem_factory(scene=dataclasses.replace(scene, obstacles=obstacles))
        assert (problem.solver.M.getType() == "python") == matrix_free
        _, result = problem.solve()
        assert result.converged
        sphere = problem.model.contact.obstacle_index == 0
        assert MPI.COMM_WORLD.allreduce(float(result.normal_force[sphere].sum()), op=MPI.SUM) > 0.0
        results.append(result)
        solutions.append(gather_by_coordinates(problem.V, result.displacement))
    (x1, u1), (x2, u2) = solutions
    assert np.allclose(x1, x2)
    assert np.linalg.norm(u1 - u2) <= 1e-8 * np.linalg.norm(u2)
    assert results[0].iterations == results[1].iterations
