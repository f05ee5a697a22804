"""Running the real command under ``mpirun`` from a test or benchmark, to interrupt it mid-solve: the
environment of a fresh run, starting it and waiting until its ranks are inside the Newton iteration, the
processes of its session (tests/cli/test_interrupts.py, benchmarks/fuzz.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

__all__ = ["ROOT", "command_env", "end_session", "rank_pids", "session_processes", "start_in_newton"]


def command_env(display: bool = True) -> dict[str, str]:
    """This environment without the MPI launcher's variables of an enclosing mpirun, the repository on the path;
    ``display=False`` drops DISPLAY (a run then starts its own Xvfb for the plots)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX", "PRTE_", "OMPI_MCA_orte"))}
    env["PYTHONPATH"] = str(ROOT)
    if not display:
        env.pop("DISPLAY", None)
    return env


def start_in_newton(args: list[str], ranks: int = 2, display: bool = True, marker: str = "it ",
                    timeout: float = 120.0) -> subprocess.Popen:
    """``mpirun -n ranks python3 -m fenics_coulomb *args`` in a new session, returned once it printed a line
    starting with ``marker`` (default its first Newton iteration: the ranks are inside the solve); RuntimeError if
    it ended before, or did not print it within ``timeout`` seconds (every process of its session then killed)."""
    import threading

    cmd = ["mpirun", "-n", str(ranks), sys.executable, "-m", "fenics_coulomb", *args]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=command_env(display), start_new_session=True)
    assert proc.stdout is not None
    fired: list[bool] = []

    def expire() -> None:
        fired.append(True)
        end_session(proc.pid)

    watchdog = threading.Timer(timeout, expire)
    watchdog.start()
    try:
        for line in proc.stdout:
            if line.startswith(marker):
                return proc
    finally:
        watchdog.cancel()
    status = proc.wait()
    if fired:
        raise RuntimeError(f"the run printed no {marker!r} line within {timeout:g} s (its processes killed)")
    raise RuntimeError(f"the run ended before its first Newton iteration (status {status})")


def end_session(sid: int) -> None:
    """SIGKILL every process of session ``sid`` — mpirun and its ranks, which PRRTE starts in process groups of
    their own (a ``killpg`` of mpirun's group leaves them running)."""
    import signal

    out = subprocess.run(["ps", "-s", str(sid), "-o", "pid="], capture_output=True, text=True).stdout
    for pid in (int(p) for p in out.split()):
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def rank_pids(proc: subprocess.Popen) -> list[int]:
    """The ranks (children of mpirun running fenics_coulomb)."""
    out = subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True, text=True).stdout
    return [int(p) for p in out.split() if "fenics_coulomb" in Path(f"/proc/{p}/cmdline").read_text()]


def session_processes(sid: int) -> list[str]:
    """The processes still running in session ``sid`` (zombies are reaped, not running)."""
    out = subprocess.run(["ps", "-s", str(sid), "-o", "pid=,stat=,args="], capture_output=True, text=True).stdout
    return [line for line in out.splitlines() if line.split()[1][0] != "Z"]
