"""An interrupted load path keeps the result set of its completed solves (io/results.py): the set is kept only in a
complete state, an interrupt during an update waits for it, one rank claims the set, and nothing that is not a
result set is replaced. Rank-local file operations (the real command on 2 ranks: tests/cli/test_interrupts.py)."""

from __future__ import annotations

import json
import shutil

from mpi4py import MPI

import pytest

from fenics_coulomb.io import results
from fenics_coulomb.io.results import ResultDirectory, abandon_results, defer_interrupt

pytestmark = pytest.mark.serial  # rank-local: each rank would repeat the same file operations


class Ended(Exception):
    """Stands for MPI_Abort: the interrupt's handling ends the run here."""


def _ending(record: list[str]):
    def end() -> None:
        record.append(abandon_results())
        raise Ended

    return end


def _write(directory, name: str, text: str = "{}") -> None:
    (directory / name).write_text(text)


def _rest(directory) -> None:
    """The rest of a kept set, written when it is kept."""
    _write(directory, "view.py", "# kept")


def test_the_interrupt_waits_for_the_update_and_keeps_the_complete_set(tmp_path):
    out = ResultDirectory(MPI.COMM_SELF, tmp_path / "out")
    ended: list[str] = []
    with pytest.raises(Ended), out.writing() as tmp:
        _write(tmp, "summary.json", json.dumps({"converged": False}))
        out.keep_on_interrupt(tmp, "one solve kept", _rest)
        out.updating(tmp)
        assert defer_interrupt(_ending(ended))  # the set is between two complete states: the interrupt waits
        assert not defer_interrupt(_ending(ended))  # a second interrupt does not
        assert ended == []
        _write(tmp, "path.csv", "solve\n1\n2\n")
        out.keep_on_interrupt(tmp, "two solves kept", _rest)  # complete again: the waiting interrupt ends the run now
    assert ended == ["; two solves kept"]
    kept = tmp_path / "out.interrupted"
    assert sorted(p.name for p in kept.iterdir()) == ["path.csv", "summary.json", "view.py"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.interrupted"]  # no partial set, no output yet


def test_a_set_written_to_its_end_is_removed(tmp_path):
    """After the last solve the set is written to its end (not complete before its commit): an interrupt that waited
    for an update, or one that comes then, removes it, as an interrupt of a static solve does."""
    out = ResultDirectory(MPI.COMM_SELF, tmp_path / "out")
    ended: list[str] = []
    with pytest.raises(Ended), out.writing() as tmp:
        _write(tmp, "summary.json")
        out.keep_on_interrupt(tmp, "kept", _rest)
        out.updating(tmp)
        assert defer_interrupt(_ending(ended))
        out.busy(tmp)
    assert ended == [""] and list(tmp_path.iterdir()) == []


def test_an_earlier_interrupted_set_is_replaced_but_nothing_else(tmp_path, monkeypatch):
    monkeypatch.setattr(results, "SETTLE_WAIT", 0.0)
    earlier = tmp_path / "out.interrupted"
    earlier.mkdir()
    _write(earlier, "summary.json", json.dumps({"converged": False, "old": True}))
    out = ResultDirectory(MPI.COMM_SELF, tmp_path / "out")
    with pytest.raises(KeyboardInterrupt), out.writing() as tmp:  # Ctrl-C without the command's handler
        _write(tmp, "summary.json", json.dumps({"converged": False, "new": True}))
        out.keep_on_interrupt(tmp, "new set", _rest)
        raise KeyboardInterrupt
    assert json.loads((earlier / "summary.json").read_text()) == {"converged": False, "new": True}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.interrupted"]
    # a directory of that name that is not a result set is the user's: never replaced, the set is removed
    shutil.rmtree(earlier)
    earlier.mkdir()
    _write(earlier, "notes.txt", "mine")
    ended: list[str] = []
    with pytest.raises(Ended), out.writing() as tmp:
        _write(tmp, "summary.json")
        out.keep_on_interrupt(tmp, "kept", _rest)
        _ending(ended)()
    assert ended == [""] and [p.name for p in earlier.iterdir()] == ["notes.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.interrupted"]


def test_one_rank_claims_the_set(tmp_path, monkeypatch):
    """Every interrupted rank settles the set (SIGTERM to every rank); the first rename claims it: the second rank
    neither keeps nor removes anything."""
    monkeypatch.setattr(results, "SETTLE_WAIT", 0.0)
    out = ResultDirectory(MPI.COMM_SELF, tmp_path / "out")
    with pytest.raises(Ended), out.writing() as tmp:
        _write(tmp, "summary.json")
        keep = (out.path, "kept", _rest)
        assert results._settle(tmp, keep) == "; kept"
        assert results._settle(tmp, keep) == "" and results._settle(tmp, None) == ""
        raise Ended
    assert sorted(p.name for p in (tmp_path / "out.interrupted").iterdir()) == ["summary.json", "view.py"]


def test_a_set_whose_rest_cannot_be_written_is_not_kept(tmp_path, monkeypatch):
    """The rest of the set fails (a full disk): nothing is kept, nothing named, the earlier interrupted set stays."""
    monkeypatch.setattr(results, "SETTLE_WAIT", 0.0)
    earlier = tmp_path / "out.interrupted"
    earlier.mkdir()
    _write(earlier, "summary.json", json.dumps({"old": True}))

    def full(directory) -> None:
        raise OSError(28, "No space left on device")

    out = ResultDirectory(MPI.COMM_SELF, tmp_path / "out")
    ended: list[str] = []
    with pytest.raises(Ended), out.writing() as tmp:
        out.keep_on_interrupt(tmp, "kept", full)
        _ending(ended)()
    assert ended == [""] and json.loads((earlier / "summary.json").read_text()) == {"old": True}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.interrupted"]

