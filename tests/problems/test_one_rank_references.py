"""The one-rank references of the tests that compare ranks (tests/one_rank.py): each computed on one rank, the
costliest first to the least loaded rank, the results the same on every rank, a failure reported on every rank."""

from __future__ import annotations

from mpi4py import MPI

import pytest

from one_rank import Reference, compute_references, registered


def where() -> tuple[int, int]:
    return MPI.COMM_WORLD.rank, MPI.COMM_SELF.size


def fails() -> None:
    raise ValueError("a reference that fails")


def test_each_reference_on_one_rank_balanced_and_shared():
    comm = MPI.COMM_WORLD
    costs = [20.0, 8.3, 6.3, 5.6, 1.0]
    refs = [Reference(f"r{k}", where, cost) for k, cost in enumerate(costs)]
    values = compute_references(comm, refs)._values
    assert sorted(values) == [f"r{k}" for k in range(len(costs))]
    assert all(size == 1 for _, size in values.values())
    # the greedy split: on 2 ranks 20 then 1.0 on rank 0 (21.0), 8.3 + 6.3 + 5.6 (20.2) on rank 1
    expected = {1: [0, 0, 0, 0, 0], 2: [0, 1, 1, 1, 0], 3: [0, 1, 2, 2, 1]}.get(comm.size)
    if expected is not None:
        assert [values[f"r{k}"][0] for k in range(len(costs))] == expected
    assert comm.allgather(values) == [values] * comm.size


def test_a_failing_reference_fails_its_tests_on_every_rank():
    comm = MPI.COMM_WORLD
    refs = [Reference(f"{fails.__module__}.fails", fails, 5.0), Reference(f"{where.__module__}.where", where, 1.0)]
    references = compute_references(comm, refs)
    with pytest.raises(AssertionError, match="a reference that fails"):
        references[fails]
    assert references[where][1] == 1
    with pytest.raises(KeyError, match="not a registered"):
        references[test_a_failing_reference_fails_its_tests_on_every_rank]


def test_registered_in_a_fixed_order():
    refs = registered(["test_two_body_cores", "test_mindlin_core", "no_such_module"])
    assert [r.key for r in refs] == sorted(r.key for r in refs)
    assert registered([]) == []
