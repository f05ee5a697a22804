"""Load paths on the command line (issue 14): ``[[path.step]]`` scenes, ``--steps N``, ``--start-step K``.

The in-process tests (``main([...])``) run on 1 rank and on 2 ranks; the real-command test starts
``mpirun -n 2 python3 -m fenics_coulomb`` as a user does and compares it with 1 rank.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np
import pytest

from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.cli import EXIT_DIVERGED, EXIT_INPUT, main
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.scenes.path import obstacle_labels, plan, run_path
from fenics_coulomb.scenes.cuboid import expected_sizes

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "demos" / "scenes" / "d3_L2_path.toml"
PROG = "python3 -m fenics_coulomb"
FIELDS = {"displacement", "contact_state", "contact_pressure", "contact_force", "tangential_force", "stress",
          "von_mises", "contact_traction", "gap",
          "contact_normal"}
#: The demo's solves: step 1 in 3 substeps, steps 2 and 3 in 2 each.
DEMO_TIMES = [1 / 3, 2 / 3, 1.0, 1.5, 2.0, 2.5, 3.0]


def run(*args: str) -> int:
    status = main([*args, "--quiet"])
    MPI.COMM_WORLD.barrier()
    return status


@pytest.fixture(scope="module")
def demo_path_run() -> Iterator[Path]:
    """The demo path at lev 2 (``--scene DEMO --lev 2``, plots included), run once on this communicator for the
    tests that check it, resume from it and compare the real 2-rank command with it; its directory is shared by
    all ranks and removed after the module."""
    comm = MPI.COMM_WORLD
    path = tempfile.mkdtemp(prefix="fenics-coulomb-path-") if comm.rank == 0 else None
    path = Path(comm.bcast(path, root=0))
    out = path / "path"
    assert run("--scene", str(DEMO), "--lev", "2", "--out", str(out)) == 0
    yield out
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


def shared_file(path: Path, text: str) -> Path:
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    return path


def grids(out: Path) -> list[ET.Element]:
    root = ET.parse(out / "solution.xdmf").getroot()
    return root.findall("Domain/Grid/Grid")


def displacement(out: Path, k: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """(vertex coordinates, displacement of the k-th grid), rows sorted by the coordinates (rank-independent)."""
    with h5py.File(out / "solution.h5", "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        names = sorted(h5["Function/displacement"], key=int)
        u = h5[f"Function/displacement/{names[k]}"][:]
    order = np.lexsort(np.round(x, 12).T[::-1])
    return x[order], u[order]


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), np.finfo(float).tiny))


def test_demo_path(demo_path_run, mpi_tmp_path):
    """The demo path: every solve is a grid with all fields at time = its step number, path.csv and summary
    agree, each step's contact force and reactions balance its applied load, the counts cover p."""
    out = demo_path_run
    summary = json.loads((out / "summary.json").read_text())
    p = expected_sizes(2)[0]
    steps = summary["steps"]
    assert summary["converged"] is True and summary["path"]["solves"] == len(steps) == 7
    assert [s["time"] for s in steps] == pytest.approx(DEMO_TIMES, abs=1e-15)
    assert [s["step"] for s in steps] == [1, 1, 1, 2, 2, 3, 3]
    # the XDMF: the unloaded body at t = 0, then one grid per solve, time = the step number, every field in
    # every grid
    times = [float(g.find("Time").get("Value")) for g in grids(out)]
    assert times == pytest.approx([0.0, *DEMO_TIMES], abs=1e-15)
    assert grids(out)[0].get("Name") == "initial state"
    assert not np.any(displacement(out, 0)[1])
    with h5py.File(out / "solution.h5", "r") as h5:
        for field in FIELDS:
            assert sorted(h5[f"Function/{field}"], key=int) == [str(i) for i in range(8)], field
        first = sorted(h5["Function/contact_state"], key=int)[0]
        assert set(np.unique(h5[f"Function/contact_state/{first}"][:])) <= {-1, 0}  # nothing touches yet
        assert not np.any(h5[f"Function/contact_pressure/{first}"][:])
    for g in grids(out):
        assert {a.get("Name") for a in g.findall("Attribute")} == FIELDS
    # path.csv = summary steps
    rows = (out / "path.csv").read_text().strip().splitlines()
    header = rows[0].split(",")
    table = [dict(zip(header, r.split(","), strict=True)) for r in rows[1:]]
    assert len(table) == 7
    for row, s in zip(table, steps, strict=True):
        assert float(row["time"]) == s["time"] and int(row["newton_iterations"]) == s["newton_iterations"] > 0
        assert [float(row[f"contact_force_{c} [GPa*L^2]"]) for c in "xyz"] == s["contact_force"]
        assert [float(row[f"reaction_left_{c} [GPa*L^2]"]) for c in "xyz"] == s["reactions"]["left"]
        assert sum(s["state_counts"].values()) == p
        assert int(row["open"]) + int(row["stick"]) + int(row["slip"]) == p
        # global balance of the step: contact force + reactions + applied load = 0
        applied = np.asarray(s["applied_load"])
        total = np.asarray(s["contact_force"]) + np.asarray(s["reactions"]["left"]) + applied
        assert np.linalg.norm(total) <= 1e-8 * np.linalg.norm(applied)
    # the applied load follows the path: L2 (top [0, 0, -1] on area 2, right [-0.17, -0.1, 0]) at t = 1 and 3,
    # a third of it at t = 1/3, the side load reversed at t = 2 and gone half-way (t = 1.5, 2.5)
    applied = {s["time"]: np.asarray(s["applied_load"]) for s in steps}
    l2 = applied[1.0]
    assert l2[2] == pytest.approx(-2.0, rel=1e-12) and l2[1] / l2[0] == pytest.approx(0.1 / 0.17, rel=1e-12)
    assert np.allclose(3 * applied[DEMO_TIMES[0]], l2, rtol=1e-12, atol=0)
    assert np.allclose(applied[2.0], l2 * [-1, -1, 1], rtol=1e-12, atol=0)
    assert np.allclose(applied[1.5], l2 * [0, 0, 1], rtol=1e-12, atol=1e-15)
    assert np.allclose(applied[3.0], l2, rtol=1e-12, atol=0)
    # the static solve of the final load differs: friction remembers the reversal (residual slip)
    static = mpi_tmp_path / "static"
    assert run("--scene", str(ROOT / "demos/scenes/d3_L2.toml"), "--lev", "2", "--rtol", "1e-10",
               "--no-plots", "--out", str(static)) == 0
    assert relative(displacement(out)[1], displacement(static)[1]) > 1e-3
    # ... but the path's first step end (the same load from 0 in 3 increments) is close to it
    assert relative(displacement(out, 3)[1], displacement(static)[1]) < 1e-1  # grid 0 is t = 0


def test_steps_one_is_the_static_solve(mpi_tmp_path):
    """--steps 1 is the static solve (1e-10)."""
    one, static = mpi_tmp_path / "one", mpi_tmp_path / "static"
    assert run("--lev", "2", "--steps", "1", "--no-plots", "--out", str(one)) == 0
    assert run("--lev", "2", "--no-plots", "--out", str(static)) == 0
    x1, u1 = displacement(one)
    x0, u0 = displacement(static)
    assert np.array_equal(x1, x0) and relative(u1, u0) <= 1e-10
    assert [float(g.find("Time").get("Value")) for g in grids(one)] == [0.0, 1.0]


def test_each_step_shows_its_newton_progress(mpi_tmp_path, capsys):
    """Without -v a load path prints every solve's Newton lines (its target first), not only one line per step."""
    assert main(["--lev", "2", "--steps", "2", "--out", str(mpi_tmp_path / "progress"), "--no-plots"]) == 0
    if MPI.COMM_WORLD.rank == 0:
        err = capsys.readouterr().err
        assert err.count("SCD semismooth* Newton") == 2 and err.count("stops at |y| <=") == 2
        assert "it   1  |y|/|y0|" in err


def test_frictionless_end_does_not_depend_on_the_steps(mpi_tmp_path):
    """F = 0: --steps 3 ends where the static solve is (1e-8); with F > 0 it differs (the load's history)."""
    tight = ("--lev", "2", "--rtol", "1e-12", "--tol", "1e-6", "--no-plots")
    outs = {}
    for name, extra in {"steps": ("--steps", "3"), "static": ()}.items():
        for friction in ("0", "0.23"):
            outs[name, friction] = mpi_tmp_path / f"{name}{friction}"
            assert run(*tight, "--friction", friction, *extra, "--out", str(outs[name, friction])) == 0
    assert relative(displacement(outs["steps", "0"])[1], displacement(outs["static", "0"])[1]) <= 1e-8
    assert relative(displacement(outs["steps", "0.23"])[1], displacement(outs["static", "0.23"])[1]) > 1e-6
    summary = json.loads((outs["steps", "0"] / "summary.json").read_text())
    assert [s["load_factor"] for s in summary["steps"]] == pytest.approx([1 / 3, 2 / 3, 1.0], abs=1e-15)


FAILING = """
[body]
lev = 2
gap = "d3"
[load]
case = "L2"
[[path.step]]           # lifted off: the predictor's one linear solve is the solution
tractions = { top = [0, 0, 0.01], right = [0, 0, 0] }
[[path.step]]           # the paper's load: needs more Newton steps than --max-it allows
"""


def test_failed_step_exits_3_keeping_the_completed_steps(mpi_tmp_path, capsys):
    scene = shared_file(mpi_tmp_path / "failing.toml", FAILING)
    out = mpi_tmp_path / "failed"
    assert main(["--scene", str(scene), "--predictor", "--max-it", "3", "--no-plots", "--out", str(out)]) \
        == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False and "3 Newton iterations" in summary["reason"]
    assert [s["converged"] for s in summary["steps"]] == [True, False]
    assert summary["path"]["completed"] == 1
    names = [g.get("Name") for g in grids(out)]
    assert names[0] == "initial state" and names[1] == "step 1"
    assert names[2].startswith("step 2: last iterate (NOT converged")
    info = {i.get("Name"): i.get("Value") for i in grids(out)[2].findall("Information")}
    assert info["converged"] == "false"
    assert len((out / "path.csv").read_text().strip().splitlines()) == 3
    _, u = displacement(out, 1)
    assert np.all(np.isfinite(u)) and np.abs(u).max() > 0
    if MPI.COMM_WORLD.rank == 0:
        err = capsys.readouterr().err
        assert "step 2 of the load path did not converge" in err


def test_resume_reproduces_the_path(demo_path_run, mpi_tmp_path):
    """--start FILE --start-step K solves K+1..N from step K of an earlier path: the same states (1e-8)."""
    full, resumed = demo_path_run, mpi_tmp_path / "resumed"
    common = ("--scene", str(DEMO), "--lev", "2", "--no-plots")
    assert run(*common, "--start", str(full / "solution.xdmf"), "--start-step", "1", "--out", str(resumed)) == 0
    times = [float(g.find("Time").get("Value")) for g in grids(resumed)]
    assert times == pytest.approx(DEMO_TIMES[3:], abs=1e-15)
    for k in range(4):
        assert relative(displacement(resumed, k)[1], displacement(full, 4 + k)[1]) <= 1e-8  # full: t = 0 first
    summary = json.loads((resumed / "summary.json").read_text())
    assert summary["path"]["start_step"] == 1 and [s["index"] for s in summary["steps"]] == [4, 5, 6, 7]


def test_physics_on_every_step(mpi_tmp_path):
    """Through the Python side of the CLI (builder, plan, run_path): every step of the demo path meets
    equilibrium, Signorini, the Coulomb cone and the friction direction against the slip increment."""
    scene = Scene.from_toml(DEMO).override(lev=2, rtol=1e-11, tol=1e-10)
    built = build_problem(scene, MPI.COMM_WORLD, petsc_options_prefix="pathcli_")
    checked = []

    def check(solve, record, result) -> None:  # noqa: ANN001
        residuals = physics_residuals(built.problem.model, result.displacement)
        for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone",
                    "slip_direction", "reaction_balance"):
            assert residuals[key] < 1e-7, (solve.time, key, residuals[key])
        checked.append(solve.time)

    with built.problem as problem:
        records, _, failure = run_path(problem, built.loads, plan(scene), obstacle_labels(scene),
                                       built.dirichlet_groups, on_solve=check)
        assert failure == "" and problem.step == 7
    assert checked == pytest.approx(DEMO_TIMES) and all(r.counts["slip"] > 0 for r in records)


BAD_STEPS = [
    ('[[path.step]]\nforce = 1', "unknown key 'force' in [[path.step]] 1"),
    ('[[path.step]]\nsubsteps = 0', "[[path.step]] 1 substeps = 0: must be an integer >= 1"),
    ('[[path.step]]\nsubsteps = 1.5', "[[path.step]] 1 substeps = 1.5"),
    ('[[path.step]]\n[[path.step]]\ntractions = { roof = [0, 0, 1] }', "[[path.step]] 2 tractions: boundary 'roof'"),
    ('[[path.step]]\ntractions = { top = [0, 0] }', "[[path.step]] 1 traction on 'top' = [0, 0]"),
    ('[[path.step]]\ntractions = { top = [0, 0, "x9"] }', "x9"),
    ('[[path.step]]\ntractions = [1, 2, 3]', "[[path.step]] 1 tractions = [1, 2, 3]: must be a table"),
    ('[[path.step]]\nprescribed = { top = [0, 0, -0.01] }',
     "boundary 'top' is not in the scene's [prescribed] (empty): the Dirichlet boundaries cannot change"),
    ('[[path.step]]\nmove = { indenter = [0, 0, 0.01] }', "[[path.step]] 1 move: no obstacle named 'indenter'"),
    ('[[path.step]]\nbody_force = [0, 0]', "[[path.step]] 1 body_force = [0, 0]"),
    ('[path]\nsteps = 3', "unknown key 'steps' in [path]"),
    ('path = 3', "[path] must be a table"),
    ('[path]\nstep = []', "[path] has no [[path.step]] table"),
]


@pytest.mark.parametrize("toml, fragment", BAD_STEPS, ids=[f"bad{i}" for i in range(len(BAD_STEPS))])
def test_bad_steps_exit_2(toml, fragment, mpi_tmp_path, capsys):
    scene = shared_file(mpi_tmp_path / "bad.toml", toml + "\n[body]\nlev = 0\n")
    out = mpi_tmp_path / "out"
    assert main(["--scene", str(scene), "--out", str(out)]) == EXIT_INPUT
    MPI.COMM_WORLD.barrier()
    lines = capsys.readouterr().err.strip().splitlines()
    if MPI.COMM_WORLD.rank == 0:
        assert len(lines) == 1 and lines[0].startswith(PROG) and fragment in lines[0], lines
    else:
        assert lines == []
    assert not out.exists()


def test_bad_path_flags_exit_2(mpi_tmp_path, capsys):
    first = mpi_tmp_path / "first"
    assert run("--lev", "0", "--steps", "2", "--no-plots", "--out", str(first)) == 0
    start = str(first / "solution.xdmf")
    cases = [
        (["--steps", "0"], "--steps 0: must be an integer in [1, "),
        (["--scene", str(DEMO), "--steps", "3"], "give either --steps or [[path.step]], not both"),
        (["--start-step", "1"], "--start-step 1: only for a load path"),
        (["--steps", "3", "--start-step", "1"], "give the earlier path's solution.xdmf with --start FILE"),
        (["--steps", "3", "--start", start, "--start-step", "3"], "--start-step 3: must lie in [1, 2]"),
        (["--steps", "4", "--start", start, "--start-step", "3"], "no step 3 in it"),
        # the earlier path at lev 0, this one at lev 1: resumed from another scene's state (exit 0 before)
        (["--steps", "2", "--start", start, "--start-step", "1"],
         "the earlier path is another scene (scene.body.lev = 0 there, 1 here)"),
        (["--steps", "2", "--nested", "1"], "--nested: nested iteration is not available for a load path"),
    ]
    capsys.readouterr()
    for args, fragment in cases:
        out = mpi_tmp_path / "out"
        assert main(["--lev", "1", *args, "--out", str(out)]) == EXIT_INPUT, args
        MPI.COMM_WORLD.barrier()
        lines = capsys.readouterr().err.strip().splitlines()
        if MPI.COMM_WORLD.rank == 0:
            assert len(lines) == 1 and fragment in lines[0], (args, lines)
        assert not out.exists()


@pytest.mark.serial
@pytest.mark.multirank
def test_real_command_two_ranks_equals_one(demo_path_run, tmp_path):
    """`mpirun -n 2 python3 -m fenics_coulomb --scene demos/scenes/d3_L2_path.toml` (the real command, from a
    directory outside the repository) gives the path of 1 rank (1e-8 at every step)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX", "PRTE_"))}
    env["PYTHONPATH"] = str(ROOT)
    two = tmp_path / "two"
    proc = subprocess.run(["mpirun", "-n", "2", sys.executable, "-m", "fenics_coulomb", "--scene", str(DEMO),
                           "--lev", "2", "--out", str(two)], capture_output=True, text=True, timeout=300,
                          env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("step 3/3, substep 2/2") == 1 and "load path completed" in proc.stdout
    one = demo_path_run  # the same scene and level on this one rank
    for k in range(7):
        x1, u1 = displacement(one, k)
        x2, u2 = displacement(two, k)
        assert np.allclose(x1, x2, atol=1e-14) and relative(u2, u1) <= 1e-8, k
    files = json.loads((two / "summary.json").read_text())["files"]
    assert {"path.csv", "path.png", "solution.xdmf", "summary.json"} <= set(files)
    assert (two / "path.png").stat().st_size > 0


def test_drag_path_hysteresis(mpi_tmp_path):
    """demos/scenes/cylinder_drag_path.toml: the pressed cylinder dragged to +δ, back to −δ and forward again.
    With friction the tangential force at δ1 = 0 depends on the direction of the motion (a hysteresis loop,
    slip at the turning points); without friction the path is reversible (the same force both ways, 1e-8)."""
    scene = str(ROOT / "demos" / "scenes" / "cylinder_drag_path.toml")
    forces = {}
    for friction in ("0.3", "0"):
        out = mpi_tmp_path / f"drag{friction}"
        assert run("--scene", scene, "--friction", friction, "--no-plots", "--out", str(out)) == 0
        steps = json.loads((out / "summary.json").read_text())["steps"]
        delta = {s["time"]: s["obstacle_displacements"]["roller"] for s in steps}
        assert delta[2.0] == [0.004, 0.0, -0.01] and delta[3.0] == [-0.004, 0.0, -0.01]
        assert delta[2.5][0] == 0.0 and delta[3.5][0] == 0.0
        forces[friction] = {s["time"]: np.asarray(s["contact_force"]) for s in steps}
        if friction != "0":
            slip = {s["time"]: s["state_counts"]["slip"] for s in steps}
            assert slip[2.0] > 0 and slip[3.0] > 0 and slip[2.5] == 0  # the turning points slip
    back, forward = forces["0.3"][2.5][0], forces["0.3"][3.5][0]
    scale = abs(forces["0.3"][2.0][0])
    assert back < forward and forward - back > 1e-2 * scale
    free = forces["0"]
    # reversible to the solve's accuracy: finite sliding's geometry iteration stops within 8·rtol (rtol 1e-7 here)
    assert abs(free[2.5][0] - free[3.5][0]) <= 8e-7 * abs(free[2.0][0])
