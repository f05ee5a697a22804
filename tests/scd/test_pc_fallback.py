"""pc = "auto": a linear solve that stagnates hands the rest of the solve to the next preconditioner of the
ladder ILU → GAMG → BoomerAMG → LU (preconditioner.auto_ladder; issue 11 section 6, issue 27).

d3/L2 at lev 2 with ν = 0.49 is a case the automatic rule gives ILU (hexahedra, few unknowns) on which
ILU-GMRES stagnates: 2000 iterations per Newton step on 2 ranks without reaching tol = 0.1, a breakdown after
28 000 iterations on 1 rank. With the ladder the solve converges and passes the physics checks; a stage that
stagnates as well (forced here by a GAMG without coarse levels or smoothing) passes on to the next one.
"""

from __future__ import annotations

import numpy as np
import pytest

from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.model.dof_values import owned_values
from fenics_coulomb.scd.preconditioner import AUTO_LU_MAX_UNKNOWNS, AUTO_STALL_ITS, auto_ladder

CHECK_TOL = 1e-8


def assert_physics(problem, uh):
    checks = physics_residuals(problem.model, owned_values(uh))
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone"):
        assert checks[key] < CHECK_TOL, (key, checks[key])


@pytest.mark.parametrize(("pc", "expected"), [("auto", "gamg"), ("ilu", "ilu")])
def test_stalled_ilu_falls_back_to_gamg_only_under_auto(problem_factory, pc, expected):
    # poisson_ratio 0.3: the solver is not told that the body is nearly incompressible (an API user's own forms)
    problem = problem_factory(lev=2, poisson=0.49, poisson_ratio=0.3, rtol=1e-12, pc=pc,
                              ksp_max_it=4 * AUTO_STALL_ITS, max_it=30 if pc == "auto" else 3)
    try:
        uh, result = problem.solve()
    except Exception as err:  # an explicit ILU may fail; it must not switch preconditioners
        assert expected == "ilu", err
        assert problem.solver.pc == "ilu" and not problem.solver.pc_history
        return
    assert result.pc == expected
    if expected == "gamg":
        assert result.converged
        assert [(h["from"], h["to"]) for h in result.pc_history] == [("ilu", "gamg")]
        assert result.pc_history[0]["krylov_iterations"] == AUTO_STALL_ITS
        # no linear solve ran on past the cap with ILU, none hit the limit with GAMG
        assert max(r.krylov_iterations for r in result.records) <= 2 * AUTO_STALL_ITS
        assert_physics(problem, uh)


def test_every_stage_of_the_ladder_takes_over_when_the_previous_one_stagnates(problem_factory):
    """With ksp_max_it = 2 every stage that needs more than 2 GMRES iterations for tol = 0.1 counts as stagnated:
    ILU (ν = 0.49) → GAMG → BoomerAMG on the explicit Newton matrix (the operator is no longer matrix-free) → LU
    where needed, within the first Newton step, and the solve still converges to the same physics."""
    problem = problem_factory(lev=2, poisson=0.49, poisson_ratio=0.3, rtol=1e-12, pc="auto", ksp_max_it=2, max_it=60)
    uh, result = problem.solve()
    assert result.converged and result.pc in ("hypre", "lu")
    steps = [(h["from"], h["to"]) for h in result.pc_history]
    assert steps[:2] == [("ilu", "gamg"), ("gamg", "hypre")] and steps[2:] in ([], [("hypre", "lu")])
    assert result.pc_history[0]["newton_step"] == 1
    assert all(h["krylov_iterations"] == 2 for h in result.pc_history)
    assert not problem.solver.operator.matrix_free
    assert_physics(problem, uh)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_ladder():
    assert auto_ladder("ilu", 1000) == ["gamg", "hypre", "lu"]
    assert auto_ladder("gamg", 1000) == ["hypre", "lu"]
    assert auto_ladder("gamg", AUTO_LU_MAX_UNKNOWNS + 1) == ["hypre"]
    assert auto_ladder("lu", 10) == []


def test_no_fallback_where_ilu_works(problem_factory):
    """The paper's d3/L2 at lev 3 keeps ILU: the ladder changes nothing where ILU converges."""
    problem = problem_factory(lev=3)
    _, result = problem.solve()
    assert result.converged and result.pc == "ilu" and result.pc_history == []


@pytest.mark.parametrize("poisson", [0.3, 0.49])
def test_nearly_incompressible_bodies_get_gamg_with_smoothed_aggregation(problem_factory, poisson):
    """The scene's material reaches the policy (SolverSettings.poisson_ratio, set by the builder): from ν = 0.48 on
    pc = auto skips ILU (it breaks down) and GAMG smooths its prolongators also on hexahedra (rows spread over
    neighbouring aggregates: more than the six rigid-body coefficients)."""
    from test_solver import finest_prolongator_row_lengths

    problem = problem_factory(lev=3, poisson=poisson)
    assert problem.settings.poisson_ratio == poisson
    nearly = poisson >= 0.48
    assert problem.solver.pc == ("gamg" if nearly else "ilu")
    _, result = problem.solve()
    assert result.converged and result.pc_history == []
    if nearly:
        assert not np.all(finest_prolongator_row_lengths(problem.solver.ksp.getPC()) <= 6)
