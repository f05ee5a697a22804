r"""The stopping rule of the Newton iteration.

Stop when ‖ŷ‖ ≤ rtol·min(‖ŷ⁽⁰⁾‖, max(100·‖ŷ(ũ = 0)‖ without contact, ‖ŷ(ũ = 0)‖)), or when ‖ŷ‖ reaches the round-off level of the problem's
scales, 100·ε·√(1+γ²)·(‖d‖ + ‖ũ⁽⁰⁾‖ + ‖l̃‖/γ) with d the gaps, ũ⁽⁰⁾ the start and l̃ the load (not of the start
alone, which is 0 for the paper's start under a zero load). The driver also tries the rule at ũ = 0 before
the first step: a zero load (or one below round-off) stops at once with ũ = 0.

The load's own residual scale ‖ŷ(ũ = 0)‖ = √(1+γ²)/γ·‖l̃‖ (no contact at ũ = 0): ‖ŷ⁽⁰⁾‖ of the paper's start
is dominated by γ·d when the load is small, and a reduction relative to it alone would accept a field that
does not resolve the load. The reduction is therefore taken relative to min(‖ŷ⁽⁰⁾‖, 100·‖ŷ(ũ = 0)‖): the
paper's rule for ordinary loads (‖ŷ⁽⁰⁾‖ is then below the bound), a load-relative rule when the start's
misfit dwarfs the load. Where ũ = 0 itself misfits more than the load says — an obstacle moved into the
body (an indentation, or a step of a load path that only moves an obstacle: l̃ = 0) — the guard's scale is
the computed ‖ŷ(ũ = 0)‖ (the overlap), so that the target is neither 0 (iterating to round-off) nor relative to
the paper's start alone (whose misfit γ‖d‖ is dominated by the gaps of far-away nodes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fenics_coulomb.errors import SolverError

#: The reduction is measured relative to min(‖ŷ⁽⁰⁾‖, LOAD_GUARD·‖ŷ(ũ = 0)‖).
LOAD_GUARD = 100.0
#: ‖ŷ‖ below ROUNDOFF_FACTOR·ε·(the problem's displacement and residual scales) counts as converged.
ROUNDOFF_FACTOR = 100.0


@dataclass(frozen=True)
class StoppingRule:
    """When the Newton iteration ends.

    Attributes:
        rtol: The residual reduction asked for.
        max_it: Newton iterations allowed.
        initial: ‖ŷ⁽⁰⁾‖.
        target: rtol·min(‖ŷ⁽⁰⁾‖, max(LOAD_GUARD·‖ŷ(ũ = 0)‖ without contact, ‖ŷ(ũ = 0)‖)).
        floor: The round-off level of ‖ŷ‖.
    """

    rtol: float
    max_it: int
    initial: float
    target: float
    floor: float

    @classmethod
    def create(cls, rtol: float, max_it: int, initial: float, shift_norm: float, start_norm: float,
               load_norm: float, gamma: float, zero_residual: float = 0.0) -> StoppingRule:
        """The rule for a solve.

        Args:
            rtol: Residual reduction.
            max_it: Newton iterations allowed.
            initial: ‖ŷ⁽⁰⁾‖.
            shift_norm: √(1+γ²)·‖d‖ (the gaps).
            start_norm: √(1+γ²)·‖ũ⁽⁰⁾‖ of the start.
            load_norm: √(1+γ²)·‖l̃‖.
            gamma: γ of the approximation step.
            zero_residual: ‖ŷ(ũ = 0)‖ computed (with the contact conditions: the misfit of an obstacle that
                overlaps the undeformed body), when known.
        """
        # Round-off floor of ‖ŷ‖ = √(1+γ²)‖u − d̂‖, from the problem's displacement scales and never from the
        # start iterate alone (from the paper's start under a tiny load that would be ~0, and the iteration
        # would chase ‖ŷ‖ → 0 to the iteration limit): the gaps d, the start ũ⁽⁰⁾ and the load's scale ‖l̃‖/γ.
        floor = ROUNDOFF_FACTOR * np.finfo(np.float64).eps * (shift_norm + start_norm + load_norm / gamma)
        # the guard's scale: the load's, or the misfit of ũ = 0 when that is larger (an obstacle moved into the
        # body drives it without any load: with l̃ = 0 alone the target would be 0 and the iteration would run
        # to the round-off floor); no scale at all: the paper's rule
        guard = max(LOAD_GUARD * load_norm / gamma, zero_residual)
        target = rtol * (min(initial, guard) if guard > 0.0 else initial)
        return cls(rtol, max_it, initial, target, floor)

    @property
    def threshold(self) -> float:
        """The residual norm that ends the iteration."""
        return max(self.target, self.floor)

    def satisfied(self, residual: float) -> bool:
        """Whether ‖ŷ‖ = ``residual`` ends the iteration successfully."""
        return residual <= self.threshold

    def check(self, iteration: int, residual: float) -> None:
        """Raise SolverError when the iteration must stop without success."""
        if not math.isfinite(residual):
            what = "the initial residual is" if iteration == 0 else f"the residual in iteration {iteration} is"
            raise SolverError(f"{what} not finite ({residual})", "non_finite")
        if iteration >= self.max_it:
            raise SolverError(
                f"no convergence after {iteration} Newton iterations: |y|/|y0| = {residual / self.initial:.3e} "
                f"> rtol = {self.rtol:g}", "max_iterations")
