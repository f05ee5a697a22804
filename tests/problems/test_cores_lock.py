"""The serial pass's lock on the cores (tests/cores.py): the ranks a command starts, a multirank test alone and
before the shared requests that arrive after it, and the pass refusing a job of several ranks from a test without
the mark."""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from cores import CoresLock, ranks_of

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.serial  # rank-local: threads and a pytest process of its own


@pytest.mark.parametrize("command, ranks", [
    (["mpirun", "-n", "2", "python3", "-m", "fenics_coulomb"], 2),
    (["/usr/bin/mpiexec", "--oversubscribe", "-np", "3", "python3"], 3),
    (["mpirun", "-n=4", "python3"], 4),
    ("mpirun --map-by :OVERSUBSCRIBE -n 16 python3 -m fenics_coulomb", 16),
    (["mpirun", "python3"], 1),
    (["python3", "-m", "fenics_coulomb", "-n", "2"], 1),
    (["pvpython", "view.py"], 1),
    ("", 1),
])
def test_ranks_of_a_command(command, ranks):
    assert ranks_of(command) == ranks


def test_a_multirank_test_runs_alone_and_before_later_shared_requests(tmp_path):
    """Shard 1 holds the cores shared; shard 2's multirank test waits for it, and shard 3's next test, asking after
    it, waits for the multirank test: the order of entry is 1, 2, 3 and 2 never overlaps another."""
    path = tmp_path / "cores.lock"
    locks = [CoresLock(path) for _ in range(3)]
    order: list[str] = []
    inside: list[int] = []
    release = threading.Event()
    first_in = threading.Event()

    def holder(k: int, alone: bool, wait: threading.Event | None) -> None:
        with locks[k].hold(alone):
            order.append(f"in {k}")
            inside.append(k)
            if k == 0:
                first_in.set()
            if wait is not None:
                wait.wait(10)
            time.sleep(0.05)
            inside.remove(k)
            order.append(f"out {k}")

    threads = [threading.Thread(target=holder, args=(0, False, release))]
    threads[0].start()
    assert first_in.wait(10)
    threads.append(threading.Thread(target=holder, args=(1, True, None)))
    threads[1].start()
    # the exclusive request is waiting once it holds the turn (a probe cannot take it): no timing assumed
    with open(f"{path}.turn", "a+") as probe:
        deadline = time.monotonic() + 30
        while True:
            try:
                fcntl.flock(probe, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                break
            fcntl.flock(probe, fcntl.LOCK_UN)
            assert time.monotonic() < deadline, "the exclusive request never asked"
            time.sleep(0.01)
    threads.append(threading.Thread(target=holder, args=(2, False, None)))
    threads[2].start()
    time.sleep(0.3)  # were the later shared request let in before the exclusive one, it would be in by now
    assert order == ["in 0"], order  # neither the exclusive nor the later shared request entered
    release.set()
    for t in threads:
        t.join(10)
    assert order == ["in 0", "out 0", "in 1", "out 1", "in 2", "out 2"], order
    for lock in locks:
        lock.close()


def test_the_pass_refuses_an_unmarked_job_of_several_ranks(tmp_path):
    """A pytest run with --cores-lock (the repository's conftest as a plugin): the test that starts `mpirun -n 2`
    without the mark fails naming itself and the mark; the marked one runs it."""
    tests = tmp_path / "test_jobs.py"
    tests.write_text(
        "import subprocess\nimport pytest\n\n"
        "def test_unmarked():\n    subprocess.run(['mpirun', '-n', '2', 'true'], check=True)\n\n"
        "def test_one_rank():\n    subprocess.run(['mpirun', '-n', '1', 'true'], check=True)\n\n"
        "@pytest.mark.multirank\n"
        "def test_marked():\n    subprocess.run(['mpirun', '-n', '2', 'true'], check=True)\n")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM_WORLD", "PMIX_", "PMI_"))}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "tests"), str(ROOT)])
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "conftest",
                           "--rootdir", str(ROOT), "-c", str(ROOT / "pyproject.toml"),
                           "--cores-lock", str(tmp_path / "cores.lock"), str(tests)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300, env=env)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 1, out
    assert "1 failed, 2 passed" in out, out
    assert "test_unmarked starts a job of 2 ranks but is not marked multirank" in out, out
