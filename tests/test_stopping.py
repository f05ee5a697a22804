"""The stopping rule (fenics_coulomb/stopping.py): target, load guard and round-off floor."""

from __future__ import annotations

import numpy as np
import pytest

from fenics_coulomb.errors import SolverError
from fenics_coulomb.stopping import LOAD_GUARD, ROUNDOFF_FACTOR, StoppingRule

EPS = np.finfo(np.float64).eps


def test_target_is_relative_to_the_start_for_ordinary_loads():
    rule = StoppingRule.create(1e-8, 50, initial=3.0, shift_norm=1.0, start_norm=0.0, load_norm=20.0, gamma=2.0)
    assert rule.target == pytest.approx(3e-8)  # ‖ŷ⁽⁰⁾‖ = 3 < 100·20/2
    assert rule.floor == pytest.approx(ROUNDOFF_FACTOR * EPS * (1.0 + 0.0 + 10.0))
    assert rule.satisfied(2.9e-8) and not rule.satisfied(3.1e-8)


def test_load_guard_when_the_start_misfit_dwarfs_the_load():
    rule = StoppingRule.create(1e-8, 50, initial=1e6, shift_norm=1.0, start_norm=0.0, load_norm=2e-3, gamma=2.0)
    assert rule.target == pytest.approx(1e-8 * LOAD_GUARD * 1e-3)


def test_obstacle_driven_problem_without_load():
    """l̃ = 0 (only an obstacle's displacement drives the body): relative to the misfit of ũ = 0 (the overlap)
    when the start's misfit dwarfs it, to the start otherwise, and never 0 (which would iterate to the round-off
    floor); without any scale the paper's rtol·‖ŷ⁽⁰⁾‖."""
    rule = StoppingRule.create(1e-6, 50, initial=5e4, shift_norm=1.0, start_norm=2.0, load_norm=0.0, gamma=2.0,
                               zero_residual=0.5)
    assert rule.target == pytest.approx(1e-6 * 0.5)
    assert rule.threshold == rule.target > rule.floor
    rule = StoppingRule.create(1e-6, 50, initial=0.2, shift_norm=1.0, start_norm=2.0, load_norm=0.0, gamma=2.0,
                               zero_residual=0.5)
    assert rule.target == pytest.approx(2e-7)
    rule = StoppingRule.create(1e-6, 50, initial=5.0, shift_norm=1.0, start_norm=2.0, load_norm=0.0, gamma=2.0)
    assert rule.target == pytest.approx(5e-6)


def test_iteration_limit_and_non_finite_residual_raise():
    rule = StoppingRule.create(1e-8, 3, initial=1.0, shift_norm=1.0, start_norm=0.0, load_norm=1.0, gamma=1.0)
    with pytest.raises(SolverError):
        rule.check(3, 0.5)
    with pytest.raises(SolverError):
        rule.check(0, float("nan"))
