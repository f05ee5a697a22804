"""Stability at the extremes: converge to a solution that passes the physics checks, or stop with a reason;
never NaN, never a hang, never a plausible-looking wrong field."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest
from conftest import global_norm, make_problem

from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.cli import EXIT_DIVERGED, EXIT_INPUT, main
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.scd.stopping import ROUNDOFF_FACTOR

REASONS = {"max_iterations", "line_search", "ksp_breakdown", "non_finite"}
CHECK_TOL = {"equilibrium": 1e-8, "penetration": 1e-8, "negative_pressure": 1e-8, "complementarity": 1e-8,
             "cone": 1e-8, "reaction_balance": 1e-8}


def attempt(scene: Scene):
    """Solve a scene through the API; return (problem, result), converged or not (the caller destroys)."""
    problem = make_problem(scene=scene)
    u0 = dolfinx.fem.Function(problem.V) if scene.start == "undeformed" else None
    try:
        _, result = problem.solve(u0)
    except SolverError as err:
        result = err.result
        assert err.reason in REASONS and str(err)
    assert np.all(np.isfinite(result.displacement)) and np.all(np.isfinite(result.residual_history))
    return problem, result


def roundoff_equilibrium(model) -> float:
    """The equilibrium residual (relative to max |l̃|) that round-off alone leaves in ũ = u − d.

    The solver iterates on the shifted unknown u = ũ + d and stops at ‖ŷ‖ ≈ stopping.ROUNDOFF_FACTOR·ε·(its
    scales) at the latest, so ũ carries an error of that order relative to the gaps d: the free rows of A ũ − l̃
    then show about ROUNDOFF_FACTOR·ε·max|A d| of it. Against max |l̃| this only matters when the load is tiny
    compared with the forces the gaps represent (load_scale = 1e-6: max|A d| / max|l̃| ≈ 1e6).
    """
    comm = MPI.COMM_WORLD
    Ad = model.A.createVecLeft()
    model.A.mult(model.shift, Ad)
    shift_force = comm.allreduce(float(np.max(np.abs(Ad.array), initial=0.0)), op=MPI.MAX)
    load = comm.allreduce(float(np.max(np.abs(model.load.array), initial=0.0)), op=MPI.MAX)
    Ad.destroy()
    return ROUNDOFF_FACTOR * np.finfo(np.float64).eps * shift_force / max(load, np.finfo(np.float64).tiny)


def assert_converged_or_explained(problem, result):
    if result.converged:
        checks = physics_residuals(problem.model, result.displacement)
        for key, tol in CHECK_TOL.items():
            bound = max(tol, roundoff_equilibrium(problem.model)) if key == "equilibrium" else tol
            assert checks[key] < bound, (key, checks[key], bound)
    else:
        assert result.reason in REASONS


BASE = Scene().override(lev=2, gap="d3", load="L2", rtol=1e-12)


@pytest.mark.parametrize(
    "overrides",
    [{"friction": 0.0}, {"friction": 1e-6}, {"friction": 1.0}, {"friction": 5.0}, {"poisson": 0.0},
     {"poisson": 0.49}, {"poisson": 0.499}, {"load_scale": 1e-6}, {"load_scale": 10.0}, {"gap": "0"},
     {"young": 1e-3}, {"young": 1e3}, {"lev": 0}, {"tol": 0.5}, {"variant": "4b", "friction": 1.0}],
    ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()),
)
def test_converges_or_explains(overrides):
    model, result = attempt(BASE.override(**overrides))
    assert_converged_or_explained(model, result)
    model.destroy()


def test_small_friction_approaches_frictionless():
    """F = 1e-6 is a tiny perturbation of F = 0 (continuity in F), not a different regime."""
    m0, r0 = attempt(BASE.override(friction=0.0))
    m1, r1 = attempt(BASE.override(friction=1e-6))
    assert global_norm(r0.displacement - r1.displacement) <= 1e-4 * global_norm(r0.displacement)
    m0.destroy()
    m1.destroy()


def test_scale_free():
    """Scaling E and the loads by the same factor leaves ũ and the iteration unchanged (γ, tolerances and the
    line search are relative), for factors 1e-3 … 1e3 around E = 70 GPa."""
    ref_model, ref = attempt(BASE)
    comm = MPI.COMM_WORLD
    for factor in (1e-3, 1e3):
        model, res = attempt(BASE.override(young=70.0 * factor, load_scale=factor))
        assert res.converged and res.iterations == ref.iterations
        assert global_norm(res.displacement - ref.displacement) <= 1e-8 * global_norm(ref.displacement)
        assert res.state_counts(comm) == ref.state_counts(comm)
        model.destroy()
    ref_model.destroy()


def test_zero_and_pulling_loads():
    model, result = attempt(BASE.override(load_scale=0.0, start="undeformed"))
    assert result.converged and result.iterations == 0 and np.all(result.displacement == 0.0)
    model.destroy()
    model, result = attempt(BASE.override(load_scale=-1.0, start="undeformed"))
    assert result.converged
    assert result.state_counts(MPI.COMM_WORLD) == {"open": model.p, "stick": 0, "slip": 0}
    assert np.all(result.normal_force == 0.0)
    model.destroy()


def test_touching_everywhere_start():
    """d ≡ 0: every bottom node touches the plane initially; the solution keeps gap ≥ 0 and passes the checks."""
    model, result = attempt(BASE.override(gap="0"))
    assert result.converged
    assert_converged_or_explained(model, result)
    model.destroy()


def test_line_search_exhausted_exits_3(mpi_tmp_path, capsys):
    """With only the full step allowed and the paper's γ (about λ_max(A) = 82 at lev 2, fixed: no per-node cap), a
    full step is soon rejected: exit 3 naming the line search, with the last iterate and the history written."""
    out = mpi_tmp_path / "ls"
    scene = mpi_tmp_path / "ls.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene.write_text("[body]\nlev = 2\n[solver]\ngamma = 80.0\nline_search_steps = 1\n")
    MPI.COMM_WORLD.barrier()
    assert main(["--scene", str(scene), "--out", str(out), "--no-plots"]) == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reason"] == "line_search" and not summary["converged"]
    assert len(summary["residual_history"]) == summary["newton_iterations"] + 1
    assert (out / "solution.h5").exists() and (out / "convergence.csv").exists()
    if MPI.COMM_WORLD.rank == 0:
        assert "line search found no acceptable step" in capsys.readouterr().err


def test_bad_solver_setting_in_scene(mpi_tmp_path):
    scene = mpi_tmp_path / "bad.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene.write_text("[solver]\nline_search_steps = 0\n")
    MPI.COMM_WORLD.barrier()
    with pytest.raises(InputError, match="line_search_steps = 0"):
        Scene.from_toml(scene)


def test_non_finite_linear_solve_exits_3(mpi_tmp_path, capsys):
    """A linear solver that produces inf/NaN stops the solve with exit 3 naming the KSP, outputs written."""
    out = mpi_tmp_path / "nan"
    opts = ["-coulomb_ksp_type", "richardson", "-coulomb_ksp_richardson_scale", "1e308", "-coulomb_pc_type", "none",
            "-coulomb_ksp_max_it", "5", "-coulomb_ksp_norm_type", "none", "-coulomb_ksp_pc_side", "left"]
    status = main(["--lev", "1", "--out", str(out), "--no-plots", *opts])
    from petsc4py import PETSc

    for key in ("coulomb_ksp_type", "coulomb_ksp_richardson_scale", "coulomb_pc_type", "coulomb_ksp_max_it",
                "coulomb_ksp_norm_type", "coulomb_ksp_pc_side"):
        PETSc.Options().delValue(key)
    assert status == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reason"] in ("ksp_breakdown", "non_finite") and not summary["converged"]
    if MPI.COMM_WORLD.rank == 0:
        assert "linear solver" in capsys.readouterr().err


@pytest.mark.serial
@pytest.mark.multirank
def test_exception_on_one_rank_ends_all_ranks(tmp_path):
    """An unexpected exception on rank 1 of 2 ends both ranks with the message (no hang)."""
    script = tmp_path / "fail.py"
    script.write_text(textwrap.dedent("""
        from mpi4py import MPI
        import fenics_coulomb.cli as cli
        real = cli.run
        def run(args, comm):
            if comm.rank == 1:
                raise RuntimeError("injected failure on rank 1")
            return real(args, comm)  # rank 0 enters the collective solve and would wait forever
        cli.run = run
        raise SystemExit(cli.main(["--lev", "2", "--out", "%s", "--quiet"]))
    """ % (tmp_path / "out")))
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX", "PRTE_"))}
    proc = subprocess.run(["mpirun", "-n", "2", sys.executable, str(script)], capture_output=True, text=True,
                          timeout=120, env=env)
    assert proc.returncode != 0
    assert "injected failure on rank 1" in proc.stderr + proc.stdout


def test_petsc_options_the_solver_cannot_use_exit_2(mpi_tmp_path, capsys):
    """A KSP chosen on the command line that cannot work as the solver's (here: Richardson cannot monitor the
    unpreconditioned residual with right preconditioning) is refused before any work: exit 2 with PETSc's
    reason in one line, no traceback (it used to fail inside the first Newton step with exit 3)."""
    out = mpi_tmp_path / "refused"
    status = main(["--lev", "1", "--out", str(out), "--no-plots", "-coulomb_ksp_type", "richardson"])
    from petsc4py import PETSc

    assert not PETSc.Options().hasName("coulomb_ksp_type")  # a refused option does not stay behind
    assert status == EXIT_INPUT
    assert not (out / "summary.json").exists()
    if MPI.COMM_WORLD.rank == 0:
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "does not support norm type" in err[0] and "Traceback" not in err[0]
