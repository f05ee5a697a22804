"""A run's result directory: written whole or not at all.

Every rank writes into a temporary sibling ``.NAME.partial-HOST-PID-RAND`` that replaces NAME only when
the whole set is written (:class:`ResultDirectory`); a failed write, an interrupt or a not-converged solve
never replaces a converged earlier set (that one is written to ``NAME.not-converged``). An interrupted load path
keeps the set of its completed solves as ``NAME.interrupted`` (:meth:`ResultDirectory.keep_on_interrupt`). Files
written by rank 0 alone carry their failure to every rank (:func:`rank0_file`)."""

from __future__ import annotations

import contextlib
import errno
import functools
import glob
import json
import os
import re
import shlex
import shutil
import socket
import time
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from mpi4py import MPI

from fenics_coulomb.errors import Interrupted, OutputError

__all__ = ["ResultDirectory", "abandon_results", "defer_interrupt", "rank0_file", "room_for", "RESULT_FILES",
           "FAILED_SUFFIX", "INTERRUPTED_SUFFIX", "HDF5_OVERHEAD", "HDF5_OVERHEAD_PER_DATASET"]


class ResultDirectory:
    """The result set of a run, written as a whole: into a temporary sibling of the output directory, then
    renamed into place (MPI-aware: rank 0 checks and renames, every rank writes into the temporary directory).
    A run that did not converge (``failed``) never replaces a converged set: it goes to ``NAME.not-converged``
    beside it.

    Until :meth:`writing` commits, an existing result set stays untouched; if writing fails the temporary
    directory is removed. The output directory belongs to the run: an existing one is replaced as a whole,
    except for entries that the previous run did not write (listed in its ``summary.json`` "files"), which are
    carried over. A non-empty directory that is not a fenics-coulomb result set is refused.
    """

    MANIFEST = "summary.json"
    #: Set by the caller before the set is committed: the run did not converge (:meth:`writing`).
    failed: bool = False
    #: The committed set's directory as (device, inode) (rank 0): :meth:`add` adds to it only while it is there.
    _identity: tuple[int, int] | None = None

    def __init__(self, comm: MPI.Comm, path: str | Path, name: str = "--out") -> None:
        """Check that the result set can be written to ``path`` (collective; InputError on every rank); ``name``
        is what the messages call it (the command's flag, or the API's argument)."""
        from fenics_coulomb.errors import check_all

        self.comm = comm
        self.given = str(path)
        self.name = name
        final = Path(path)
        self.path = final.absolute()
        #: Where the last set went (:meth:`writing`): the output directory, or for a failed run beside an earlier
        #: converged set, ``NAME.not-converged``.
        self.committed = self.path
        check_all(comm, not (message := self._check_name()), message)  # pure: every rank, before the file system
        message = ""
        if comm.rank == 0:
            if final.is_symlink():
                self.path = Path(os.path.realpath(final)).absolute()
            message = self._check()
        message, self.path = comm.bcast((message, self.path), root=0)  # a symlink resolved on rank 0: every rank's
        check_all(comm, not message, message)

    def _check_name(self) -> str:
        """"" if every component of the path fits the file system, with room for the temporary directory's tail
        (the set is written into ".NAME.partial-HOST-PID-RANDOM" first)."""
        tail = len(f"..partial-{_owner()}-00000000".encode())
        for i, part in enumerate(self.path.parts):
            limit = 255 - (tail if i == len(self.path.parts) - 1 else 0)
            if len(part.encode()) > limit:
                shown = part if len(part) <= 40 else part[:37] + "..."
                return (f"{self.name}: the name {shown!r} has {len(part.encode())} bytes; at most {limit} fit a file "
                        "name here")
        return ""

    def _check(self) -> str:
        prefix = f"{self.name} {self.given!r}"
        try:
            cwd = Path.cwd()
            if self.path == cwd or self.path in cwd.parents:
                return f"{prefix}: the output directory would replace the current directory or one above it"
            if self.path.exists():
                if not self.path.is_dir():
                    return f"{prefix}: exists and is not a directory"
                if any(self.path.iterdir()) and not (self.path / self.MANIFEST).is_file():
                    return (f"{prefix}: a non-empty directory that is not a fenics-coulomb result set (no "
                            f"{self.MANIFEST}); refusing to replace it")
            self.path.parent.mkdir(parents=True, exist_ok=True)
            probe = self.path.parent / f".{self.path.name}.probe-{os.getpid()}"
            probe.mkdir()
            probe.rmdir()
        except (OSError, ValueError) as err:  # ValueError: a NUL in the name
            return f"{prefix}: output directory is not writable ({getattr(err, 'strerror', None) or err})"
        return ""

    @contextlib.contextmanager
    def writing(self) -> Iterator[Path]:
        """Yield the temporary directory to write the result set into; commit it on success (collective).

        The temporary directory is named ``.NAME.partial-HOST-PID-RANDOM`` after rank 0's host and process, so that
        a later run into the same parent removes what a run that was killed left behind (:meth:`clean_stale`).
        On an exception (an interrupt included) every rank that sees it removes the temporary directory at once
        (no communication: the run ends, and a rank waiting for another must not keep it) and the exception
        propagates. Rank-0-only files that fail (:func:`rank0_file`) fail the set on every rank together:
        :class:`~fenics_coulomb.errors.OutputError`, one line, with the earlier result set kept.
        """
        if self.comm.rank == 0:
            self.clean_stale()
        _FINISHED.clear()
        tmp_path = self._temporary("the results cannot be written")
        errors: list[str] = []
        _DEFERRED.append(errors)
        _WRITING.add(tmp_path)
        try:
            yield tmp_path
        except BaseException as err:
            keep = _KEEPABLE.get(tmp_path) if isinstance(err, KeyboardInterrupt | Interrupted) else None
            kept = _settle(tmp_path, keep)
            _release(tmp_path)
            if kept:
                err.kept = kept  # type: ignore[attr-defined]  # the end of the interrupt's line (cli)
            _UPDATING.discard(tmp_path)
            raise
        finally:
            _DEFERRED.remove(errors)
            _WRITING.discard(tmp_path)
            _KEEPABLE.pop(tmp_path, None)
            _run_deferred()
        committed = False
        try:
            self._commit_set(tmp_path, errors)
            committed = True
            if self.comm.rank == 0:  # what an interrupt from now on says (rank 0's line alone names it)
                _FINISHED[:] = [f"; the run had {'ended' if self.failed else 'finished'}: its results are in "
                                f"{shlex.quote(str(self.committed))}"]
        finally:  # an interrupt that waited for the set (a load path's last write) ends the run now
            _release(tmp_path)
            if tmp_path in _UPDATING and _PENDING:
                _COMMITTED.append(f"; the path had finished: its results are in {self.committed}" if committed else
                                  "; the path had finished, but its results could not be written (the earlier "
                                  "results are kept)")
            _UPDATING.discard(tmp_path)
            _run_deferred()

    def _commit_set(self, tmp_path: Path, errors: list[str]) -> None:
        """Commit the written set ``tmp_path`` (collective; :meth:`writing`)."""
        failed = [e for e in self.comm.allgather(errors[0] if errors else "") if e]
        error = None
        if failed:
            error = f"results could not be written into {self.given} ({failed[0]}); the earlier results are kept"
            if self.comm.rank == 0:
                shutil.rmtree(tmp_path, ignore_errors=True)
        elif self.comm.rank == 0:
            target = self.path
            if self.failed and self._holds_converged_set():  # a failed run never replaces a solution
                target = self.path.with_name(f"{self.path.name}{FAILED_SUFFIX}")
            try:
                self._commit(tmp_path, target)
                self.committed = target
                self._identity = _identity(target)
            except OSError as err:
                error = (f"results could not be moved into {target}: {err.strerror or err} (the complete set is "
                         f"kept in {tmp_path})")
        error, self.committed = self.comm.bcast((error, self.committed), root=0)
        if error:
            raise OutputError(error)

    def add(self, write: Callable[[Path], list[str]], note: Callable[[str], str]) -> list[str]:
        """Add files to the set committed last (collective; after :meth:`writing`): ``write`` writes them into a
        temporary sibling ``.NAME.partial-HOST-PID-RAND`` (every rank calls it: it may communicate) and returns
        their names, the same on every rank; rank 0 then moves each into the committed set, replacing a file of
        that name (``summary.json``: the manifest that lists them, moved last). For what is slow and never costs
        the results, e.g. the figures: the committed set is whole before they are started, and an interrupt
        meanwhile ends the run at once — under mpirun the ranks have 250 ms between its SIGTERM and its SIGKILL,
        a set being :meth:`updating` a few milliseconds — with the set as committed, without the files, and its
        line ending in ``"; " + note(the committed set's place, quoted for a shell)``. Nothing is added when the
        committed directory is no longer this run's (another run into the same place committed meanwhile:
        OutputError). An error in ``write`` is raised after the temporary directory is removed; returns the names
        added."""
        staging = self._temporary("files cannot be added to the results")
        # rank 0's line names the set (every rank's would: the same line twice in mpirun's terminal)
        _ADDING[staging] = f"; {note(shlex.quote(str(self.committed)))}" if self.comm.rank == 0 else ""
        errors: list[str] = []  # of rank-0-only files (rank0_file): raised on every rank together
        try:
            _DEFERRED.append(errors)
            try:
                names = write(staging)
            finally:
                _DEFERRED.remove(errors)
            replaced = self.comm.rank == 0 and _identity(self.committed) != self._identity
            if replaced and not errors:  # another run committed into the same place meanwhile: not ours to add to
                errors.append("\0")
            if self.comm.rank == 0 and not errors:
                name = ""
                _UPDATING.add(staging)  # the moves (milliseconds): an interrupt waits for the manifest to match
                try:
                    for name in sorted(names, key=lambda n: n == self.MANIFEST):  # the manifest last
                        os.replace(staging / name, self.committed / name)
                except OSError as err:
                    errors.append(f"{name}: {err.strerror or err}")
                finally:
                    _ADDING.pop(staging, None)  # moved (or not): the set as it now is
                    _UPDATING.discard(staging)
                    _run_deferred()
            failed = [e for e in self.comm.allgather(errors[0] if errors else "") if e]
            if failed and failed[0] == "\0":
                raise OutputError(f"files were not added to {self.committed}: another run's set replaced this run's "
                                  "there meanwhile")
            if failed:
                raise OutputError(f"files could not be added to the results in {self.committed} ({failed[0]}); the "
                                  "results are there without them")
            return names
        finally:
            _ADDING.pop(staging, None)
            if self.comm.rank == 0:
                shutil.rmtree(staging, ignore_errors=True)
            _release(staging)

    def _temporary(self, failure: str) -> Path:
        """A new temporary sibling ``.NAME.partial-HOST-PID-RANDOM`` made by rank 0, after its host and process
        (collective; :meth:`clean_stale` removes it once that process is gone); OutputError "``failure`` (reason)"
        on every rank if it cannot be made."""
        tmp = ""
        if self.comm.rank == 0:
            tail = f"{_owner()}-{uuid.uuid4().hex[:8]}"
            tmp = str(self.path.parent / f".{self.path.name}.partial-{tail}")
            # made under a name clean_stale does not look at, locked, then renamed: another run's clean_stale never
            # sees it unlocked
            making = self.path.parent / f".{self.path.name}.making-{tail}"
            try:
                os.mkdir(making)
                _hold(making)
                os.rename(making, tmp)
                if making in _LOCKS:  # the lock is the inode's: it moves with the name
                    _LOCKS[Path(tmp)] = _LOCKS.pop(making)
            except OSError as err:
                _release(making)
                tmp = f"\0{err.strerror or err}"
        tmp = self.comm.bcast(tmp, root=0)
        if tmp.startswith("\0"):
            raise OutputError(f"{self.name} {self.given!r}: {failure} ({tmp[1:]})")
        return Path(tmp)

    def keep_on_interrupt(self, tmp: Path, note: Callable[[str], str], complete: Callable[[Path], None]) -> None:
        """Mark the temporary set ``tmp`` as complete so far but for the files ``complete`` writes (on this rank
        alone, into the directory it is given): its files describe finished work (a load path's completed solves,
        between two solves). An interrupt on this rank then completes it and moves it to the first free name of
        ``NAME.interrupted``, ``NAME.interrupted-2``, … (no earlier set is replaced) instead of removing it
        (:func:`abandon_results`), naming it with ``note(the place, quoted for a shell)``; an interrupt deferred while
        the set was :meth:`updating` ends the run now. No communication: call it on every rank after a point that
        every rank reaches only when all of the set's files are written (a barrier)."""
        _KEEPABLE[tmp] = (self.path, note, complete)
        _UPDATING.discard(tmp)
        _run_deferred()

    @staticmethod
    def updating(tmp: Path) -> None:
        """The set ``tmp`` is being written (a load path's next solve, or its end): an interrupt on this rank waits
        for :meth:`keep_on_interrupt`, or for the set's commit (then the run ends with the whole set in place); a
        second interrupt within :data:`REPEAT_WINDOW` is the same one, a later one ends the run at once, removing
        the set. Every rank is in the same write — its collective calls hold the ranks together — so the wait is
        that of one solve's output."""
        _KEEPABLE.pop(tmp, None)
        _UPDATING.add(tmp)

    def _holds_converged_set(self) -> bool:
        """Whether the output directory holds the result set of a run that converged (rank 0)."""
        try:
            return bool(json.loads((self.path / self.MANIFEST).read_text()).get("converged"))
        except (OSError, ValueError, AttributeError):
            return False

    def clean_stale(self) -> None:
        """Remove temporary siblings (``.NAME.partial-*``, ``.NAME.previous-*``) of runs that are gone (rank 0 only;
        no communication): a temporary set whose lock no process holds (:func:`_held`; every run in container/run
        is in a PID namespace of its own, where rank 0 of every ``mpirun -n 2`` is process 5, so a process number
        tells nothing there), else one of this host whose process is gone."""
        host = _owner().rsplit("-", 1)[0]
        for kind in ("partial", "previous"):
            prefix = f".{self.path.name}.{kind}-"
            for entry in self.path.parent.glob(f"{glob.escape(prefix)}*"):
                held = _held(entry) if kind == "partial" else None  # a previous set lives milliseconds
                if held is not None:  # the lock its writer holds (_temporary) tells, in any PID namespace
                    if not held:
                        shutil.rmtree(entry, ignore_errors=True)
                    continue
                owner_host, pid = _split_owner(entry.name[len(prefix):])
                # this process's number: ours, or another sandbox's run (each numbers its processes from 1)
                if owner_host != host or not pid.isdigit() or int(pid) == os.getpid():
                    continue
                try:
                    os.kill(int(pid), 0)
                except ProcessLookupError:
                    shutil.rmtree(entry, ignore_errors=True)
                except OSError:  # alive under another user: not ours to remove
                    continue

    def _commit(self, tmp: Path, target: Path) -> None:
        """Rename the new set to ``target``; carry over foreign entries of the previous one; drop the rest."""
        if not target.exists():
            os.rename(tmp, target)
            return
        previous = target.parent / f".{target.name}.previous-{_owner()}-{uuid.uuid4().hex[:8]}"
        os.rename(target, previous)
        os.rename(tmp, target)
        ours = set(RESULT_FILES)
        with contextlib.suppress(OSError, ValueError, TypeError):
            ours |= set(json.loads((previous / self.MANIFEST).read_text()).get("files", []))
        for entry in previous.iterdir():
            if entry.name not in ours and not (target / entry.name).exists():
                os.rename(entry, target / entry.name)
        shutil.rmtree(previous, ignore_errors=True)


#: Seconds after a waiting interrupt within which another signal is taken for the same interrupt (ignored); a later
#: one ends the run at once, giving up the set being written.
REPEAT_WINDOW = 2.0


def defer_interrupt(end: Callable[[], None]) -> bool:
    """Whether the interrupt whose handling is ``end`` is not handled now: an interrupt is being handled already
    (it ends the run: a second signal must not cut its renames short), one waits and this one follows it within
    :data:`REPEAT_WINDOW`, or a result set of this process is :meth:`updating <ResultDirectory.updating>` (``end``
    then runs when the set is complete again or committed)."""
    if _SETTLING:
        return True
    if _PENDING:  # a repeat within REPEAT_WINDOW is the same interrupt (a double Ctrl-C, a batch system's burst)
        return time.monotonic() - _PENDING_SINCE[0] < REPEAT_WINDOW
    if not _UPDATING:
        return False
    _PENDING.append(end)
    _PENDING_SINCE[:] = [time.monotonic()]
    return True


def _run_deferred() -> None:
    """Run an interrupt deferred by :func:`defer_interrupt` once no set of this process is being updated."""
    if _PENDING and not _UPDATING:
        _PENDING.pop()()


def abandon_results() -> str:
    """Remove the temporary directories of every result set this process is writing (for a run that ends now,
    e.g. on a signal, without unwinding: the earlier result sets stay untouched); one marked complete so far
    (:meth:`ResultDirectory.keep_on_interrupt`) is kept as ``NAME.interrupted`` instead; files being added to a
    committed set (:meth:`ResultDirectory.add`) are dropped, the set stays as committed. Returns "" or "; " + what
    became of the work (the end of the interrupt's line)."""
    _SETTLING.append(True)
    kept = _COMMITTED.pop() if _COMMITTED else ""
    for staging, note in list(_ADDING.items()):  # files being added to a committed set (ResultDirectory.add)
        shutil.rmtree(staging, ignore_errors=True)
        kept = note
    if not kept and not _WRITING and _FINISHED:  # the run's set is in place: where
        kept = _FINISHED[0]
    for path in list(_WRITING):
        kept = _settle(path, _KEEPABLE.pop(path, None)) or kept
        _WRITING.discard(path)
    return kept


#: Seconds at most that a rank which finds the temporary set claimed by another rank of the run waits for that rank
#: to finish with it (:func:`_settle`: the rest written, the set moved) before it ends the run, which would cut the
#: other rank short: milliseconds on an idle machine, longer beside other work.
SETTLE_WAIT = 10.0


def _settle(tmp: Path, keep: Keep | None) -> str:
    """Remove the temporary set ``tmp``, or with ``keep`` = (the output directory NAME, the note, the function that
    writes the rest of the set) complete it and move it to the first free name of NAME.interrupted,
    NAME.interrupted-2, … (no communication; no earlier set is replaced). Every rank that is interrupted settles the
    set; the first to rename it to a name of its own claims it (an atomic rename: no rank removes what another
    keeps), the others wait until it is done (at most :data:`SETTLE_WAIT`). A set whose rest cannot be written is
    removed, and the line says so. Returns "" or "; " + what became of it."""
    claimed = tmp.with_name(f"{tmp.name}x{os.getpid()}")  # still .NAME.partial-HOST-PID-RAND…: clean_stale's
    try:
        os.rename(tmp, claimed)
    except OSError:  # gone: another rank of the run claimed it (or it was never made); wait until it is done
        # (a rank whose write failed because another rank claimed the set, too: ending the run now would cut the
        # claiming rank short)
        deadline = time.monotonic() + SETTLE_WAIT
        while time.monotonic() < deadline and any(tmp.parent.glob(f"{glob.escape(tmp.name)}x*")):
            time.sleep(0.02)
        return ""
    if keep is None:
        shutil.rmtree(claimed, ignore_errors=True)
        return ""
    out, note, complete = keep
    try:
        complete(claimed)
        for k in range(1, 1000):
            target = out.with_name(out.name + INTERRUPTED_SUFFIX + (f"-{k}" if k > 1 else ""))
            if os.path.lexists(target):
                continue
            try:
                os.rename(claimed, target)  # onto a name made meanwhile by another process: that one is kept
                break
            except OSError as err:
                if err.errno not in (errno.EEXIST, errno.ENOTEMPTY, errno.EISDIR, errno.ENOTDIR):
                    raise
        else:
            raise OSError(f"{out.name}{INTERRUPTED_SUFFIX}-1 … -999 all exist")
    except (OSError, ValueError, TypeError) as err:  # a file of the rest (disk full, …)
        shutil.rmtree(claimed, ignore_errors=True)
        return f"; its completed solves could not be kept ({getattr(err, 'strerror', None) or err})"
    return f"; {note(shlex.quote(str(target)))}"


def rank0_file(write: Callable[..., None]) -> Callable[..., None]:
    """Make a writer that writes ``path`` (its first argument) on rank 0 alone safe inside
    :meth:`ResultDirectory.writing`: an OSError there (disk full, a file-size limit) is kept for the whole set
    instead of raised on rank 0 alone, which would leave the other ranks waiting in the next collective call; the
    set then fails on every rank together. Outside a result directory it raises as usual."""

    @functools.wraps(write)
    def wrapper(path: Path, *args: Any, **kwargs: Any) -> None:
        if not _DEFERRED:
            write(path, *args, **kwargs)
            return
        if _DEFERRED[-1]:  # an earlier file of the set failed: the set is lost anyway
            return
        try:
            write(path, *args, **kwargs)
        except OSError as err:
            _DEFERRED[-1].append(f"{Path(path).name}: {_io_reason(err)}")

    return wrapper


#: Files of a result set written before the manifest (``summary.json`` "files") existed.
RESULT_FILES = ("solution.xdmf", "solution.h5", "summary.json", "convergence.csv", "convergence.png",
                "contact_states.png", "deformed.png", "path.csv", "path.png", "view.py", "obstacles.xdmf",
                "obstacles.h5", "contact_pressure.png")


#: A run that did not converge writes its set here, beside the output directory, when that holds a converged set.
FAILED_SUFFIX = ".not-converged"
#: An interrupted load path leaves the set of its completed solves here, beside the output directory.
INTERRUPTED_SUFFIX = ".interrupted"


def _owner() -> str:
    """HOST-PID of this process, for the names of temporary result directories."""
    return f"{socket.gethostname().replace('-', '_')}-{os.getpid()}"


def _split_owner(rest: str) -> tuple[str, str]:
    """(host as :func:`_owner` writes it, pid) of the HOST-PID-RANDOM tail of a temporary result directory's name
    ("", "" if it has none)."""
    parts = rest.split("-")
    if len(parts) != 3:
        return "", ""
    return parts[0], parts[1]


#: Room kept for an HDF5 file's own metadata besides its data: a base and a share per dataset (bytes).
HDF5_OVERHEAD, HDF5_OVERHEAD_PER_DATASET = 256 * 1024, 16 * 1024


def room_for(file: Path, nbytes: int) -> str:
    """"" when ``file`` can grow by ``nbytes`` — within the process's file-size limit (RLIMIT_FSIZE, from its
    current size) and the free space of its file system — else the reason as the system would give it ("File too
    large", "No space left on device"). HDF5 must never meet either while writing: it then crashes when it closes
    the broken dataset (a segmentation fault, exit 59, the partial set left behind); checked first, the write
    fails in one line with the earlier results kept."""
    import errno
    import resource

    size = file.stat().st_size if file.exists() else 0
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY and size + nbytes > soft:
        return os.strerror(errno.EFBIG)
    try:
        stat = os.statvfs(file.parent)
    except OSError as err:
        return err.strerror or str(err)
    if nbytes > stat.f_bavail * stat.f_frsize:
        return os.strerror(errno.ENOSPC)
    return ""


def _io_reason(err: BaseException) -> str:
    """The reason of a failed write in a few words (HDF5 packs errno and its text into a long message)."""
    code = getattr(err, "errno", None)
    if not isinstance(code, int):
        found = re.search(r"errno = (\d+)", str(err))
        code = int(found.group(1)) if found else None
    if isinstance(code, int) and code > 0:
        return os.strerror(code)
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    return lines[0] if lines else type(err).__name__


#: Deferred write errors of rank-0-only files, one list per active :meth:`ResultDirectory.writing` (a stack).
_DEFERRED: list[list[str]] = []


#: The temporary directories of the result sets being written by this process (:func:`abandon_results`).
_WRITING: set[Path] = set()
#: Those of them complete so far, by their temporary directory: (the output directory, the note of the kept set,
#: the function that writes the rest of it) (:meth:`ResultDirectory.keep_on_interrupt`).
Keep = tuple[Path, Callable[[str], str], Callable[[Path], None]]
_KEEPABLE: dict[Path, Keep] = {}
#: Those being brought to their next complete state (:meth:`ResultDirectory.updating`).
_UPDATING: set[Path] = set()
#: The handling of an interrupt that waits for them (:func:`defer_interrupt`).
_PENDING: list[Callable[[], None]] = []
#: When the waiting interrupt arrived (time.monotonic()).
_PENDING_SINCE: list[float] = [0.0]
#: An interrupt is being handled (:func:`abandon_results`): a second signal leaves it to end the run.
_SETTLING: list[bool] = []
#: Where the last set this process committed went, as the end of an interrupt's line (rank 0).
_FINISHED: list[str] = []
#: The open directories whose shared lock marks this process's temporary sets as alive (:func:`_hold`).
_LOCKS: dict[Path, int] = {}


def _identity(directory: Path) -> tuple[int, int] | None:
    """(device, inode) of ``directory``, or None if it is gone."""
    try:
        st = os.stat(directory)
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _hold(tmp: Path) -> None:
    """Hold a shared lock on the temporary directory ``tmp`` while this process writes it (released when the
    process ends, however it ends: :func:`_held` then finds it free)."""
    import fcntl

    try:
        fd = os.open(tmp, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:  # a file system without locks: clean_stale falls back to the process number
        os.close(fd)
        return
    _LOCKS[tmp] = fd


def _release(tmp: Path) -> None:
    """Release :func:`_hold`'s lock on ``tmp`` (which may have been renamed since: the lock is the inode's)."""
    fd = _LOCKS.pop(tmp, None)
    if fd is not None:
        os.close(fd)


def _held(entry: Path) -> bool | None:
    """Whether a process holds the lock of the temporary directory ``entry`` (:func:`_hold`); None when that
    cannot be told (not a directory, no locks on its file system)."""
    import fcntl

    try:
        fd = os.open(entry, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return None
    finally:
        os.close(fd)
    return False


#: The temporary directories of files being added to a committed set, with the end of an interrupt's line
#: (:meth:`ResultDirectory.add`).
_ADDING: dict[Path, str] = {}
#: What a waiting interrupt reports when the set it waited for was committed (:meth:`ResultDirectory.writing`).
_COMMITTED: list[str] = []

