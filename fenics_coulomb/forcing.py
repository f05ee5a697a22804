r"""Forcing terms of the inexact Newton method: the tolerance of each linear solve."""

from __future__ import annotations


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
