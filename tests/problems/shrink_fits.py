"""The small-sliding shrink fit at level 0 (``benchmarks.verification.shrink_fit``), solved once per method and
process for the two modules that check it: tests/problems/test_verification.py (against Lamé) and
tests/problems/test_finite_sliding_shrink.py (finite sliding against it).

Collective: every rank runs the same tests in the same order, so every rank solves (or reuses) alike. Holds plain
Python numbers only (no PETSc object) and hands out copies."""

from __future__ import annotations

import copy
from typing import Any

from mpi4py import MPI

import benchmarks.verification as verification

__all__ = ["small_shrink_fit"]

_SOLVED: dict[str, dict[str, Any]] = {}


def small_shrink_fit(method: str) -> dict[str, Any]:
    """``verification.shrink_fit(MPI.COMM_WORLD, method, 0)`` in small sliding (the benchmark's default), a copy of
    the first solve of this process."""
    assert verification.SHRINK_SLIDING == "small", verification.SHRINK_SLIDING
    if method not in _SOLVED:
        _SOLVED[method] = verification.shrink_fit(MPI.COMM_WORLD, method, 0)
    return copy.deepcopy(_SOLVED[method])
