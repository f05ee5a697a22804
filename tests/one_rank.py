"""One-rank references of the tests that compare a run on all ranks with one rank alone (marker
``compares_ranks``), computed side by side.

Such a test solves its case on the communicator (a module fixture) and compares it with the same case solved on one
rank alone (``MPI.COMM_SELF``). Computed inside each test on rank 0, every reference left the other ranks waiting
(40 s of the 2-rank pass of tests/problems, one core idle). Registered with :func:`one_rank_reference`, the
references the session's selected tests ask for are computed together the first time one is asked for: each on one
rank, the costliest first, each to the rank with the least cost so far, then shared with every rank
(:func:`compute_references`). A reference is the same function on ``MPI.COMM_SELF`` as before, so the same bits
on whichever rank it runs. A failing reference fails the tests that ask for it, with its error, on every rank (no
rank is left in a collective call).
"""

from __future__ import annotations

import traceback
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, TypeVar

from mpi4py import MPI

__all__ = ["Reference", "References", "compute_references", "one_rank_reference", "registered"]

F = TypeVar("F", bound=Callable[[], Any])


@dataclass(frozen=True)
class Reference:
    """A one-rank reference: ``compute()`` solves the case on ``MPI.COMM_SELF``; ``cost`` its measured seconds."""

    key: str
    compute: Callable[[], Any]
    cost: float


_REGISTRY: dict[str, dict[str, Reference]] = {}  # by module name, then by function name


def one_rank_reference(cost: float) -> Callable[[F], F]:
    """Register a module-level function without arguments that computes a one-rank reference (on
    ``MPI.COMM_SELF``, returning something picklable); ``cost``: its measured seconds, to balance the ranks."""

    def register(compute: F) -> F:
        key = f"{compute.__module__}.{compute.__name__}"
        _REGISTRY.setdefault(compute.__module__, {})[compute.__name__] = Reference(key, compute, float(cost))
        return compute

    return register


def registered(modules: Iterable[str]) -> list[Reference]:
    """The references registered by the given modules, in a fixed order (the same on every rank)."""
    return [_REGISTRY[m][name] for m in sorted(set(modules)) if m in _REGISTRY for name in sorted(_REGISTRY[m])]


class References:
    """The computed references, by their function: ``references[fn]`` is ``fn()``'s result (collective-free)."""

    def __init__(self, values: dict[str, Any], errors: dict[str, str]) -> None:
        self._values = values
        self._errors = errors

    def __getitem__(self, compute: Callable[[], Any]) -> Any:
        key = f"{compute.__module__}.{compute.__name__}"
        if key in self._errors:
            raise AssertionError(f"the one-rank reference {key} failed:\n{self._errors[key]}")
        if key not in self._values:
            raise KeyError(f"{key} is not a registered one-rank reference of this session's tests")
        return self._values[key]


def compute_references(comm: MPI.Comm, references: list[Reference]) -> References:
    """Compute every reference on one rank of ``comm`` (the costliest first, each to the rank with the least cost
    so far; ties to the lower rank) and share the results (collective)."""
    loads = [0.0] * comm.size
    mine: list[Reference] = []
    for ref in sorted(references, key=lambda r: (-r.cost, r.key)):
        rank = loads.index(min(loads))
        loads[rank] += ref.cost
        if rank == comm.rank:
            mine.append(ref)
    values: dict[str, Any] = {}
    errors: dict[str, str] = {}
    for ref in mine:
        try:
            values[ref.key] = ref.compute()
        except Exception:  # reported by the tests that ask for it, on every rank
            errors[ref.key] = traceback.format_exc()
    merged_values: dict[str, Any] = {}
    merged_errors: dict[str, str] = {}
    for part_values, part_errors in comm.allgather((values, errors)):
        merged_values.update(part_values)
        merged_errors.update(part_errors)
    return References(merged_values, merged_errors)
