"""The process around a command: interrupts end every rank, a failure ends quietly with its exit status.

:func:`_end_on_signals` turns SIGINT/SIGTERM/SIGHUP into one line and ``MPI_Abort(128 + signal)`` (never an
unwinding through PETSc, never a hang); :func:`exit_status` and :func:`run_command` finalize MPI on every rank
together and end rank 0 with the status (the launcher prints nothing more)."""

from __future__ import annotations

import os
import signal
import sys
import time
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

from fenics_coulomb.errors import EXIT_INTERRUPTED

__all__ = ["exit_status", "QUIET_EXIT_DELAY"]


def exit_status(status: int, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """The process's exit status for the command ``status`` of :func:`main` (collective; call it once, as the
    program ends: it finalizes MPI).

    Under mpirun a rank that exits non-zero while others still run makes OpenMPI print a block about "one or more
    processes exited with non-zero status" after our one-line message, and the PMIx server sometimes a
    "PMIX ERROR: PMIX_ERR_UNREACH" line. So on a failure every rank synchronizes and finalizes MPI, the other
    ranks end with 0 and rank 0, a moment later, with the status, which mpirun (and srun: the largest status of
    its tasks) then reports alone: the launcher stays quiet. A failure ends without Python's shutdown (the
    streams flushed, PETSc and MPI finalized): no destructor runs after MPI or on a file a failed write broke.
    """
    if status == 0:
        return status
    sys.stdout.flush()
    sys.stderr.flush()
    comm.Barrier()
    rank, size = comm.rank, comm.size
    PETSc._finalize()
    MPI.Finalize()
    if rank == 0 and size > 1:
        time.sleep(QUIET_EXIT_DELAY)
    # no destructor may run after MPI (DOLFINx's objects at shutdown), nor one of a file a failed write left
    # broken (HDF5 crashed closing it at exit)
    os._exit(status if rank == 0 else 0)


#: Rank 0 ends this long after the others on a failure (:func:`exit_status`).
QUIET_EXIT_DELAY = 0.2


def _finish_together(comm: MPI.Comm) -> None:
    """Synchronize the ranks before a non-zero exit: mpirun ends the job at the first non-zero exit, and a
    rank that is still starting up or finalizing then prints PMIx errors after the one-line message."""
    comm.Barrier()


def _end_on_signals(comm: MPI.Comm) -> dict[int, Any]:
    """End the run at once on SIGINT, SIGTERM and SIGHUP: one line on stderr, the partial result set removed (a load
    path's completed solves kept as NAME.interrupted, :func:`~fenics_coulomb.io.results.abandon_results`), and
    MPI_Abort with 128 + the signal (every rank ends; the earlier results stay untouched). Aborting from the
    handler, not by unwinding the stack: the signal may arrive inside a PETSc call (the matrix-free operator's
    mult runs in Python inside GMRES and a multigrid cycle), after which the PETSc objects are in no state to be
    destroyed collectively. Returns the previous handlers."""
    def handler(signum: int, frame: object) -> None:
        from fenics_coulomb.io.results import abandon_results, defer_interrupt

        if defer_interrupt(lambda: handler(signum, frame)):  # a load path writing its next solve: until it is done
            return
        kept = abandon_results()  # a load path's completed solves: "; … kept in NAME.interrupted …"
        print(f"fenics-coulomb: interrupted by {signal.Signals(signum).name} on rank {comm.rank}; ending all "
              f"ranks{kept}", file=sys.stderr, flush=True)
        comm.Abort(EXIT_INTERRUPTED + signum)

    previous: dict[int, object] = {}
    try:
        for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            previous[signum] = signal.signal(signum, handler)
    except ValueError:  # not the main thread (e.g. main() called from a worker thread): keep the defaults
        pass
    return previous

