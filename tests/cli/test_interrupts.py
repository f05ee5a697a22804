"""Interrupts end every rank promptly, exit non-zero and leave no process behind (mpirun, ranks, Xvfb).

Each run is a real ``mpirun -n 2 python3 -m fenics_coulomb`` in its own session; after the signal the test
waits for mpirun and then looks for any process left in that session (``ps -s``). The same for
``container/run`` from the host is tests/host/interrupts.sh (the sandbox cannot start a sandbox).

A signal to a rank (Ctrl-C in a rank's terminal, a batch system's time limit that signals every task) ends the
job with 128 + the signal on every solver path — the matrix-free operator (its mult runs in Python inside GMRES,
where the interrupt used to be swallowed as a failed linear solve), GAMG, ILU and a load path — and leaves the
earlier result set byte for byte and no partial one; a load path's completed solves are kept in OUT.interrupted,
from which it resumes. A signal to mpirun itself is OpenMPI's to handle: PRRTE
sends SIGTERM to the ranks (they end with 143) and exits 1 (it does not forward SIGINT/SIGTERM, by design); on
Ctrl-C in mpirun's terminal the line still appears there (the ranks write it to the terminal too).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = [pytest.mark.serial, pytest.mark.multirank]

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from launching import command_env, end_session, rank_pids, session_processes, start_in_newton  # noqa: E402


def _start(tmp_path, lev: int = 6) -> subprocess.Popen:
    try:
        return start_in_newton(["--lev", str(lev), "--out", str(tmp_path / "out")], display=False)
    except RuntimeError as err:
        pytest.fail(str(err))


@pytest.mark.parametrize(
    "target, signum",
    [("group", signal.SIGINT), ("mpirun", signal.SIGTERM), ("rank", signal.SIGINT), ("rank", signal.SIGTERM)],
    ids=["SIGINT-group", "SIGTERM-mpirun", "SIGINT-one-rank", "SIGTERM-one-rank"],
)
def test_signal_ends_all_ranks(tmp_path, target, signum):
    proc = _start(tmp_path)
    ranks = rank_pids(proc)
    assert len(ranks) == 2
    xvfb = subprocess.run(["ps", "-s", str(proc.pid), "-o", "args="], capture_output=True, text=True).stdout
    assert "Xvfb" in xvfb  # the plots' display runs during the solve ...
    t0 = time.monotonic()
    if target == "group":
        os.killpg(proc.pid, signum)
    elif target == "mpirun":
        proc.send_signal(signum)
    else:
        os.kill(ranks[-1], signum)
    try:
        proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        end_session(proc.pid)
        pytest.fail(f"{signal.Signals(signum).name} to {target}: the run did not end within 20 s")
    elapsed = time.monotonic() - t0
    assert proc.returncode != 0
    assert elapsed < 10.0, elapsed
    deadline = time.monotonic() + 5.0
    while (left := session_processes(proc.pid)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not left, left  # ... and neither it nor a rank is left behind


def _digest(directory: Path) -> str:
    h = hashlib.sha256()
    for name in sorted(os.listdir(directory)):
        h.update(name.encode())
        h.update((directory / name).read_bytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def earlier_set(tmp_path_factory) -> Path:
    """A result set of the real command (lev 1), written once for the module: each test copies it."""
    out = tmp_path_factory.mktemp("earlier") / "out"
    subprocess.run([sys.executable, "-m", "fenics_coulomb", "--lev", "1", "--out", str(out), "--no-plots",
                    "--quiet"], env=command_env(display=False), check=True)
    return out


def _interrupt_after(tmp_path, earlier: Path, args: list[str], target: str, signum: int,
                     marker: str = "it ", ranks: int = 2) -> str:
    """Put a copy of the result set ``earlier`` in place, start ``args`` into the same directory, signal one rank
    or every rank once the run printed ``marker``: it ends with 128 + the signal, no process is left, the earlier
    set is kept byte for byte and no partial one is left. Returns the run's output after the marker."""
    out = tmp_path / "out"
    shutil.copytree(earlier, out)
    before = _digest(out)
    assert before == _digest(earlier)
    try:
        proc = start_in_newton([*args, "--out", str(out), "--no-plots"], ranks=ranks, display=False, marker=marker)
    except RuntimeError as err:
        pytest.fail(str(err))
    pids = rank_pids(proc)
    for rank in pids[-1:] if target == "rank" else pids:
        os.kill(rank, signum)
    try:
        rest, _ = proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        end_session(proc.pid)
        pytest.fail(f"{signal.Signals(signum).name} to {target}: the run hung")
    assert proc.returncode == 128 + signum, rest[-2000:]
    assert f"interrupted by {signal.Signals(signum).name}" in rest
    deadline = time.monotonic() + 5.0
    while (left := session_processes(proc.pid)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not left, left
    assert _digest(out) == before  # the earlier result set, byte for byte
    assert not [p for p in os.listdir(tmp_path) if "partial" in p]
    return rest


#: Ctrl-C in one rank's terminal (the other rank is then inside a collective call of the same solver path: the case
#: that can hang) on every path; a batch system's SIGTERM to every rank on the paths whose work runs in Python (the
#: matrix-free mult, the load path's steps, the pair's Python preconditioner) — on GAMG and ILU it meets the same
#: handler inside the same PETSc calls as the one-rank signal.
ONE_RANK, EVERY_RANK = ("rank", signal.SIGINT), ("ranks", signal.SIGTERM)


@pytest.mark.parametrize("path, target, signum", [
    pytest.param(["--lev", "4", "--pc", "none", "--tol", "1e-12"], *ONE_RANK, id="shell-SIGINT-one-rank"),
    pytest.param(["--lev", "4", "--pc", "none", "--tol", "1e-12"], *EVERY_RANK, id="shell-SIGTERM-every-rank"),
    pytest.param(["--lev", "5", "--pc", "gamg", "--tol", "1e-12"], *ONE_RANK, id="gamg-SIGINT-one-rank"),
    pytest.param(["--lev", "5", "--pc", "ilu", "--tol", "1e-12"], *ONE_RANK, id="ilu-SIGINT-one-rank"),
    pytest.param(["--lev", "4", "--steps", "4", "--pc", "none", "--tol", "1e-12"], *ONE_RANK,
                 id="load-path-SIGINT-one-rank"),
    pytest.param(["--lev", "4", "--steps", "4", "--pc", "none", "--tol", "1e-12"], *EVERY_RANK,
                 id="load-path-SIGTERM-every-rank"),
])
def test_interrupt_on_every_solver_path(tmp_path, earlier_set, path, target, signum):
    """The matrix-free shell (no preconditioner), GAMG on A with the shell operator, the explicit Newton matrix
    (ILU) and a load path."""
    _interrupt_after(tmp_path, earlier_set, path, target, signum)


@pytest.mark.parametrize("scene, options, target, signum", [
    # one body, an STL obstacle: GAMG on A
    pytest.param("stl_roller_rolling", [], *ONE_RANK, id="obstacle-SIGINT-one-rank"),
    # a pair: GAMG on B inside the python PC (M⁻¹ B⁻¹ M⁻ᵀ)
    pytest.param("slide_off", ["--pc", "gamg", "--tol", "1e-12"], *ONE_RANK, id="pair-SIGINT-one-rank"),
    pytest.param("slide_off", ["--pc", "gamg", "--tol", "1e-12"], *EVERY_RANK, id="pair-SIGTERM-every-rank"),
])
def test_interrupt_during_the_geometry_iteration(tmp_path, earlier_set, scene, options, target, signum):
    """Finite sliding: a signal right after a geometry update (the ranks re-pair, re-place and solve again) ends
    every rank with 128 + the signal and keeps the earlier result set (-v: a load path's updates are logged)."""
    path = Path(__file__).resolve().parents[2] / "demos" / "scenes" / f"{scene}.toml"
    _interrupt_after(tmp_path, earlier_set, ["--scene", str(path), *options, "-v"], target, signum,
                     marker="finite sliding: geometry update")


def test_interrupt_on_the_rank_that_read_a_gmsh_mesh(tmp_path, earlier_set):
    """Ctrl-C on one rank — the rank that read the scene's gmsh mesh — during a finite-sliding solve: 130 with the
    message and the earlier result set kept. gmsh.initialize() left SIGINT at SIG_DFL on the reading rank (its
    finalize does not restore the handler): the rank died by the signal, without the message or the cleanup."""
    path = Path(__file__).resolve().parents[2] / "demos" / "scenes" / "slide_off.toml"
    _interrupt_after(tmp_path, earlier_set, ["--scene", str(path), "--pc", "gamg", "--tol", "1e-12", "-v"], "rank",
                     signal.SIGINT, marker="finite sliding: geometry update", ranks=1)


def test_an_interrupted_path_keeps_its_completed_solves(tmp_path, earlier_set):
    """Ctrl-C on one rank once the path's second solve is done (it may arrive while that solve's grid is written:
    the interrupt then waits for the write): 130, the earlier set byte for byte, no partial set — and the completed
    solves in OUT.interrupted, a result set of its own (summary.json not converged, reason "interrupted", one
    path.csv row and one XDMF grid per solve beside t = 0, every dataset the XML names in the HDF5 file), named in
    the interrupt's line with the options that resume the path, which then runs to its end. SIGTERM to every rank
    at the same moment: tests/cli/test_fuzz.py's case signal-path-after-a-solve-SIGTERM."""
    target, signum = ONE_RANK
    import xml.etree.ElementTree as ET

    import h5py

    path = ["--lev", "3", "--steps", "6", "--pc", "none", "--tol", "1e-12"]
    rest = _interrupt_after(tmp_path, earlier_set, path, target, signum, marker="solve 2/6")
    kept = tmp_path / "out.interrupted"
    summary = json.loads((kept / "summary.json").read_text())
    done = summary["path"]["completed"]
    assert not summary["converged"] and summary["reason"] == "interrupted" and 2 <= done < 6
    assert [s["step"] for s in summary["steps"]] == list(range(1, done + 1))
    assert len((kept / "path.csv").read_text().splitlines()) == done + 1
    grids = ET.parse(kept / "solution.xdmf").getroot().findall("Domain/Grid/Grid")
    assert [float(g.find("Time").get("Value")) for g in grids] == [float(k) for k in range(done + 1)]
    with h5py.File(kept / "solution.h5", "r") as h5:
        for item in ET.parse(kept / "solution.xdmf").getroot().iter("DataItem"):
            assert item.text.split(":")[1] in h5
    lines = [x for x in rest.splitlines() if "interrupted by" in x]
    resume = f"(resume: --start {tmp_path / 'out'}.interrupted/solution.xdmf --start-step {done})"
    naming = [x for x in lines if x.endswith(f"the {done} completed solve(s) of the path are kept in {kept} {resume}")]
    assert len(naming) == 1 and len(lines) <= 2, lines
    proc = subprocess.run([sys.executable, "-m", "fenics_coulomb", *path, "--start", str(kept / "solution.xdmf"),
                           "--start-step", str(done), "--out", str(tmp_path / "resumed"), "--no-plots", "--quiet"],
                          env=command_env(display=False), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    resumed = json.loads((tmp_path / "resumed" / "summary.json").read_text())
    assert resumed["converged"] and [s["step"] for s in resumed["steps"]] == list(range(done + 1, 7))



def _on_a_terminal(args: list[str], marker: str, timeout: float = 60.0) -> tuple[str, int, int]:
    """Run ``args`` as a user does in a terminal (a pseudo-terminal of its own session), type Ctrl-C once the output
    shows ``marker``: (everything the terminal showed, the exit status, the session)."""
    import pty
    import select

    pid, fd = pty.fork()
    if pid == 0:  # the child: the session's leader, the pseudo-terminal its controlling terminal
        os.execvpe(args[0], args, command_env(display=False))
    shown, typed = b"", False
    deadline = time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            if not select.select([fd], [], [], 0.5)[0]:
                continue
            try:
                data = os.read(fd, 65536)
            except OSError:  # EIO: every process holding the terminal has ended
                break
            if not data:
                break
            shown += data
            if not typed and marker.encode() in shown:
                os.write(fd, b"\x03")  # the terminal's line discipline: SIGINT to its foreground group, mpirun
                typed = True
        else:
            end_session(pid)
            pytest.fail(f"the run did not end within {timeout} s: {shown.decode(errors='replace')[-2000:]}")
    finally:
        _, status = os.waitpid(pid, 0)
        os.close(fd)
    assert typed, shown.decode(errors="replace")[-2000:]
    return shown.decode(errors="replace").replace("\r\n", "\n"), os.waitstatus_to_exitcode(status), pid


def test_ctrl_c_in_mpiruns_terminal_shows_where_the_solves_are_kept(tmp_path):
    """Ctrl-C in the terminal of ``mpirun -n 2``, as users stop a run: it reaches mpirun alone, which sends SIGTERM
    to the ranks and no longer relays their output. The completed solves of the path are kept, and the line that
    says where — and how to resume — appears on the terminal (it used to be lost with mpirun's relay, exit 1
    without a word). mpirun's own exit status (1) is OpenMPI's."""
    out = tmp_path / "out"
    args = ["mpirun", "-n", "2", sys.executable, "-m", "fenics_coulomb", "--lev", "3", "--steps", "6", "--pc", "none",
            "--tol", "1e-12", "--out", str(out), "--no-plots"]
    shown, status, session = _on_a_terminal(args, marker="solve 2/6")
    assert status != 0
    kept = tmp_path / "out.interrupted"
    assert (kept / "summary.json").exists() and not out.exists()
    lines = [x for x in shown.splitlines() if "fenics-coulomb: interrupted by SIGTERM" in x]  # after the echoed ^C
    naming = [x for x in lines if f"completed solve(s) of the path are kept in {kept} (resume: --start {kept}" in x]
    assert len(naming) == 1 and len(lines) <= 2, shown[-3000:]
    deadline = time.monotonic() + 5.0
    while (left := session_processes(session)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not left, left


#: A run whose figures take a minute to draw, announced ("drawing the figures"): the moment to interrupt it.
SLOW_FIGURES = """
import sys, time
import fenics_coulomb.io.figures as figures
from fenics_coulomb.cli import run_command
draw = figures.write_figures
def slow(*args, **kwargs):
    print("drawing the figures", flush=True)
    time.sleep(60)
    return draw(*args, **kwargs)
figures.write_figures = slow
sys.exit(run_command(sys.argv[1:]))
"""


@pytest.mark.parametrize("launch, run", [
    pytest.param(["mpirun", "-n", "2"], ["--lev", "3", "--steps", "3"], id="mpirun-load-path"),
    pytest.param([], ["--lev", "3"], id="one-rank-static"),
])
def test_ctrl_c_while_the_figures_are_drawn_keeps_the_results(tmp_path, launch, run):
    """Ctrl-C while the figures are drawn (they take seconds: 1.3 s of a 4 s slide_off path on 2 ranks). They were
    drawn inside the result set's write, during which an interrupt waited; mpirun gives its ranks 250 ms between
    SIGTERM and SIGKILL (PRRTE's odls), so they were killed: exit 1, no line, the set left in a hidden
    ``.OUT.partial-*``. The figures are now drawn once the set is in place: the results stay, without them, and the
    line says where."""
    out = tmp_path / "out"
    args = [*launch, sys.executable, "-c", SLOW_FIGURES, *run, "--pc", "none", "--out", str(out)]
    shown, status, session = _on_a_terminal(args, marker="drawing the figures")
    assert status != 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and not [f for f in summary["files"] if f.endswith(".png")]
    assert not list(out.glob("*.png"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # nothing beside it: no partial set, no .interrupted
    lines = [x for x in shown.splitlines() if "fenics-coulomb: interrupted by" in x]
    naming = [x for x in lines if x.endswith(f"the run had finished: its results are in {out}, without the figures it "
                                             "was drawing")]
    assert len(naming) == 1 and len(lines) <= 2, shown[-3000:]
    deadline = time.monotonic() + 5.0
    while (left := session_processes(session)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not left, left


def test_a_job_piped_to_tee_and_ended_through_mpirun_shows_where_the_solves_are_kept(tmp_path):
    """``mpirun ... 2>&1 | tee log`` ended by a signal to mpirun (a batch system's, or kill): mpirun sends SIGTERM to
    the ranks and stops relaying their output, so the pipe carried OpenMPI's abort banner alone, not where the
    completed solves were kept. The ranks now write the line into mpirun's own stderr (the pipe) as well. (Into a
    log file mpirun writes at its own offset, its banner would overwrite the line: not done.)"""
    out = tmp_path / "out"
    args = ["mpirun", "-n", "2", sys.executable, "-m", "fenics_coulomb", "--lev", "3", "--steps", "6", "--pc", "none",
            "--tol", "1e-12", "--out", str(out), "--no-plots"]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=command_env(display=False),
                            start_new_session=True, stdin=subprocess.DEVNULL, text=True)
    assert proc.stdout is not None
    shown = []
    try:
        for line in proc.stdout:
            shown.append(line)
            if line.startswith("solve 2/6"):
                proc.send_signal(signal.SIGTERM)
                break
        rest, _ = proc.communicate(timeout=30)
    finally:
        end_session(proc.pid)
    kept = tmp_path / "out.interrupted"
    assert (kept / "summary.json").exists()
    text = "".join(shown) + rest
    lines = [x for x in text.splitlines() if "fenics-coulomb: interrupted by SIGTERM" in x]
    assert len([x for x in lines if f"are kept in {kept} (resume: --start {kept}" in x]) == 1, text[-3000:]
