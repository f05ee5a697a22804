"""The normal rule of node-to-surface at a master vertex, against a brute force of its own.

A hexagonal pyramid (six triangles around a raised apex) is the master surface; slave points sit at the apex
displaced by d = ρ h u in many directions u, from ρ = 3e-9 (the node all but on the vertex: any direction of d
passes the cone test within its absolute tolerance 1e-8 h) to ρ = 1e-3 (a clear direction). The brute force finds
the closest point by enumerating every triangle's interior, edges and vertices, the facets containing it by
barycentric coordinates, the distance of ±d to their normal cone by non-negative least squares (scipy's NNLS, not
the Carathéodory enumeration of the implementation), and applies the rules of
:mod:`fenics_coulomb.model.pairs.projection` (interior: the facet normal; edge or vertex: ±d/|d| when ±d is in the
cone, the cone's mean direction when |d| ≤ 1e-10 h or when ±d passes only within the absolute tolerance but lies
off the cone by more than CONE_ANGLE). Every paired node's normal must then equal the brute force's, and lie in the
closed cone to within CONE_ANGLE: never a tangential normal (before the rule, d/|d| of a node on the vertex).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import nnls

from fenics_coulomb.model.pairs.projection import (CONE_ANGLE, CONE_TOL, TIE_TOL, Surface, facet_ranks, facet_sizes,
                                                   project)

pytestmark = pytest.mark.serial  # rank-local: no communicator

APEX = np.array([0.0, 0.0, 0.3])
#: The physical requirement, independent of the implementation's constant: a normal off the cone by at most 1e-3 rad.
OFF_CONE = 1e-3


def _pyramid() -> Surface:
    """Six triangles (apex, b_k, b_{k+1}) around the apex, base on the unit circle at x3 = 0; normals up."""
    phi = np.arange(6) * np.pi / 3 + 0.1
    base = np.stack([np.cos(phi), np.sin(phi), np.zeros(6)], axis=1)
    X = np.stack([np.broadcast_to(APEX, (6, 3)), base, np.roll(base, -1, axis=0)], axis=1)
    blocks = np.stack([np.zeros(6, np.int64), 1 + np.arange(6), 1 + np.roll(np.arange(6), -1)], axis=1)
    N = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
    return Surface(X, blocks, np.where(N[:, 2] > 0, 1.0, -1.0))


def _closest_brute(x: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """The closest point of the triangle ``tri`` (3, 3) to x: the plane's projection if inside, else the best of
    the three edges' (clamped) projections and the vertices."""
    a, b, c = tri
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    p = x - np.dot(x - a, n) * n
    lam = np.linalg.solve(np.stack([b - a, c - a, n], axis=1), p - a)[:2]
    if lam.min() >= 0 and lam.sum() <= 1:
        return p
    best = None
    for s, e in ((a, b), (b, c), (c, a)):
        t = np.clip(np.dot(x - s, e - s) / np.dot(e - s, e - s), 0.0, 1.0)
        q = s + t * (e - s)
        if best is None or np.linalg.norm(x - q) < np.linalg.norm(x - best):
            best = q
    assert best is not None
    return best


def _contains(tri: np.ndarray, q: np.ndarray, tol: float) -> tuple[bool, bool]:
    """Whether the triangle contains q (within ``tol``), and whether q lies on its boundary."""
    a, b, c = tri
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    if abs(np.dot(q - a, n)) > tol:
        return False, False
    lam = np.linalg.solve(np.stack([b - a, c - a, n], axis=1), q - a)[:2]
    bary = np.array([1 - lam.sum(), lam[0], lam[1]])
    return bool(bary.min() >= -tol), bool(bary.min() <= tol)


def _cone_distance_nnls(d: np.ndarray, normals: np.ndarray) -> float:
    """min over λ ≥ 0 of |d − Σ λ_k n_k|."""
    return float(nnls(normals.T, d)[1])


def _expected(x: np.ndarray, surface: Surface, h: float) -> tuple[np.ndarray, bool]:
    """The brute force's normal and pairing of the point x."""
    X = surface.X
    N = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
    N = surface.sign[:, None] * N / np.linalg.norm(N, axis=1)[:, None]
    q = np.array([_closest_brute(x, tri) for tri in X])
    dist = np.linalg.norm(x - q, axis=1)
    near = int(np.argmin(dist))
    tol = TIE_TOL * h
    # the tie rule: facets whose closest points coincide with the nearest one's (within 1e-10 h), the one with the
    # lexicographically smallest sorted vertex numbers chosen
    T = (dist <= dist[near] + tol) & (np.linalg.norm(q - q[near], axis=1) <= tol)
    chosen = min(np.flatnonzero(T), key=lambda f: tuple(np.sort(surface.blocks[f])))
    xm = q[chosen]
    on_edge = T.sum() > 1 or _contains(X[chosen], xm, tol)[1]
    d = x - xm
    if not on_edge:
        return N[T][0], True
    mean = N[T].sum(axis=0)
    mean /= np.linalg.norm(mean)
    if np.linalg.norm(d) <= TIE_TOL * h:
        return mean, True
    plus, minus = _cone_distance_nnls(d, N[T]), _cone_distance_nnls(-d, N[T])
    if plus <= CONE_TOL * h:
        sign, off = 1.0, plus
    elif minus <= CONE_TOL * h:
        sign, off = -1.0, minus
    else:
        return np.full(3, np.nan), False
    if off > CONE_ANGLE * np.linalg.norm(d):
        return mean, True
    return sign * d / np.linalg.norm(d), True


@pytest.mark.parametrize("rho", [3e-9, 1e-6, 1e-3])
def test_vertex_normals_against_brute_force(rho: float) -> None:
    surface = _pyramid()
    size = facet_sizes(surface)
    h = float(size.max())
    rng = np.random.default_rng(11)
    u = rng.normal(size=(400, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    x = APEX + rho * h * u
    out = project(x, surface, size, facet_ranks(surface))
    N = np.cross(surface.X[:, 1] - surface.X[:, 0], surface.X[:, 2] - surface.X[:, 0])
    N /= np.linalg.norm(N, axis=1)[:, None]
    vague = 0
    for i in range(x.shape[0]):
        n_ref, paired_ref = _expected(x[i], surface, h)
        assert bool(out["paired"][i]) == paired_ref, (i, u[i])
        if not paired_ref:
            continue
        n = out["normal"][i]
        # d/|d| carries the round-off of x_s − x_m (≈ 1e-16) over |d| = ρ h
        assert np.linalg.norm(n - n_ref) <= max(1e-12, 1e-14 / rho), (i, u[i], n, n_ref)
        # never tangential: the normal lies in the closed cone of the six facets' normals (to CONE_ANGLE)
        assert _cone_distance_nnls(n, N) <= OFF_CONE + 1e-12, (i, u[i], n)
        d = x[i] - out["closest"][i]
        vague += int(np.linalg.norm(d) > TIE_TOL * h and abs(abs(np.dot(d, n)) / np.linalg.norm(d) - 1) > 1e-6)
    # the vague rule takes part only for the node all but on the vertex (ρ h below the cone's absolute tolerance)
    assert (vague > 0) == (rho < CONE_TOL), vague
