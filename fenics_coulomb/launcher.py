"""The process around a command: interrupts end every rank, a failure ends quietly with its exit status.

:func:`_end_on_signals` turns SIGINT/SIGTERM/SIGHUP into one line (into mpirun's terminal or pipe too when mpirun
may drop it: :func:`_to_launcher_stderr`) and ``MPI_Abort(128 + signal)`` (never an unwinding through PETSc, never a
hang);
:func:`exit_status` and :func:`run_command` finalize MPI on every rank together and end rank 0 with the status (the
launcher prints nothing more)."""

from __future__ import annotations

import os
import signal
import stat
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


def _to_launcher_stderr(line: str) -> None:
    """Write ``line`` where mpirun's own stderr goes too, since mpirun may drop what the ranks write.

    A signal to mpirun — Ctrl-C in its terminal (it reaches mpirun alone: PRRTE starts each rank in a process group
    of its own), a batch system ending the job — makes it send SIGTERM to the ranks and stop relaying their output,
    so the line a rank writes to its stderr (a pipe to mpirun) never appears, and with it where a load path's
    completed solves are kept. A rank whose parent is mpirun (``prterun``/``mpirun``/``orterun``) writes the line to
    that parent's stderr as well (``/proc/PPID/fd/2``) when it is a terminal or a pipe (``| tee log``), SIGTTOU
    ignored (a terminal set to ``stty tostop`` would otherwise stop the rank, which is not in the
    foreground group), never blocking. Nothing changes under other launchers (srun's parent is a daemon) or
    without a launcher. The price: SIGTERM sent by hand to one rank, while mpirun still relays, shows the line twice.
    """
    if not _LAUNCHED or not _launcher_parent():
        return
    target = f"/proc/{os.getppid()}/fd/2"
    try:
        # a terminal or a pipe only: into a log file mpirun writes at its own offset, and its abort banner would
        # overwrite the line
        mode = os.stat(target).st_mode
        if not (stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)):
            return
        signal.signal(signal.SIGTTOU, signal.SIG_IGN)
        fd = os.open(target, os.O_WRONLY | os.O_APPEND | os.O_NOCTTY | os.O_NONBLOCK)
    except (OSError, ValueError):  # mpirun gone, or its stderr closed
        return
    try:
        os.write(fd, (line + "\n").encode())
    except OSError:  # a full or hung-up terminal, a closed pipe: the line on stderr stands
        pass
    finally:
        os.close(fd)


def _launcher_parent() -> bool:
    """Whether this process's parent is Open MPI's launcher."""
    try:
        with open(f"/proc/{os.getppid()}/comm") as f:
            return f.read().strip() in ("prterun", "mpirun", "mpiexec", "orterun")
    except OSError:
        return False


#: Whether this process was started by an MPI launcher (mpirun's PMIx server sets PMIX_RANK, srun's too).
_LAUNCHED = "PMIX_RANK" in os.environ or "OMPI_COMM_WORLD_SIZE" in os.environ


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
        line = f"fenics-coulomb: interrupted by {signal.Signals(signum).name} on rank {comm.rank}; ending all " \
               f"ranks{kept}"
        print(line, file=sys.stderr, flush=True)
        if signum == signal.SIGTERM and (kept or comm.rank == 0):
            _to_launcher_stderr(line)
        comm.Abort(EXIT_INTERRUPTED + signum)

    previous: dict[int, object] = {}
    try:
        for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            previous[signum] = signal.signal(signum, handler)
    except ValueError:  # not the main thread (e.g. main() called from a worker thread): keep the defaults
        pass
    return previous

