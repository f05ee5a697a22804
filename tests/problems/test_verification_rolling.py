"""The fast subset of case 8 of the verification table (benchmarks/verification_rolling.py): tractive rolling of
a rigid roller on a plane-strain slice, a short roll from the pre-loaded start on the coarse test level
(h = 0.02 ≈ a/4.2, ten steps of h, no far-field correction).

What a short roll can check, with bounds of its own: the slice is plane strain (the contact nodes keep their held
u2 and stay in contact), the normal problem is 2D Hertz's (the closed nodes' half-width within one spacing h of
a = √(4PR/πE*)), the driving roller's traction on the block points backwards with partial slip (0 < Q < μP), the
stick zone lies at the LEADING edge (it holds the leading closed node, the trailing one slips) with the width
2a√(1 − Q/μP) to two spacings (its edges lie between nodes), and two ranks give one rank's P and Q to 1e-8.
Carter's creep law itself needs the steady state, which the table's rows reach (docs/verification §8). The steady
rule's remainder (``remaining``) is checked on geometric sequences: it is the distance to the limit.
"""

from __future__ import annotations

from mpi4py import MPI

import pytest

import math

from benchmarks.verification_rolling import MU, STEADY_STEPS, hertz_half_width, remaining, roll
from one_rank import one_rank_reference

CREEP = 0.01


@pytest.fixture(scope="module")
def rolled():
    return roll(MPI.COMM_WORLD, CREEP, level=-1, max_steps=10, cycle=0.0)


def test_short_roll_from_the_preload(rolled):
    r, h = rolled, rolled["h"]
    assert len(r["history"]) == r["preload_steps"] + 1 + 10 and r["corrections"] == []
    assert abs(r["a_nodes"] - hertz_half_width(r["P"])) <= h
    assert 0.0 < r["Q"] < MU * r["P"]
    leading = r["centre"] + r["a_nodes"] - h / 2  # the leading closed node
    trailing = r["centre"] - r["a_nodes"] + h / 2
    assert r["stick_to"] == pytest.approx(leading, abs=1e-9)
    assert r["stick_from"] > trailing + h / 2
    assert abs(r["stick_width"] - r["stick_width_ref"]) <= 2 * h


@one_rank_reference(cost=5.6)
def roll_alone():
    r = roll(MPI.COMM_SELF, CREEP, level=-1, max_steps=10, cycle=0.0)
    return {k: r[k] for k in ("P", "Q")}


@pytest.mark.compares_ranks
def test_one_rank_agrees(rolled, one_rank):
    """The same roll on one rank alone (MPI.COMM_SELF): P and Q to 1e-8."""
    one = one_rank[roll_alone]
    for key in ("P", "Q"):
        assert rolled[key] == pytest.approx(one[key], rel=1e-8), key


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_remaining_is_the_geometric_tail(sign):
    """Q_k = Q∞ + A r^k with r = exp(−Δ/L), from above and from below: ``remaining`` gives |Q∞ − Q_k|/|Q_k| times
    r^−(n−1) (the largest of the last n changes over n steps is the oldest), and keeps the largest when the last
    change falls to zero (jitter); nan before two windows exist."""
    step, length, limit, n = 0.02, 0.23, 0.0776, STEADY_STEPS
    r = math.exp(-step / length)
    qs = [limit + sign * 0.01 * r**k for k in range(30)]
    assert math.isnan(remaining(qs[:2 * n - 1], step, length))
    exact = abs(limit - qs[-1]) / qs[-1]
    assert remaining(qs, step, length) == pytest.approx(exact / r ** (n - 1), rel=1e-9)
    jittered = qs[:-1] + [qs[-1 - n]]  # Q back to its value five steps ago: the last change is zero
    oldest = abs(qs[-n] - qs[-2 * n])  # the oldest change of the window, qs[25] − qs[20]
    assert remaining(jittered, step, length) == pytest.approx(oldest * r**n / (1 - r**n) / jittered[-1], rel=1e-9)
