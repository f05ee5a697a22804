"""The machine's cores shared by the serial pass's shards side by side (``make test-serial``).

Each shard is one process on one core. A test that starts a job of several ranks (``mpirun -n 2``, ``-n 3``)
needs every core while it runs: beside another shard its ranks wait for each other in busy-polling collectives
while the scheduler gives their cores away (measured: the reproducibility test's ILU case 7 s alone, 18 s beside
one busy process, with or without ``mpi_yield_when_idle``). Such a test is marked ``multirank`` and runs alone:
the shards share a lock file, every test holds it shared, a ``multirank`` test exclusively, so the other shards
wait between two of their tests while it runs. A second file, held while a test asks for the first, gives the
exclusive request precedence over the shared ones that arrive after it (no shard starves).

:func:`ranks_of` reads the ranks of a command, so that the serial pass refuses a test that starts a job of
several ranks without the mark (tests/conftest.py).
"""

from __future__ import annotations

import fcntl
import os
import shlex
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

__all__ = ["CoresLock", "ranks_of"]

LAUNCHERS = ("mpirun", "mpiexec", "orterun", "prterun")


def ranks_of(args: str | bytes | os.PathLike | Sequence[str | bytes | os.PathLike]) -> int:
    """The ranks a command starts: the value of ``-n``/``-np``/``--n``/``--np`` (also ``-n=N``) after an MPI
    launcher as its first word; 1 for any other command or a launcher without the option."""
    if isinstance(args, (str, bytes, os.PathLike)):
        words = shlex.split(os.fsdecode(args))
    else:
        words = [os.fsdecode(a) for a in args]
    if not words or os.path.basename(words[0]) not in LAUNCHERS:
        return 1
    for k, word in enumerate(words[1:], start=1):
        name, _, value = word.partition("=")
        if name in ("-n", "-np", "--n", "--np", "-c"):
            value = value or (words[k + 1] if k + 1 < len(words) else "")
            return int(value) if value.isdigit() else 1
    return 1


class CoresLock:
    """The shards' lock on the cores (a writer-preferring shared/exclusive lock over two ``flock`` files).

    Args:
        path: The lock file, the same for every shard (created when missing); ``path + ".turn"`` is the second.
    """

    def __init__(self, path: Path) -> None:
        self._main = open(path, "a+")  # held for the session
        self._turn = open(f"{path}.turn", "a+")

    @contextmanager
    def hold(self, alone: bool) -> Iterator[None]:
        """Hold the cores for one test: shared, or ``alone`` (exclusively)."""
        fcntl.flock(self._turn, fcntl.LOCK_EX)
        try:
            fcntl.flock(self._main, fcntl.LOCK_EX if alone else fcntl.LOCK_SH)
        except BaseException:
            fcntl.flock(self._turn, fcntl.LOCK_UN)
            raise
        if not alone:
            fcntl.flock(self._turn, fcntl.LOCK_UN)
        try:
            yield
        finally:
            fcntl.flock(self._main, fcntl.LOCK_UN)
            if alone:
                fcntl.flock(self._turn, fcntl.LOCK_UN)

    def close(self) -> None:
        """Close the lock files (releases nothing held: call outside :meth:`hold`)."""
        self._main.close()
        self._turn.close()
