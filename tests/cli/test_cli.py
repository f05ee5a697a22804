"""The command line: outputs (XDMF fields, summary.json) and exit statuses, on 1 and 2 ranks."""

from __future__ import annotations

import json

from mpi4py import MPI

import h5py
import numpy as np
import pytest

from fenics_coulomb.cli import EXIT_DIVERGED, EXIT_INPUT, main
from fenics_coulomb.scd.forcing import terminal_forcing
from fenics_coulomb.scenes.cuboid import expected_sizes


def test_outputs(mpi_tmp_path, capsys):
    out = mpi_tmp_path / "run"
    status = main(["--lev", "2", "--gap", "d3", "--load", "L2", "--out", str(out), "--quiet"])
    assert status == 0
    comm = MPI.COMM_WORLD
    comm.barrier()
    summary = json.loads((out / "summary.json").read_text())
    p, n = expected_sizes(2)
    assert summary["n"] == n and summary["p"] == p
    assert summary["converged"] is True
    assert summary["newton_iterations"] == len(summary["residual_history"]) - 1 > 0
    assert summary["krylov_iterations"] == sum(summary["krylov_history"]) > 0
    assert summary["residual_history"][-1] <= summary["stopping_target"]
    assert summary["rtol"] == summary["settings"]["rtol"]
    assert sum(summary["state_counts"].values()) == p
    assert summary["wall_time_s"] > 0 and summary["ranks"] == comm.size
    with h5py.File(out / "solution.h5", "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        u = h5["Function/displacement/0"][:]
        state = h5["Function/contact_state/0"][:].ravel()
        pressure = h5["Function/contact_pressure/0"][:].ravel()
        tangential = h5["Function/tangential_force/0"][:]
    assert u.shape == x.shape and np.all(np.isfinite(u))
    assert np.all(u[np.isclose(x[:, 0], 0.0)] == 0.0)  # clamped face
    contact = state >= 0
    assert contact.sum() == p
    counts = {name: int(np.sum(state == code)) for code, name in enumerate(("open", "stick", "slip"))}
    assert counts == summary["state_counts"]
    assert np.all(pressure >= 0) and np.all(pressure[~contact] == 0) and np.all(pressure[state == 0] == 0)
    assert np.all(pressure[state > 0] > 0)
    assert np.all(tangential[:, 2] == 0) and np.all(tangential[~contact] == 0)
    # bottom nodes touching the obstacle end at x3 + u3 = 0
    touching = state > 0
    assert np.allclose(x[touching, 2] + u[touching, 2], 0.0, atol=1e-10)
    if comm.rank == 0:
        assert "converged" in capsys.readouterr().out
    # convergence.csv: one row per iterate, consistent with the summary
    rows = (out / "convergence.csv").read_text().strip().splitlines()
    assert rows[0].startswith("iteration,residual,relative_residual,step_length,krylov_iterations")
    table = [r.split(",") for r in rows[1:]]
    assert len(table) == summary["newton_iterations"] + 1
    assert np.allclose([float(r[1]) for r in table], summary["residual_history"], rtol=1e-15)
    assert [int(r[4]) for r in table[1:]] == summary["krylov_history"]
    assert [int(r[5]) + int(r[6]) + int(r[7]) for r in table[1:]] == [p] * (len(table) - 1)
    # the forcing term of each linear solve (the fixed tol by default) and the linear residual it reached
    assert summary["settings"]["adaptive_tol"] is False
    forcing = [float(r[8]) for r in table[1:]]
    history, target, tol = summary["residual_history"], summary["stopping_target"], summary["settings"]["tol"]
    expected = [terminal_forcing(tol, y, target) for y in history[:-1]]  # tol, tightened in the step that can end
    assert np.allclose(forcing, summary["forcing_history"], rtol=1e-6)
    assert np.allclose(forcing, expected, rtol=1e-5) and forcing[0] == tol
    assert all(0.0 <= float(r[9]) <= float(r[8]) for r in table[1:])
    for png in ("convergence.png", "contact_states.png", "deformed.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_no_plots(mpi_tmp_path):
    out = mpi_tmp_path / "noplots"
    assert main(["--lev", "0", "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    assert (out / "convergence.csv").exists() and not list(out.glob("*.png"))


@pytest.mark.parametrize(
    "args, message",
    [
        (["--friction", "-1"], "friction"),
        (["--friction", "nan"], "friction"),
        (["--young", "0"], "Young"),
        (["--young", "inf"], "young = inf"),
        (["--poisson", "0.5"], "Poisson"),
        (["--poisson", "-1.5"], "Poisson"),
        (["--lev", "-1"], "lev = -1"),
        (["--gap", "d7"], "d7"),
        (["--load", "L9"], "L9"),
        (["--load-scale", "nan"], "load_scale = nan"),
        (["--tol", "0"], "tol"),
        (["--rtol", "2"], "rtol"),
        (["--pc", "magic"], "magic"),
        (["--variant", "4c"], "4c"),
        (["--variant", "4b", "--pc", "hypre"], "hypre"),
        (["--galerkin-coarse"], "--galerkin-coarse"),
        (["--pc", "gamg-newton"], "gamg-newton"),
        (["--start", "somewhere"], "start"),
        (["-ksp_type", "cg"], "coulomb_"),
    ],
)
def test_bad_input(args, message, mpi_tmp_path, capsys):
    """Every bad value ends with one line naming it and exit status 2, on every rank."""
    status = main([*args, "--lev", "0", "--out", str(mpi_tmp_path)] if "--lev" not in args
                  else [*args, "--out", str(mpi_tmp_path)])
    assert status == EXIT_INPUT
    if MPI.COMM_WORLD.rank == 0:
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err


def test_unwritable_output(mpi_tmp_path, capsys):
    blocker = mpi_tmp_path / "file"
    if MPI.COMM_WORLD.rank == 0:
        blocker.write_text("not a directory")
    MPI.COMM_WORLD.barrier()
    assert main(["--lev", "0", "--out", str(blocker / "sub")]) == EXIT_INPUT
    if MPI.COMM_WORLD.rank == 0:
        assert "--out" in capsys.readouterr().err


def test_divergence_writes_last_iterate(mpi_tmp_path):
    """A solve stopped by the iteration limit exits 3 and still writes the iterate and its history."""
    out = mpi_tmp_path / "diverged"
    status = main(["--lev", "1", "--max-it", "2", "--out", str(out), "--quiet"])
    assert status == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False and summary["reason"] == "max_iterations"
    assert summary["newton_iterations"] == 2 and len(summary["residual_history"]) == 3
    assert (out / "solution.xdmf").exists() and (out / "solution.h5").exists()


def test_petsc_options_reach_the_ksp(mpi_tmp_path):
    """-coulomb_* options tune the Newton system's KSP (here a direct solve: one Krylov step each)."""
    out = mpi_tmp_path / "lu"
    pc = ["-coulomb_pc_type", "lu"]
    if MPI.COMM_WORLD.size > 1:
        pc += ["-coulomb_pc_factor_mat_solver_type", "mumps"]
    status = main(["--lev", "1", "--out", str(out), "--quiet", "--no-plots", "-coulomb_ksp_type", "preonly", *pc])
    from petsc4py import PETSc

    opts = PETSc.Options()
    for key in ("coulomb_ksp_type", "coulomb_pc_type", "coulomb_pc_factor_mat_solver_type"):
        opts.delValue(key)
    assert status == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["krylov_iterations"] == summary["newton_iterations"]
