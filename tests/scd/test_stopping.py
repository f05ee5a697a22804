"""The stopping rule (fenics_coulomb/scd/stopping.py): a target relative to ‖ŷ(ũ = 0)‖ whatever the start, and the
round-off floor; the same solution from the paper's start and from the undeformed one."""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import gather_by_coordinates

from fenics_coulomb.errors import SolverError
from fenics_coulomb.scd.stopping import ROUNDOFF_FACTOR, StoppingRule

EPS = np.finfo(np.float64).eps


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_target_is_relative_to_the_residual_of_the_undeformed_body():
    for initial in (3.0, 1e6):  # the start's own residual does not matter
        rule = StoppingRule.create(1e-8, 50, initial=initial, scale=0.5, shift_norm=1.0, start_norm=0.0,
                                   load_norm=20.0, gamma=2.0)
        assert rule.target == pytest.approx(5e-9)
        assert rule.floor == pytest.approx(ROUNDOFF_FACTOR * EPS * (1.0 + 0.0 + 10.0))
        assert rule.satisfied(4.9e-9) and not rule.satisfied(5.1e-9)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_no_load_and_no_overlap_leaves_the_round_off_floor():
    rule = StoppingRule.create(1e-8, 50, initial=2.0, scale=0.0, shift_norm=1.0, start_norm=2.0, load_norm=0.0,
                               gamma=2.0)
    assert rule.target == 0.0 and rule.threshold == rule.floor > 0.0


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_iteration_limit_and_non_finite_residual_raise():
    rule = StoppingRule.create(1e-8, 3, initial=1.0, scale=1.0, shift_norm=1.0, start_norm=0.0, load_norm=1.0,
                               gamma=1.0)
    with pytest.raises(SolverError, match="target"):
        rule.check(3, 0.5)
    with pytest.raises(SolverError):
        rule.check(0, float("nan"))


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_an_accuracy_asks_for_a_small_full_newton_correction_too():
    rule = StoppingRule.create(1e-8, 10, initial=1.0, scale=1.0, shift_norm=1.0, start_norm=0.0, load_norm=1.0,
                               gamma=1.0, accuracy=1e-6)
    assert not rule.converged(2e-8, 1e-9)  # the residual first
    assert not rule.converged(5e-9, None)  # a start meeting the residual: a correction checks it
    assert not rule.converged(5e-9, 2e-6) and not rule.converged(5e-9, np.inf)  # too large; a damped step
    assert rule.converged(5e-9, 1e-6) and rule.converged(0.5 * rule.floor, None)  # ... or round-off
    plain = StoppingRule.create(1e-8, 10, initial=1.0, scale=1.0, shift_norm=1.0, start_norm=0.0, load_norm=1.0,
                                gamma=1.0)
    assert plain.converged(5e-9, None) and plain.converged(5e-9, 1.0)  # without an accuracy: the residual alone
    with pytest.raises(SolverError, match=re.escape("correction, 2.000e-06 of |u|, exceeds the accuracy 1e-06")):
        rule.check(10, 5e-9, 2e-6)


@pytest.mark.parametrize("case", [("d3", "L2", 4), ("d1", "L1", 3)])
def test_the_same_solution_from_the_papers_start_and_the_undeformed_one(problem_factory, case):
    """The paper's start misfits by γ‖d‖ (25× ‖ŷ(ũ = 0)‖ at lev 6); with the start-independent target both starts
    give the same solution to the solver's accuracy, far below what the old relative rule left (rtol·‖ŷ⁽⁰⁾‖)."""
    import dolfinx.fem

    gap, load, lev = case
    solutions, results = [], []
    for start in ("zero", "undeformed"):
        problem = problem_factory(lev, gap, load)
        u0 = None if start == "zero" else dolfinx.fem.Function(problem.V)
        _, result = problem.solve(u0)
        assert result.converged
        results.append(result)
        solutions.append(gather_by_coordinates(problem.V, result.displacement)[1])
    assert results[0].residual_history[0] > 3 * results[1].residual_history[0]  # the starts differ
    diff = np.linalg.norm(solutions[0] - solutions[1]) / np.linalg.norm(solutions[1])
    assert diff <= 1e-6, diff
