"""A fuzz harness over every input surface of the command line (issue 24): flags, scene keys and values, load
expressions, meshes, start files, output directories, PETSc options, signals; and the Python API.

Every generated case runs the real entry point — ``fenics_coulomb.cli.main`` in-process (fast; the same code as
``python3 -m fenics_coulomb``) or, for signals and the launcher, the real command in a subprocess — into an
output directory that already holds an earlier result set, and asserts what a user may rely on:

* the exit status is 0, 2 (bad input), 3 (no convergence), 4 (results not written) or 128 + a signal;
* status 2 and 4 print exactly one line on stderr (rank 0), status 3 names its reason; never a traceback;
* unless the run succeeded, the earlier result set is byte for byte what it was, and no partial set is left (a
  run that did not converge writes its last iterate beside it, into ``OUT.not-converged``);
* exit 0 only with the physics checks of summary.json passing (and converged: true);
* a subprocess leaves no process behind.

    container/run python3 benchmarks/fuzz.py --cases 240 --seed 1 --out docs/fuzz

The cases are reproducible from the seed; tests/cli/test_fuzz.py runs a fixed subset of them.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import hashlib
import io
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
from launching import end_session, rank_pids, session_processes, start_in_newton  # noqa: E402

#: The statuses a run may end with (128 + SIGINT, SIGTERM, SIGHUP included).
STATUSES = {0, 2, 3, 4, 129, 130, 143}
#: The physics checks that decide a converged solve, with their bound (fenics_coulomb.model.checks).
DECISIVE = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone")


@dataclass
class Case:
    """One generated run: the command-line arguments (without --out), files to write first, and how to run."""

    name: str
    argv: list[str]
    files: dict[str, str] = field(default_factory=dict)
    subprocess: bool = False
    signal: int = 0
    ranks: int = 1
    #: A signal case: signalled once the run printed a line starting with this (its first Newton iteration, or a
    #: load path's completed solve: then its completed solves must be kept in OUT.interrupted).
    marker: str = "it "


# -- generators --------------------------------------------------------------------------------------------
GOOD = {
    "--lev": ["0", "1", "2"], "--gap": ["d1", "d2", "d3", "0.01 + 0.005*sin(2*pi*x1)"], "--load": ["L1", "L2"],
    "--load-scale": ["1", "0.5", "-1", "0"], "--young": ["70", "210"], "--poisson": ["0.3", "0.45"],
    "--friction": ["0", "0.23", "1"], "--variant": ["4a", "4b"], "--tol": ["0.1", "0.01"],
    "--rtol": ["1e-7", "1e-10"], "--pc": ["auto", "ilu", "gamg", "lu"], "--gamma-scale": ["0.01", "1"],
    "--start": ["zero", "undeformed"], "--steps": ["2"], "--max-it": ["50"], "--accuracy": ["1e-6"],
    "--sliding": ["finite", "small"],
}
BAD = {
    "--lev": ["-1", "abc", "41", "1.5", ""], "--gap": ["d9", "x3", "1/", "__import__('os')", "sin(x1, x2)", ""],
    "--load": ["L3", ""], "--load-scale": ["nan", "inf", "1e300", "abc"], "--young": ["-1", "0", "nan", "1e20"],
    "--poisson": ["0.5", "-1", "2", "nan"], "--friction": ["-0.1", "inf", "nan"], "--variant": ["4c", ""],
    "--tol": ["0", "1", "-0.1", "nan"], "--rtol": ["0", "1", "-1e-8"], "--pc": ["none2", "", "ILU"],
    "--gamma-scale": ["0", "-1", "1e-300", "inf"], "--start": ["/nonexistent.xdmf", "/dev/null", "yes"],
    "--steps": ["0", "-3", "1e9", "x"], "--max-it": ["0", "-5", "1.5"], "--accuracy": ["0", "1", "-1"],
    "--nested": ["-1", "x"], "--start-step": ["1"], "--sliding": ["large", "", "Finite", "1"],
}
PETSC_GOOD = [["-coulomb_ksp_monitor_cancel"], ["-coulomb_ksp_gmres_restart", "50"], ["-coulomb_pc_type", "jacobi"]]
PETSC_BAD = [["-coulomb_ksp_max_it", "-3"], ["-coulomb_ksp_rtol", "-1"], ["-coulomb_"], ["-ksp_monitor"],
             ["-coulomb_ksp_type", "nonsense"], ["-coulomb_pc_type", "nonsense"], ["-coulomb_ksp_rtol", "2"],
             ["--nonsense"]]
SCENE_BAD = [
    "[body]\nlev = 'two'\n", "[body]\nshape = 'sphere'\n", "[material]\nyoung = -70\n", "[material]\npoisson = 0.5\n",
    "[friction]\ncoefficient = 'high'\n", "[load]\ncase = 'L7'\n", "[tractions]\ntop = [0, 0, '1/0']\n",
    "[tractions]\ntop = [0, 0, '-1e300*x1']\n", "[tractions]\ntop = [0, 0, 'x4']\n",
    "[tractions]\nnowhere = [0, 0, 1]\n",
    "[solver]\npower_iterations = 100000000\n", "[solver]\nrtol = 2\n", "[solver]\npc = 'magic'\n",
    "[nonsense]\na = 1\n", "a = " + "[" * 2000 + "]" * 2000 + "\n", "[body\n", "\x00\x01binary",
    "[[obstacle]]\ntype = 'sphere'\ncenter = [1.0, 0.5, 0.5]\nradius = 0.1\n",
    "[[obstacle]]\ntype = 'cone'\n", "[[obstacle]]\ntype = 'plane'\nnormal = [0, 0, 0]\n",
    "[[obstacle]]\ntype = 'sphere'\ncenter = [1, 0.5, -1]\nradius = -1\n",
    "[body]\ngap = '0.0*x1'\nclamped = ['bottom']\ncontact = ['top']\n[tractions]\n[[obstacle]]\nname = 'r'\n"
    "type = 'cylinder'\npoint = [1.0, 0.5, 1.5]\naxis = [0, 1, 0]\nradius = 0.5\ndisplacement = [0, 0, -2.0]\n",
    "[[path.step]]\nsubsteps = 0\n", "[[path.step]]\nmove = { nothing = [0, 0, 1] }\n",
    "[body]\nclamped = ['nowhere']\n", "[body]\ncontact = ['left']\nclamped = ['left']\n[solver]\nrtol = 1e-7\n",
    "[prescribed]\ntop = [0.01, 'loose', 0]\n", "[prescribed]\ntop = [nan, 'free', 'free']\n",
    "[prescribed]\ntop = ['free', 'free', 'free']\n", "[prescribed]\ntop = [0.01, 'free']\n",
    "[prescribed]\ntop = [0.01, 'free', 0]\n[[path.step]]\nprescribed = { top = [0.02, 0, 0] }\n",
    "[body]\nclamped = ['left']\n[roller]\nleft = [0]\n", "[prescribed]\ntop = [0, 0, -0.01]\n[roller]\ntop = [0]\n",
]
SCENE_GOOD = [
    "[body]\nlev = 1\n", "[body]\nlev = 1\ngap = 'd2'\n[friction]\ncoefficient = 0.5\n",
    "[body]\nlev = 1\n[tractions]\ntop = [0, 0, '-0.1*x1']\n",
    "[body]\nlev = 1\ngap = '0.0*x1'\nclamped = ['bottom']\ncontact = ['top']\n[tractions]\n[[obstacle]]\n"
    "type = 'sphere'\ncenter = [1.0, 0.5, 1.6]\nradius = 0.6\ndisplacement = [0, 0, -0.005]\n"
    "[solver]\nstart = 'undeformed'\n",
    "[body]\nlev = 1\n[[path.step]]\nsubsteps = 2\n[[path.step]]\n",
    "[body]\nlev = 1\nclamped = []\n[tractions]\n[prescribed]\ntop = [0.002, 'free', -0.01]\n[roller]\nleft = [0]\n"
    "sides = [1]\n",
]


def _stl(triangles: object) -> str:
    """ASCII STL text of triangles (k, 3, 3) (normals by the right-hand rule)."""
    import numpy as np

    X = np.asarray(triangles, dtype=np.float64)
    lines = ["solid fuzz"]
    for tri in X:
        lines += ["facet normal 0 0 0", "outer loop", *(f"vertex {v[0]!r} {v[1]!r} {v[2]!r}" for v in tri),
                  "endloop", "endfacet"]
    return "\n".join([*lines, "endsolid fuzz", ""])


@functools.cache
def _mistagged_cube() -> str:
    """The text of a gmsh file whose physical surface 1 holds triangles that are not faces of its tetrahedra
    (meshes/transfinite_cube.py, "Right")."""
    from meshes.transfinite_cube import write_cube

    with tempfile.TemporaryDirectory() as tmp:
        return write_cube(Path(tmp) / "cube.msh", "Right").read_text()


def hostile_cases() -> list[tuple[list[str], dict[str, str]]]:
    """Obstacles the contact nodes cannot see, a gmsh surface whose elements are not faces of the volume, a loose
    accuracy and rtol given twice: (argv, files) —
    each must end with exit 2 in one line or exit 3, never exit 0 with a wrong answer."""
    from meshes.surfaces import icosphere, rectangle

    block = "[body]\nlev = 2\ngap = '0.0*x1'\nclamped = ['bottom']\ncontact = ['top']\n[tractions]\n[[obstacle]]\n"
    stl = {"ball.stl": _stl(icosphere(0.3, (1.0, 0.5, 1.5), level=1)),
           "buried.stl": _stl(icosphere(0.2, (1.0, 0.5, 0.5), level=1)),
           "up.stl": _stl(rectangle((-1.0, -1.0), (3.0, 2.0), z=1.0))}
    scenes = [
        "type = 'surface'\nfile = 'buried.stl'\n",
        "type = 'surface'\nfile = 'ball.stl'\ndisplacement = [0, 0, -2.0]\n",
        "name = 'b'\ntype = 'surface'\nfile = 'ball.stl'\n[[path.step]]\n[[path.step]]\n"
        "rotate = { b = [180, [0, 1, 0], [1, 0.5, 0.5]] }\n",
        "type = 'sphere'\ncenter = [1, 0.5, 1.5]\nradius = 0.3\ndisplacement = [0, 0, -2000.0]\n",
        "type = 'plane'\npoint = [0, 0, 1.0]\nnormal = [0, 0, 1]\ndisplacement = [0, 0, -0.01]\n",
        "type = 'surface'\nfile = 'up.stl'\ndisplacement = [0, 0, -0.01]\n",
    ]
    cases = [(["--scene", "{dir}/scene.toml"], {"scene.toml": block + text, **stl}) for text in scenes]
    free = "[body]\nlev = 2\ngap = '0.0*x1'\nclamped = []\ncontact = {}\n[friction]\ncoefficient = 0.0\n[tractions]\n"
    cases += [(["--scene", "{dir}/scene.toml"], {"scene.toml": text}) for text in (
        # a face driven into the floor by its supports (exit 2); the edge of a floor and a wall (exit 3)
        free.format("['bottom']") + "[prescribed]\nleft = ['free', 0.0, -0.02]\n",
        free.format("['bottom', 'right']") + "[prescribed]\ntop = ['free', 'free', -0.01]\nleft = [0.01, 'free', "
        "'free']\n[[obstacle]]\ntype = 'plane'\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n[[obstacle]]\ntype = 'plane'\n"
        "point = [2, 0, 0]\nnormal = [-1, 0, 0]\n",
        # the body moved past a ball within one solve (exit 3)
        free.format("['bottom', 'right', 'sides', 'left']") + "[prescribed]\ntop = [3.0, 0.0, 0.0]\n[[obstacle]]\n"
        "type = 'sphere'\ncenter = [2.5, 0.5, 0.5]\nradius = 0.3\n")]
    mesh = ("[body]\nshape = 'mesh'\nmesh = 'cube.msh'\nclamped = ['face5']\ncontact = ['face6']\n[boundaries]\n"
            + "".join(f"face{i} = {i}\n" for i in range(1, 7)) + "[tractions]\n[[obstacle]]\ntype = 'plane'\n"
            "point = [0, 0, 1.0]\nnormal = [0, 0, -1]\ndisplacement = [0, 0, -0.01]\n")
    cases.append((["--scene", "{dir}/scene.toml"], {"scene.toml": mesh, "cube.msh": _mistagged_cube()}))
    cases += [(["--lev", "0", "--rtol", "1e-5", "--accuracy", "1e-3"], {}),
              (["--scene", "{dir}/scene.toml", "--lev", "0"],
               {"scene.toml": "[solver]\nrtol = 1e-6\naccuracy = 1e-4\n"}),
              (["--lev", "3", "--accuracy", "0.9"], {})]
    return cases


def generate(seed: int, count: int) -> list[Case]:
    """``count`` reproducible cases of every kind."""
    rng = random.Random(seed)
    cases: list[Case] = []
    kinds = ["flag_bad", "flag_good", "petsc_bad", "petsc_good", "scene_bad", "scene_good", "out_bad", "mixed",
             "diverge", "hostile"]
    hostile = hostile_cases()
    for i in range(count):
        kind = kinds[i % len(kinds)]
        argv: list[str] = ["--lev", rng.choice(["0", "1"])]
        files: dict[str, str] = {}
        if kind in ("flag_bad", "mixed"):
            flag = rng.choice(sorted(BAD))
            argv += [flag, rng.choice(BAD[flag])]
        if kind in ("flag_good", "mixed"):
            for flag in rng.sample(sorted(GOOD), 2):
                argv += [flag, rng.choice(GOOD[flag])]
        if kind == "diverge":
            argv += rng.choice([["--max-it", "1"], ["--max-it", "2", "--rtol", "1e-12"],
                                ["--pc", "ilu", "--tol", "1e-9", "-coulomb_ksp_max_it", "1"]])
        if kind == "petsc_bad":
            argv += rng.choice(PETSC_BAD)
        if kind == "petsc_good":
            argv += rng.choice(PETSC_GOOD)
        if kind in ("scene_bad", "scene_good"):
            files["scene.toml"] = rng.choice(SCENE_BAD if kind == "scene_bad" else SCENE_GOOD)
            argv = ["--scene", "{dir}/scene.toml"]
        if kind == "hostile":
            argv, more = rng.choice(hostile)
            files.update(more)
        if kind == "out_bad":
            argv += ["--out", rng.choice(["{dir}/" + "a" * 300, "/proc/nonexistent/out", "{dir}/file.txt", ""])]
            files["file.txt"] = "not a directory"
        cases.append(Case(f"{i:03d}-{kind}", argv, files))
    return cases


def signal_cases() -> list[Case]:
    """Real runs interrupted inside the Newton iteration: each solver path, one and every rank."""
    paths = [["--lev", "4", "--pc", "none", "--tol", "1e-12"], ["--lev", "5", "--pc", "gamg", "--tol", "1e-12"],
             ["--lev", "5", "--pc", "ilu", "--tol", "1e-12"], ["--lev", "4", "--steps", "4", "--pc", "none"]]
    cases = []
    for i, path in enumerate(paths):
        for signum in (signal.SIGINT, signal.SIGTERM):
            cases.append(Case(f"signal-{i}-{signal.Signals(signum).name}", path, subprocess=True, signal=signum,
                              ranks=2))
    for signum in (signal.SIGINT, signal.SIGTERM):  # a load path after its second solve: the solves kept
        cases.append(Case(f"signal-path-after-a-solve-{signal.Signals(signum).name}",
                          ["--lev", "3", "--steps", "6", "--pc", "none", "--tol", "1e-12"], subprocess=True,
                          signal=signum, ranks=2, marker="solve 2/6"))
    return cases


# -- running and checking ------------------------------------------------------------------------------------
def _digest(directory: Path) -> str:
    h = hashlib.sha256()
    if directory.is_dir():
        for name in sorted(os.listdir(directory)):
            h.update(name.encode())
            h.update((directory / name).read_bytes())
    return h.hexdigest()


def run_case(case: Case, work: Path, earlier: Path) -> tuple[int, list[str]]:
    """Run ``case`` in a fresh directory holding a copy of the earlier result set at ``out``; return the status
    and the violations found (empty: the case passed)."""
    from fenics_coulomb.cli import main

    case_dir = work / case.name
    shutil.rmtree(case_dir, ignore_errors=True)
    case_dir.mkdir(parents=True)
    for name, text in case.files.items():
        (case_dir / name).write_bytes(text.encode("utf-8", "surrogatepass"))
    argv = [a.replace("{dir}", str(case_dir)) for a in case.argv]
    out = case_dir / "out"
    if "--out" not in argv:
        shutil.copytree(earlier, out)
        argv += ["--out", str(out)]
    before = _digest(out)
    problems: list[str] = []
    if case.subprocess:
        status, err = _run_signal(case, argv)
    else:
        stderr = io.StringIO()
        with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
            try:
                status = main([*argv, "--quiet", "--no-plots"])
            except SystemExit as exit_:  # argparse's --help
                status = int(exit_.code or 0)
        err = stderr.getvalue()
    lines = [line for line in err.strip().splitlines() if line.strip()]
    if status not in STATUSES:
        problems.append(f"status {status}")
    if "Traceback" in err:
        problems.append("a traceback")
    if status in (2, 4) and len(lines) != 1:
        problems.append(f"{len(lines)} lines on stderr for status {status}")
    if status != 0:
        if out.exists() and _digest(out) != before:
            problems.append("the earlier results changed")
        if [p for p in case_dir.iterdir() if ".partial-" in p.name]:
            problems.append("a partial result set left")
        interrupted = out.with_name(out.name + ".interrupted") / "summary.json"
        if case.marker.startswith("solve") and (
                not interrupted.is_file() or json.loads(interrupted.read_text()).get("reason") != "interrupted"):
            problems.append("an interrupted path's completed solves not kept in OUT.interrupted")
        failed = out.with_name(out.name + ".not-converged") / "summary.json"
        if status == 3 and not case.subprocess and (
                not failed.is_file() or json.loads(failed.read_text()).get("converged") is not False):
            problems.append("no not-converged set beside the earlier results")
    elif (out / "summary.json").is_file():
        summary = json.loads((out / "summary.json").read_text())
        bad = [k for k in DECISIVE if not summary.get("physics_checks", {}).get(k, 0.0) <= 1e-3]
        if not summary.get("converged") or bad:
            problems.append(f"exit 0 with converged={summary.get('converged')}, failing checks {bad}")
    return status, problems


def _run_signal(case: Case, argv: list[str]) -> tuple[int, str]:
    try:
        proc = start_in_newton([*argv, "--no-plots"], ranks=case.ranks, marker=case.marker)
    except RuntimeError as err:
        return -3, str(err)
    ranks = rank_pids(proc)
    for rank in (ranks[-1:] if case.signal == signal.SIGINT else ranks):
        os.kill(rank, case.signal)
    try:
        rest, _ = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        end_session(proc.pid)
        return -1, "hang"
    deadline = time.monotonic() + 5.0
    while (left := "\n".join(session_processes(proc.pid))) and time.monotonic() < deadline:
        time.sleep(0.1)
    if left:
        return -2, "processes left: " + left
    ours = [line for line in rest.splitlines() if line.startswith("fenics-coulomb: interrupted")]
    return proc.returncode, ours[0] if ours else rest


def earlier_results(work: Path) -> Path:
    """A result set to find untouched after every failed case."""
    from fenics_coulomb.cli import main

    earlier = work / "earlier"
    if not (earlier / "summary.json").is_file():
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["--lev", "0", "--out", str(earlier), "--quiet", "--no-plots"]) == 0
    return earlier


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=240)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--signals", action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument("--out", default="docs/fuzz")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="fenics-coulomb-fuzz-") as tmp:
        work = Path(tmp)
        earlier = earlier_results(work)
        cases = generate(args.seed, args.cases) + (signal_cases() if args.signals else [])
        rows, statuses, failures = [], Counter(), []
        for case in cases:
            status, problems = run_case(case, work, earlier)
            statuses[status] += 1
            rows.append((case.name, " ".join(case.argv), status, "; ".join(problems) or "ok"))
            if problems:
                failures.append((case.name, problems))
            shutil.rmtree(work / case.name, ignore_errors=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    lines = [f"# Fuzz run: {len(cases)} cases, seed {args.seed}", "",
             "`container/run python3 benchmarks/fuzz.py --cases {} --seed {}` (issue 24). Statuses: {}.".format(
                 args.cases, args.seed, ", ".join(f"{s}: {n}" for s, n in sorted(statuses.items()))),
             f"Cases violating a guarantee: {len(failures)}.", "",
             "| case | arguments | status | checks |", "|---|---|---|---|"]
    lines += [f"| {n} | `{a[:90]}` | {s} | {c} |" for n, a, s, c in rows]
    (out / "README.md").write_text("\n".join(lines) + "\n")
    print(f"{len(cases)} cases, statuses {dict(statuses)}, {len(failures)} violations")
    for name, problems in failures:
        print(f"  {name}: {problems}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
