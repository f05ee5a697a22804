"""Issue 36's case 9 (Hertz between two elastic bodies) on the structured-core quarter model of
meshes/sphere_on_block_half.py (benchmarks/verification_two_body.py ``hertz_core``, docs/verification §9), at its
coarsest level (h₀ = a/8 in both bodies' cores, the edge growing by 0.2 per unit distance beyond, W = 200 a,
R = 100, 19 266 unknowns): a cap E 70 ν 0.35 pressed δ = a²/R onto a block E 210 ν 0.3, frictionless, mortar
with the block's flat top as the slave. And the closed forms of case 6 (Mindlin's compliance, its slip part,
Mindlin–Deresiewicz unloading) that ``mindlin_core`` compares with.

Measured at this level: a +0.41 %, p₀ +2.8 % (off the symmetry planes +1.2 %); at a/12 a −1.4 %, p₀ +1.5 %.
"""

from __future__ import annotations

from mpi4py import MPI

import pytest

from benchmarks.verification_two_body import hertz_core, mindlin_compliance, mindlin_slip, unloading_slip
from one_rank import one_rank_reference

LEVEL = 0
KEYS = ("P", "radius", "pressure", "pressure_off")


@pytest.fixture(scope="module")
def hertz():
    return hertz_core(MPI.COMM_WORLD, LEVEL)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_mindlin_formulas():
    """Mindlin's slip part s = δ − x δ'(0) vanishes to second order (x²/9 of 3μP(2 − ν)/8Ga); δ'(0) is 2/3 of that
    factor per unit x (twice the bonded disc's (2 − ν)/8Ga per body); Mindlin–Deresiewicz's unloading from x* is
    no change at x*, and ends at −s(x*) at −x* (the loop closes antisymmetrically)."""
    P, a = 1.0, 0.5
    star = float(mindlin_compliance(1.0, P, a))
    assert float(mindlin_slip(1e-3, P, a)) == pytest.approx(star * 1e-6 / 9, rel=1e-2)
    assert float(mindlin_compliance(1e-6, P, a)) / 1e-6 == pytest.approx(2 * star / 3, rel=1e-5)
    assert unloading_slip(0.8, 0.8, P, a) == pytest.approx(float(mindlin_slip(0.8, P, a)), rel=1e-12)
    assert unloading_slip(0.8, -0.8, P, a) == pytest.approx(-float(mindlin_slip(0.8, P, a)), rel=1e-12)


def test_hertz_two_bodies(hertz):
    """a within 1 % and p₀ within 3 % of Hertz's for the measured P at this level (the table's levels: §9)."""
    r = hertz
    assert r["converged"] and r["closed"] > 50
    assert abs(r["err_radius"]) <= 0.01
    assert abs(r["err_pressure"]) <= 0.03
    assert abs(r["err_pressure_off"]) <= 0.02


@one_rank_reference(cost=20.0)
def hertz_alone():
    r = hertz_core(MPI.COMM_SELF, LEVEL)
    return {k: r[k] for k in KEYS}


@pytest.mark.compares_ranks
def test_one_rank_agrees(hertz, one_rank):
    """The same case on one rank alone (MPI.COMM_SELF) agrees to 1e-8."""
    one = one_rank[hertz_alone]
    for key in KEYS:
        assert hertz[key] == pytest.approx(one[key], rel=1e-8), key
