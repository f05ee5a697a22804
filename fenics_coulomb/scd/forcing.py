r"""Forcing terms of the inexact Newton method: the tolerance of each linear solve."""

from __future__ import annotations

__all__ = ["TERMINAL_SAFETY", "TERMINAL_MIN", "terminal_forcing", "forcing_term"]

#: The last step's tolerance aims at this fraction of the stopping target (:func:`terminal_forcing`).
TERMINAL_SAFETY = 0.5
#: ... and is never tightened below this (the target is then more than one tightened step away).
TERMINAL_MIN = 0.002


def terminal_forcing(tol: float, residual: float, target: float) -> float:
    r"""The fixed rule's tolerance ``tol``, tightened in the step that can reach the stopping target.

    Near the solution the inexact Newton iteration converges linearly at the rate of its forcing terms: a step
    solved to η reduces ‖ŷ‖ by about η (docs/tradeoff: ~10× per step at tol = 0.1). When ‖ŷ⁽ᵏ⁾‖·tol would still
    miss the target but TERMINAL_SAFETY·target/‖ŷ⁽ᵏ⁾‖ >= TERMINAL_MIN, one step solved to that η reaches it:
    a GMRES solve a little tighter instead of another Newton step (matrix update, solve and line search).
    Otherwise ``tol``. The solver asks only once the contact states have settled (every node's state that of the
    iterate before): while they change, the Newton model is not the problem near the iterate, a tightened step
    does not cut ‖ŷ‖ by its η, and its extra Krylov iterations are lost (finite sliding solves its first geometry
    to a loose target, which this rule reaches from ‖ŷ‖ up to 250 × the target: on the ν = 0.49 block that made
    35–40 Krylov iterations per step instead of 18 while the states still moved; docs/sliding/README.md, "Cost").

    Args:
        tol: The fixed forcing term.
        residual: ‖ŷ⁽ᵏ⁾‖.
        target: The residual norm that ends the iteration.
    """
    if residual <= 0.0 or target <= 0.0:
        return tol
    eta = TERMINAL_SAFETY * target / residual
    return eta if TERMINAL_MIN <= eta < tol else tol


def forcing_term(tol: float, history: list[float], eta_prev: float, target: float) -> float:
    r"""Safeguarded Eisenstat–Walker forcing term (choice 2, as in Kelley 1995, (6.18)–(6.20)).

    With the residual norms ‖ŷ⁽ᵏ⁾‖ in ``history`` (last = current) and the previous forcing term η₋:

        ηᴬ = 0.9·(‖ŷ⁽ᵏ⁾‖/‖ŷ⁽ᵏ⁻¹⁾‖)²,
        ηᴮ = min(tol, ηᴬ)                      if 0.9·η₋² <= 0.1,
             min(tol, max(ηᴬ, 0.9·η₋²))        otherwise (no sudden drop after one lucky step),
        η  = min(tol, max(ηᴮ, 0.5·target/‖ŷ⁽ᵏ⁾‖))   (no over-solving in the last step).

    The first step (one residual) takes ``tol``. ``tol`` is thus the largest forcing term: while the
    method localizes the contact states (residual ratios near 1) the solves are those of the fixed rule;
    once the residual falls fast they tighten, and the Newton method turns superlinear instead of
    converging linearly at the rate ``tol``.

    Args:
        tol: Largest forcing term (the fixed rule's tolerance).
        history: Residual norms so far.
        eta_prev: Forcing term of the previous step.
        target: The residual norm that ends the iteration.
    """
    if len(history) < 2 or history[-2] <= 0.0:
        return tol
    gamma = 0.9
    eta_a = gamma * (history[-1] / history[-2]) ** 2
    safeguard = gamma * eta_prev**2
    eta_b = min(tol, eta_a) if safeguard <= 0.1 else min(tol, max(eta_a, safeguard))
    guard = 0.5 * target / history[-1] if history[-1] > 0.0 else tol
    return float(min(tol, max(eta_b, guard)))
