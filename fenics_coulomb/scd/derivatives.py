r"""Elements of the SCD derivatives S*Q̃ and SQ̃ (Proposition 6.6, Corollary 6.7, (6.16)).

For each contact node a pair of 3×3 matrices is returned whose column range is one subspace of the
derivative at the graph point (v, z) = (d̂ⁱ, zⁱ) of the approximation step:

* S*Q̃ (Newton step 4.a, system (5.4)): rge(W*, U*) with
    - L, M2, M4 (no contact, grazing):     rge(I, 0)            ((6.10), (6.16))
    - M3+, M3− (sticking):                 rge(0, I)            ((6.11), (6.16))
    - M1 (sliding), scaled as in (6.15):   W* = [[C, 0], [F nᵀ, 0]],  U* = [[b P, 0], [0, 1]]
* SQ̃ (Newton step 4.b): rge(X, Y) with
    - L, M2, M4: rge(I, 0);  M3±: rge(0, I)
    - M1, scaled as in (6.14):             X = [[C, 0], [0, 0]],      Y = [[b P, −F n], [0, 1]]

where, with s = ‖v12‖, t = −F·ϑ ≥ 0, n = v12/s, P = I₂ − n nᵀ,
a = s/(s + t), b = t/(s + t):  C = a I₂ + b n nᵀ.
These are the bases of (6.12)/(6.13) multiplied from the right by the scaling matrix of Corollary 6.7,
bounded (entries in [−1, 1] up to F) as the slip s → 0.

Without friction (F = 0) the graph of Q̃ is smooth at every pressed node, so pressed nodes at rest (M3−)
use the same formulas as M1 with F = 0 (a = 1, b = 0): tangentially free, normally fixed.

Biactive nodes (v3 = 0 and ϑ = 0: M2, M4) lie where the free and the pressed branches of the graph meet, and the
SCD derivative there holds the limits of both: the free rge(I, 0) above (the limit from L, the paper's choice), and
the limits from the pressed side — M1's bases as ϑ → 0⁻ (t → 0: a = 1, b = 0, with n = v12/‖v12‖ on M2) and M3's
rge(0, I) as ϑ → 0⁻ at v = 0 (M4; with F = 0 M3's frictionless form, tangentially free). :func:`pressed_branch`
maps M2 to M1 and M4 to M3+ so that the same formulas give those limits (tests/scd/test_derivatives.py checks them
against bases at pressed points ϑ = −ε). The solver takes the pressed branch on problems with a body held by contact
alone (:mod:`fenics_coulomb.scd.newton`): the free branch at every node of a body resting on its obstacle at gap 0
leaves its rigid motion in the Newton matrix's null space.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from fenics_coulomb.scd.resolvent import SET_M1, SET_M2, SET_M3M, SET_M3P, SET_M4

__all__ = ["sstar_blocks", "s_blocks", "pressed_branch"]

Array = npt.NDArray[np.float64]


def _slip_quantities(
    v: Array, z: Array, friction: float | Array
) -> tuple[Array, Array, Array, Array]:
    """Return (n, a, b, s) of the sliding formulas for every node (garbage where not sliding)."""
    s = np.hypot(v[:, 0], v[:, 1])
    t = -friction * z[:, 2]
    den = s + t
    safe = den > 0.0
    a = np.ones_like(s)
    b = np.zeros_like(s)
    a[safe] = s[safe] / den[safe]
    b[safe] = t[safe] / den[safe]
    n = np.zeros((v.shape[0], 2))
    moving = s > 0.0
    n[moving] = v[moving, :2] / s[moving, None]
    return n, a, b, s


def _split(sets: npt.NDArray[np.int8], friction: float | Array) -> tuple[npt.NDArray[np.bool_], ...]:
    """Boolean masks (slide, stick) of the nodes that use the sliding and the sticking subspaces."""
    slide = sets == SET_M1
    rest = (sets == SET_M3P) | (sets == SET_M3M)
    frictionless = np.broadcast_to(np.asarray(friction) == 0.0, sets.shape)
    return slide | (rest & frictionless), rest & ~frictionless


def _blocks(
    v: Array, z: Array, sets: npt.NDArray[np.int8], friction: float | Array, adjoint: bool
) -> tuple[Array, Array]:
    """The pair (W*, U*) (``adjoint``) or (X, Y) node-wise; see the module docstring.

    Both share their open/stick blocks and, on sliding nodes, C and b·P; they differ only in where
    F·n sits: in the last row of W* (the adjoint) or in the last column of Y.
    """
    m = v.shape[0]
    first = np.zeros((m, 3, 3))
    second = np.zeros((m, 3, 3))
    slide, stick = _split(sets, friction)
    first[~(slide | stick)] = np.eye(3)
    second[stick] = np.eye(3)

    F = np.broadcast_to(np.asarray(friction, dtype=np.float64), (m,))[slide]
    n, a, b, _ = _slip_quantities(v[slide], z[slide], F)
    nn = n[:, :, None] * n[:, None, :]
    eye2 = np.eye(2)
    f = np.zeros((n.shape[0], 3, 3))
    f[:, :2, :2] = a[:, None, None] * eye2 + b[:, None, None] * nn
    g = np.zeros((n.shape[0], 3, 3))
    g[:, :2, :2] = b[:, None, None] * (eye2 - nn)
    g[:, 2, 2] = 1.0
    if adjoint:
        f[:, 2, :2] = F[:, None] * n
    else:
        g[:, :2, 2] = -F[:, None] * n
    first[slide] = f
    second[slide] = g
    return first, second


def sstar_blocks(v: Array, z: Array, sets: npt.NDArray[np.int8], friction: float | Array) -> tuple[Array, Array]:
    """Return (W*, U*), shape (m, 3, 3) each, with rge(W*, U*) ∈ S*Q̃(v, z) node-wise."""
    return _blocks(v, z, sets, friction, adjoint=True)


def s_blocks(v: Array, z: Array, sets: npt.NDArray[np.int8], friction: float | Array) -> tuple[Array, Array]:
    """Return (X, Y), shape (m, 3, 3) each, with rge(X, Y) ∈ SQ̃(v, z) node-wise."""
    return _blocks(v, z, sets, friction, adjoint=False)


def pressed_branch(sets: npt.NDArray[np.int8]) -> npt.NDArray[np.int8]:
    """The sets with the biactive nodes on the pressed branch (module docstring): M2 → M1, M4 → M3+ (a copy)."""
    out = np.array(sets, dtype=np.int8, copy=True)
    out[sets == SET_M2] = SET_M1
    out[sets == SET_M4] = SET_M3P
    return out
