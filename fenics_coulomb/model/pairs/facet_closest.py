"""The closest point of one P1 triangle or Q1 bilinear quadrilateral to a point, for many (facet, point) pairs at once:
the kernels under :func:`fenics_coulomb.model.pairs.projection.project` (its docstring has the rules: a triangle's
plane, else its edges; a quadrilateral's stationary point by Newton's method, else its edges)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["TIE_TOL", "norm", "dot", "quad_map", "closest_points"]

Array = npt.NDArray[np.float64]

#: Relative tolerance (× the facet size h): coincident closest points, |x_s − x_m| ≈ 0, "on the boundary" (in
#: reference coordinates).
TIE_TOL = 1e-10


def norm(x: Array) -> Array:
    return np.linalg.norm(x, axis=-1)


def dot(a: Array, b: Array) -> Array:
    return np.einsum("...i,...i->...", a, b)


def _segment(p: Array, a: Array, b: Array) -> tuple[Array, Array]:
    """Closest points of the segments [a, b] to p and their parameters t ∈ [0, 1]."""
    ab = b - a
    t = np.clip(dot(p - a, ab) / np.maximum(dot(ab, ab), np.finfo(float).tiny), 0.0, 1.0)
    return a + t[:, None] * ab, t


def _closest_triangle(p: Array, X: Array) -> tuple[Array, Array, Array]:
    """Closest points of triangles X (k, 3, 3) to p (k, 3): (points, barycentric weights (k, 3), distance)."""
    A, B, C = X[:, 0], X[:, 1], X[:, 2]
    e1, e2, r = B - A, C - A, p - A
    a11, a12, a22 = dot(e1, e1), dot(e1, e2), dot(e2, e2)
    b1, b2 = dot(e1, r), dot(e2, r)
    det = a11 * a22 - a12 * a12
    l1 = (a22 * b1 - a12 * b2) / det
    l2 = (a11 * b2 - a12 * b1) / det
    inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
    w = np.stack([1 - l1 - l2, l1, l2], axis=1)
    candidates = [(A + l1[:, None] * e1 + l2[:, None] * e2, w, inside)]
    for i, j in ((0, 1), (1, 2), (2, 0)):
        q, t = _segment(p, X[:, i], X[:, j])
        we = np.zeros((p.shape[0], 3))
        we[:, i], we[:, j] = 1 - t, t
        candidates.append((q, we, np.ones_like(inside)))
    return _pick(p, candidates)


def quad_map(X: Array, xi: Array, eta: Array) -> tuple[Array, Array, Array]:
    """x(ξ, η), x_ξ, x_η of bilinear quadrilaterals X (k, 4, 3)."""
    a, b = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    c = X[:, 0] - X[:, 1] - X[:, 2] + X[:, 3]
    x = X[:, 0] + xi[:, None] * a + eta[:, None] * b + (xi * eta)[:, None] * c
    return x, a + eta[:, None] * c, b + xi[:, None] * c


def _quad_weights(xi: Array, eta: Array) -> Array:
    return np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta], axis=1)


def _closest_quad(p: Array, X: Array) -> tuple[Array, Array, Array]:
    """Closest points of bilinear quadrilaterals X (k, 4, 3) to p (k, 3): (points, weights (k, 4), distance)."""
    k = p.shape[0]
    xi, eta = np.full(k, 0.5), np.full(k, 0.5)
    scale = np.maximum(norm(X[:, 3] - X[:, 0]), norm(X[:, 2] - X[:, 1]))
    active = np.arange(k)
    for _ in range(50):  # Newton on the stationarity of ½|x − p|², vectorized over the pairs still moving
        Xa, pa, xa, ea = X[active], p[active], xi[active], eta[active]
        x, xx, xe = quad_map(Xa, xa, ea)
        r = x - pa
        g1, g2 = dot(xx, r), dot(xe, r)
        h11, h22, h12 = dot(xx, xx), dot(xe, xe), dot(xx, xe)
        full = h12 + dot(r, Xa[:, 0] - Xa[:, 1] - Xa[:, 2] + Xa[:, 3])
        det_full = h11 * h22 - full * full
        h12 = np.where(det_full > 1e-12 * h11 * h22, full, h12)  # Gauss–Newton where not positive definite
        det = np.maximum(h11 * h22 - h12 * h12, np.finfo(float).tiny)
        dxi = -(h22 * g1 - h12 * g2) / det
        deta = -(h11 * g2 - h12 * g1) / det
        xa, ea = np.clip(xa + dxi, -0.5, 1.5), np.clip(ea + deta, -0.5, 1.5)
        xi[active], eta[active] = xa, ea
        # done: converged, or pushed to the clipping box (far outside the patch: the edges hold the minimum)
        moving = (np.maximum(np.abs(dxi), np.abs(deta)) > 1e-14) & (np.abs(xa - 0.5) < 1) & (np.abs(ea - 0.5) < 1)
        active = active[moving]
        if active.size == 0:
            break
    x, xx, xe = quad_map(X, xi, eta)
    r = x - p
    # the stationarity residual, relative to the patch: a converged interior point
    stationary = (np.abs(dot(xx, r)) + np.abs(dot(xe, r))) <= 1e-12 * scale * (scale + norm(r))
    inside = stationary & (xi >= -TIE_TOL) & (xi <= 1 + TIE_TOL) & (eta >= -TIE_TOL) & (eta <= 1 + TIE_TOL)
    xi_c, eta_c = np.clip(xi, 0.0, 1.0), np.clip(eta, 0.0, 1.0)
    candidates = [(quad_map(X, xi_c, eta_c)[0], _quad_weights(xi_c, eta_c), inside)]
    ones, zeros = np.ones(k), np.zeros(k)
    a: Array
    b: Array
    for i, j, fixed in ((0, 1, "eta0"), (2, 3, "eta1"), (0, 2, "xi0"), (1, 3, "xi1")):
        q, t = _segment(p, X[:, i], X[:, j])
        if fixed.startswith("eta"):
            a, b = t, (zeros if fixed == "eta0" else ones)
        else:
            a, b = (zeros if fixed == "xi0" else ones), t
        candidates.append((q, _quad_weights(a, b), np.ones(k, dtype=bool)))
    return _pick(p, candidates)


def _pick(p: Array, candidates: list) -> tuple[Array, Array, Array]:
    """The nearest valid candidate (the first on exact ties)."""
    dist = np.stack([np.where(ok, norm(q - p), np.inf) for q, _, ok in candidates])
    best = np.argmin(dist, axis=0)
    rows = np.arange(p.shape[0])
    q = np.stack([c[0] for c in candidates])[best, rows]
    w = np.stack([c[1] for c in candidates])[best, rows]
    return q, w, dist[best, rows]


def closest_points(p: Array, X: Array) -> tuple[Array, Array, Array]:
    return _closest_triangle(p, X) if X.shape[1] == 3 else _closest_quad(p, X)
