"""Errors of fenics-coulomb and the collective check that raises them on every rank."""

from __future__ import annotations

import signal
from typing import Any

from mpi4py import MPI

__all__ = ["EXIT_DIVERGED", "EXIT_INPUT", "EXIT_INTERRUPTED", "EXIT_OUTPUT", "EXIT_STATUSES", "InputError",
           "OutputError", "Interrupted", "SolverError", "check_all"]


class InputError(ValueError):
    """A bad input value (exit status 2 on the command line)."""


class OutputError(OSError):
    """The result set could not be written (disk full, a file-size limit, a name too long, ...): exit status 4 on
    the command line; an earlier result set in the output directory is kept."""


class Interrupted(BaseException):
    """A termination signal (SIGTERM, SIGHUP) received by this rank; handled like KeyboardInterrupt (exit status
    128 + the signal number on the command line)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class SolverError(RuntimeError):
    """A solve that did not converge (exit status 3 on the command line).

    Attributes:
        reason: Short machine-readable cause ("max_iterations", "line_search", "ksp_breakdown",
            "ksp_limit", "non_finite").
        result: The partial result (last iterate and history) when one is available.
    """

    def __init__(self, message: str, reason: str, result: Any = None) -> None:
        super().__init__(message)
        self.reason = reason
        self.result = result


def check_all(comm: MPI.Comm, ok: bool, message: str, error: type[Exception] = InputError) -> None:
    """Raise ``error`` on every rank if the check failed on any rank.

    Every rank must call this (it is collective). The message of the lowest failing rank is raised.

    Args:
        comm: Communicator of the ranks that take part.
        ok: Local result of the check.
        message: Local message used when ``ok`` is False.
        error: Exception type to raise.
    """
    failures = comm.allgather(None if ok else message)
    for msg in failures:
        if msg is not None:
            raise error(msg)


#: The exit statuses of the command line (fenics_coulomb.cli).
EXIT_INPUT = 2
EXIT_DIVERGED = 3
EXIT_OUTPUT = 4
EXIT_INTERRUPTED = 128  # + the signal number (130 SIGINT, 143 SIGTERM), as a shell reports it
#: What each exit status guarantees (the --help epilog and the table of docs/scenes.md).
EXIT_STATUSES = {
    0: "solved: converged and the physics checks passed (summary.json physics_checks)",
    2: "bad input: one line naming the value; nothing was solved or written",
    3: "not converged, or the physics checks failed: the last iterate and the history are written (beside an "
       "earlier converged set in OUT, into OUT.not-converged)",
    4: "the results could not be written (disk full, a size limit): one line; the earlier results are kept",
    130: "interrupted (128 + the signal: 143 SIGTERM, 129 SIGHUP): every rank ended; the earlier results are "
         "kept, no partial set is left; a load path's completed solves are in OUT.interrupted (resumable)",
    1: "an unexpected error (a bug; it prints a traceback): please report it",
}
