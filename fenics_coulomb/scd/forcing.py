r"""Forcing terms of the inexact Newton method: the tolerance of each linear solve."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

__all__ = ["TERMINAL_SAFETY", "TERMINAL_MIN", "terminal_forcing", "forcing_term", "states_settled"]

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
    Otherwise ``tol``.

    Args:
        tol: The fixed forcing term.
        residual: ‖ŷ⁽ᵏ⁾‖.
        target: The residual norm that ends the iteration.
    """
    if residual <= 0.0 or target <= 0.0:
        return tol
    eta = TERMINAL_SAFETY * target / residual
    return eta if TERMINAL_MIN <= eta < tol else tol


def states_settled(comm: MPI.Comm, states: npt.NDArray[np.int8], previous: npt.NDArray[np.int8] | None) -> bool:
    r"""Whether the contact states of an iterate (open, stick, slip per contact node) are those of the iterate before,
    ``previous``, on every rank (collective); True in the first step (None), which takes :func:`terminal_forcing`
    as ever.

    :func:`terminal_forcing`'s premise — one step solved to η reduces ‖ŷ‖ by about η — holds when the semismooth
    Newton step is that of the final contact states, the piecewise linear problem itself. While the states still
    change, a step cuts ‖ŷ‖ by what the states allow, whatever its η: a loose first solve of finite sliding (target
    rtol^½) tightened its second to fourth steps to η 0.002–0.005 and got 0.39, 0.20 — twice the Krylov iterations of
    the fixed η (robustness suite, the graded "slivers" block: 103 against 79 for the same 7 Newton steps; ν = 0.49:
    430 against 270). Held to the fixed tol until the states hold still, finite sliding there needs small sliding's
    79 and 271 (docs/sliding/robustness.md).
    """
    return previous is None or bool(comm.allreduce(bool(np.array_equal(states, previous)), op=MPI.LAND))


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
