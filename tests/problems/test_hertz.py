"""benchmarks/hertz.py against Hertz's formulas at the coarse level (1 and 2 ranks), and its measuring functions.

The tolerances come from the measured level-0 numbers (docs/hertz/README.md): the linear tetrahedra are
stiffer than the exact solution, so under displacement control the force lies ABOVE Hertz's (+6.9 % at
h₀ = a/4) and falls under refinement (+3.5 % at a/8, +2.6 % at a/11.3: docs/hertz, too slow for the suite).
"""

from __future__ import annotations

import runpy
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

DEMO = runpy.run_path(str(Path(__file__).resolve().parents[2] / "benchmarks" / "hertz.py"), run_name="hertz_demo")


@pytest.mark.serial
def test_hertz_formulas_agree():
    """P(δ), a(δ), p₀(δ) satisfy a³ = 3PR/(4E*) and p₀ = 3P/(2πa²) = (2E*/π)√(δ/R)."""
    R, delta = 7.0, 0.013
    h = DEMO["hertz"](R, delta)
    back = DEMO["hertz_from_force"](R, h["force"])
    assert np.isclose(back["radius"], h["radius"], rtol=1e-12)
    assert np.isclose(back["pressure"], h["pressure"], rtol=1e-12)
    assert np.isclose(h["pressure"], 2 * DEMO["E_STAR"] / np.pi * np.sqrt(delta / R), rtol=1e-12)


@pytest.mark.serial
def test_contact_radius_estimator():
    """The separating radius lies midway between the outermost closed and the innermost open ring, and one
    stray node on either side does not move it."""
    rng = np.random.default_rng(1)
    radii = np.repeat(np.arange(0.0, 2.05, 0.1), 12) + rng.uniform(-1e-3, 1e-3, 21 * 12)
    closed = radii < 0.95  # rings 0 ... 0.9 closed, 1.0 ... open
    assert DEMO["contact_radius"](radii, closed) == pytest.approx(0.95, abs=2e-3)
    stray = closed.copy()
    stray[np.argmin(np.abs(radii - 1.5))] = True     # a closed node far out
    stray[np.argmin(np.abs(radii - 0.5))] = False    # an open node inside
    assert DEMO["contact_radius"](radii, stray) == pytest.approx(0.95, abs=2e-3)
    assert DEMO["contact_radius"](radii, np.zeros_like(closed)) == 0.0


def _physics(m) -> None:
    """Equilibrium, Signorini and balance of the solution: the support's reaction carries the contact force.

    The balance sums the solver's nodal equilibrium residual (< 1e-8 relative here, measured 2e-9) over ~10⁴
    free nodes, hence 1e-5 (measured 1e-11 for the block, 1.3e-6 for the hemisphere)."""
    assert m.max_physics_residual < 1e-8, m.max_physics_residual
    assert m.reaction_balance < 1e-5
    assert m.reaction == pytest.approx(m.force, rel=1e-5)
    assert m.force > 0 and m.min_pressure >= 0.0


def test_sphere_indentation_coarse():
    """Rigid sphere pushed δ into the block (h₀ = a/4, 19 542 unknowns), frictionless: force above Hertz by
    the P1 stiffness, within 9 % (measured +6.9 %); contact radius within 3 % of √(Rδ) (measured +0.5 %);
    p₀ within 10 % (measured +6.2 %)."""
    m = DEMO["indent_block"](0, 0.0, MPI.COMM_WORLD)
    print(m)
    _physics(m)
    assert 0.0 < m.err_force < 0.09
    assert abs(m.err_radius) < 0.03
    assert abs(m.err_pressure) < 0.10
    # the nodal tractions scatter: the largest one is above the smoothed p₀, but not wildly
    assert m.pressure < m.max_traction < 2.0 * m.pressure


def test_hemisphere_coarse():
    """Elastic hemisphere pressed by its top (prescribed δ on the whole top face) onto the plane, frictionless,
    h₀ = a/4: a and p₀ against Hertz for the measured force within 3 % and 6 % (measured −1.4 %, +4.0 %);
    the top's reaction is the contact force."""
    m = DEMO["press_hemisphere"](0, 0.0, MPI.COMM_WORLD)
    print(m)
    _physics(m)
    assert abs(m.err_radius_from_force) < 0.03
    assert abs(m.err_pressure_from_force) < 0.06
