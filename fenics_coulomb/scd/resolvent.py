r"""The contact mapping Q̃ of the paper's (6.5), its resolvent and the partition (6.9) of its graph.

Per contact node, with unknowns v = (v12, v3) (tangential, normal) in the shifted variable u = ũ + d,

    Q̃(v) = { (−F·ϑ·∂‖v12‖, ϑ) | ϑ ∈ N_{R+}(v3) },

i.e. ϑ ≤ 0, v3 ≥ 0, ϑ·v3 = 0; λ = −ϑ is the normal contact force and g = −F·ϑ·∂‖v12‖ ∈ Q̃ the
tangential part (the friction force on the body is −g). All functions act on arrays of m nodes,
shape (m, 3), without Python loops.

Resolvent (proof of Proposition 6.4): v = (γI + Q̃)⁻¹(w) is

    v3 = max(w3, 0)/γ,   ϑ = min(w3, 0),   τ = −F·ϑ,
    v12 = 0 if ‖w12‖ ≤ τ,  else (1 − τ/‖w12‖)·w12/γ,

and z := w − γ v ∈ Q̃(v) (z12 = g, z3 = ϑ).
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.frames import to_global, to_local

__all__ = ["SET_L", "SET_M1", "SET_M2", "SET_M3P", "SET_M3M", "SET_M4", "SET_NAMES", "ContactState", "OPEN",
           "STICK", "SLIP", "NOT_CONTACT", "STATE_NAMES", "resolvent", "classify", "contact_states",
           "frame_approximation"]

Array = npt.NDArray[np.float64]

# The sets of (6.9) (Table 1 of the paper), by their mechanical meaning.
SET_L = 0  #: no contact: v3 > 0, ϑ = 0
SET_M1 = 1  #: sliding: v3 = 0, ϑ < 0, v12 ≠ 0
SET_M2 = 2  #: grazing while moving: v3 = 0, ϑ = 0, v12 ≠ 0
SET_M3P = 3  #: sticking strictly inside the cone: v3 = 0, ϑ < 0, v12 = 0, ‖g‖ < −F·ϑ
SET_M3M = 4  #: sticking on the cone boundary: v3 = 0, ϑ < 0, v12 = 0, ‖g‖ = −F·ϑ
SET_M4 = 5  #: grazing at rest: v = 0, (g, ϑ) = 0
SET_NAMES = ("L", "M1", "M2", "M3+", "M3-", "M4")

# Contact states reported to users (and in the XDMF field contact_state).
class ContactState(IntEnum):
    """The state of a contact node — the one set of codes of the solver, its outputs and figures (−1 in the
    output fields marks nodes that are not contact nodes: :data:`NOT_CONTACT`)."""

    OPEN = 0
    STICK = 1
    SLIP = 2


OPEN, STICK, SLIP = ContactState.OPEN, ContactState.STICK, ContactState.SLIP
#: The contact_state field's value on nodes that are not contact nodes.
NOT_CONTACT = -1
STATE_NAMES = ("open", "stick", "slip")


def resolvent(w: Array, gamma: float | Array, friction: float | Array) -> tuple[Array, Array]:
    """Evaluate v = (γI + Q̃)⁻¹(w) node-wise and the matching z = w − γv ∈ Q̃(v).

    Args:
        w: Arguments, shape (m, 3).
        gamma: γ > 0 (a number or one per node, shape (m,): the per-node γᵢ of
            :mod:`fenics_coulomb.scd.newton`).
        friction: Coulomb coefficient F >= 0 (a number or one per node).

    Returns:
        (v, z), both of shape (m, 3).
    """
    w = np.asarray(w, dtype=np.float64)
    g = np.broadcast_to(np.asarray(gamma, dtype=np.float64), w.shape[:1])
    v = np.zeros_like(w)
    theta = np.minimum(w[:, 2], 0.0)
    v[:, 2] = np.maximum(w[:, 2], 0.0) / g
    tau = -friction * theta
    norm12 = np.hypot(w[:, 0], w[:, 1])
    slide = norm12 > tau
    scale = np.zeros_like(norm12)
    scale[slide] = (1.0 - tau[slide] / norm12[slide]) / g[slide]
    v[:, :2] = scale[:, None] * w[:, :2]
    z = w - g[:, None] * v
    # ϑ is exactly min(w3, 0): keep it free of the round-off of w3 − γ·(w3/γ).
    z[:, 2] = theta
    return v, z


def classify(v: Array, z: Array, friction: float | Array) -> npt.NDArray[np.int8]:
    """Return the set of (6.9) each graph point (v, z) ∈ gph Q̃ belongs to (SET_* codes).

    The points come from :func:`resolvent`, whose zeros are exact, so the tests are exact comparisons.
    """
    v = np.asarray(v)
    z = np.asarray(z)
    theta = z[:, 2]
    slip_norm = np.hypot(v[:, 0], v[:, 1])
    g_norm = np.hypot(z[:, 0], z[:, 1])
    sets = np.full(v.shape[0], SET_L, dtype=np.int8)
    touching = v[:, 2] <= 0.0
    pressed = touching & (theta < 0.0)
    free = touching & ~(theta < 0.0)
    sets[free & (slip_norm > 0.0)] = SET_M2
    sets[free & ~(slip_norm > 0.0)] = SET_M4
    sets[pressed & (slip_norm > 0.0)] = SET_M1
    at_rest = pressed & ~(slip_norm > 0.0)
    inside = g_norm < -friction * theta
    sets[at_rest & inside] = SET_M3P
    sets[at_rest & ~inside] = SET_M3M
    return sets


def contact_states(sets: npt.NDArray[np.int8], friction: float | Array) -> npt.NDArray[np.int8]:
    """Map the sets of (6.9) to user-facing states: OPEN (L, M2, M4), STICK (M3±), SLIP (M1).

    Without friction there is no sticking: a pressed node at rest (M3−, the only M3 set when F = 0)
    is reported as SLIP (frictionless contact).
    """
    states = np.full(sets.shape, OPEN, dtype=np.int8)
    states[sets == SET_M1] = SLIP
    rest = (sets == SET_M3P) | (sets == SET_M3M)
    frictionless = np.broadcast_to(np.asarray(friction) == 0.0, sets.shape)
    states[rest & frictionless] = SLIP
    states[rest & ~frictionless] = STICK
    return states


def frame_approximation(
    u: Array, r: Array, R: Array, gamma: float, friction: float | Array
) -> tuple[Array, Array, Array]:
    """The approximation step (6.17) on contact nodes in their frames (see the module docstring).

    Args:
        u: Shifted Cartesian unknowns uⁱ = ũⁱ + Rᵢsⁱ of the contact nodes, shape (m, 3).
        r: Cartesian residual blocks rⁱ = (A u − l)ⁱ, shape (m, 3).
        R: Frames, shape (m, 3, 3).
        gamma: γ > 0.
        friction: Coulomb coefficient F (a scalar, or per node, shape (m,)).

    Returns:
        (e, v, z): the Cartesian eⁱ = uⁱ − Rᵢvⁱ and the local graph point (vⁱ, zⁱ) ∈ gph Q̃.
    """
    w = to_local(R, gamma * u - r)
    F = np.asarray(friction, dtype=np.float64)
    if F.ndim == 0:
        v, z = resolvent(w, gamma, float(F))
    else:  # per-node friction: the resolvent is node-wise, so group the nodes by their coefficient
        v, z = np.empty_like(w), np.empty_like(w)
        for value in np.unique(F):
            sel = F == value
            v[sel], z[sel] = resolvent(w[sel], gamma, float(value))
    return u - to_global(R, v), v, z
