r"""The stopping rule of the Newton iteration.

Stop when ‖ŷ‖ ≤ rtol·‖ŷ(ũ = 0)‖, or when ‖ŷ‖ reaches the round-off level of the problem's scales,
100·ε·√(1+γ²)·(‖d‖ + ‖ũ⁽⁰⁾‖ + ‖l̃‖/γ) with d the gaps, ũ⁽⁰⁾ the start and l̃ the load. The driver also tries the
rule at ũ = 0 before the first step: a zero load (or one below round-off) stops at once with ũ = 0.

**The scale does not depend on the start.** ‖ŷ(ũ = 0)‖ is the residual of the undeformed body under the whole
load of the solve, with the contact conditions (so an obstacle moved into the body counts with its overlap):
the problem's own scale. The paper divides by ‖ŷ⁽⁰⁾‖ of its start u⁽⁰⁾ = 0 of the shifted unknown (every
contact node put on the obstacle), whose misfit γ‖d‖ grows with the gaps and with the number of contact nodes
(Section 7 cuboid: 6× ‖ŷ(ũ = 0)‖ at lev 2, 25× at lev 6; a roller 5 % of its radius above a plane: far more),
so the same rtol would mean a looser solution from the paper's start than from the undeformed one (force
imbalances 9.2e-5 against 1e-7). Relative to ‖ŷ(ũ = 0)‖ both starts, a start interpolated from a coarser
level (nested iteration) and a load path's previous step are asked for the same solution.

**What it guarantees.** At an iterate u the approximation step gives d̂ = u − e and z ∈ Q(d̂) (the contact
conditions — gap ≥ 0, pressure ≥ 0, complementarity, the Coulomb cone, friction against the slip — hold
exactly at d̂ with the forces z), and A u − l + z = Γ e (r + z = γᵢ eᵢ on contact node i, r = γ e elsewhere).
So ‖ŷ‖² = ‖Γ e‖² + ‖e‖² ≤ rtol²‖ŷ(ũ = 0)‖² bounds at once the force balance of (u, z) and the distance
of u from a displacement d̂ at which the contact conditions hold exactly. Without overlap and with every node
open at ũ = 0, ‖ŷ(ũ = 0)‖ = ‖(l̃, Γ⁻¹l̃)‖ ≈ ‖l̃‖ √(1 + 1/γ²): the relative force balance is then about rtol.

**A displacement accuracy** (``SolverSettings.accuracy`` = EPS) is not a residual: how far a residual leaves u from
the solution depends on where the residual lies (in the soft modes of a stiffness contrast, or as left by ILU or
hypre, one residual means five times the error of another: docs/tradeoff/pairs.md). Once the residual rule holds
(at rtol = EPS/ERROR_PER_RTOL), the iteration also asks that the last Newton correction Δu — a full step, in the
physical displacement u = M z — be at most EPS·‖u‖ (2-norms). Near the solution, with its contact states found, the
semismooth Newton model is the problem itself (piecewise linear), so the correction at an iterate is its error: on
the two-body demo at rtol 1e-6 the correction solved to η = 0.1 estimated the error to 4 % with hypre, ILU and GAMG
(1.83e-5 against 1.905e-5, 1.07e-5 against 1.12e-5, 2.50e-6 against 2.49e-6), whereas the error per rtol ranged from
2.5 to 19. The step then taken leaves an error of about η times that: the answer's error is below EPS with room.
So a start that meets the residual rule takes a step too (its correction is the check), unless it is ũ = 0 for a
load below round-off, the exact solution. The correction is solved to at most ACCURACY_FORCING: a loose ``tol``
(0.7) underestimated the error. Under finite sliding the contact geometry adds its own error, which the geometry
iteration bounds (:meth:`fenics_coulomb.model.sliding.GeometryIteration._accurate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fenics_coulomb.errors import SolverError

__all__ = ["ACCURACY_FORCING", "ROUNDOFF_FACTOR", "StoppingRule"]

#: ‖ŷ‖ below ROUNDOFF_FACTOR·ε·(the problem's displacement and residual scales) counts as converged.
ROUNDOFF_FACTOR = 100.0
#: The largest forcing term of a Newton correction that checks an accuracy (the estimate of the error: solved to
#: η = 0.1 it was the error to 4 %; a loose ``tol`` 0.7 left the answer 1.3 EPS away).
ACCURACY_FORCING = 0.1


@dataclass(frozen=True)
class StoppingRule:
    """When the Newton iteration ends.

    Attributes:
        rtol: The residual reduction asked for.
        max_it: Newton iterations allowed.
        initial: ‖ŷ⁽⁰⁾‖ of the start (for the reported ratios |y|/|y0|).
        target: rtol·‖ŷ(ũ = 0)‖.
        floor: The round-off level of ‖ŷ‖.
        accuracy: The relative displacement error asked for besides the residual (None: the residual alone), bounded
            by the last Newton correction (see the module docstring).
    """

    rtol: float
    max_it: int
    initial: float
    target: float
    floor: float
    accuracy: float | None = None

    @classmethod
    def create(cls, rtol: float, max_it: int, initial: float, scale: float, shift_norm: float, start_norm: float,
               load_norm: float, gamma: float, accuracy: float | None = None) -> StoppingRule:
        """The rule for a solve.

        Args:
            rtol: Residual reduction.
            max_it: Newton iterations allowed.
            initial: ‖ŷ⁽⁰⁾‖ of the start.
            scale: ‖ŷ(ũ = 0)‖, the problem's residual scale (see the module docstring).
            shift_norm: √(1+γ²)·‖d‖ (the gaps).
            start_norm: √(1+γ²)·‖ũ⁽⁰⁾‖ of the start.
            load_norm: √(1+γ²)·‖l̃‖.
            gamma: γ of the approximation step.
            accuracy: The relative displacement error asked for besides the residual (None: the residual alone).
        """
        # Round-off floor of ‖ŷ‖ = √(1+γ²)‖u − d̂‖, from the problem's displacement scales and never from the
        # start iterate alone: the gaps d, the start ũ⁽⁰⁾ and the load's scale ‖l̃‖/γ.
        floor = float(ROUNDOFF_FACTOR * np.finfo(np.float64).eps * (shift_norm + start_norm + load_norm / gamma))
        return cls(rtol, max_it, initial, rtol * scale, floor, accuracy)

    @property
    def threshold(self) -> float:
        """The residual norm that ends the iteration."""
        return max(self.target, self.floor)

    def satisfied(self, residual: float) -> bool:
        """Whether ‖ŷ‖ = ``residual`` ends the iteration successfully."""
        return residual <= self.threshold

    def converged(self, residual: float, correction: float | None) -> bool:
        """Whether the iteration ends successfully at ‖ŷ‖ = ``residual`` after a last Newton correction of relative
        size ``correction`` (:data:`math.inf` for a damped step; None before the first step)."""
        if residual <= self.floor:
            return True
        if residual > self.target:
            return False
        return self.accuracy is None or (correction is not None and correction <= self.accuracy)

    def check(self, iteration: int, residual: float, correction: float | None = None) -> None:
        """Raise SolverError when the iteration must stop without success."""
        if not math.isfinite(residual):
            what = "the initial residual is" if iteration == 0 else f"the residual in iteration {iteration} is"
            raise SolverError(f"{what} not finite ({residual})", "non_finite")
        if iteration >= self.max_it and self.satisfied(residual):
            size = math.inf if correction is None else correction
            raise SolverError(
                f"no convergence after {iteration} Newton iterations: the last Newton correction, {size:.3e} of |u|, "
                f"exceeds the accuracy {self.accuracy:g} asked (|y| = {residual:.3e} meets the target "
                f"{self.threshold:.3e})", "max_iterations")
        if iteration >= self.max_it:
            raise SolverError(
                f"no convergence after {iteration} Newton iterations: |y| = {residual:.3e} > the target "
                f"{self.threshold:.3e} (rtol = {self.rtol:g} x |y(u = 0)|; |y|/|y0| = {residual / self.initial:.3e})",
                "max_iterations")
