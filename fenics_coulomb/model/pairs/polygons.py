"""Convex polygons in a plane, vectorized over rows: orientation, convexity, Sutherland–Hodgman clipping, the
cleaning of duplicate and collinear vertices and shoelace areas (the auxiliary-plane polygons of dual mortar
segmentation, :mod:`fenics_coulomb.model.pairs.segmentation`).

Polygons are arrays (k, w, 2) with a vertex count per row (the rows padded to the widest).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["cross2", "convex", "counter_clockwise", "clip", "clean_polygon", "polygon_area", "polygon_perimeter"]

Array = npt.NDArray[np.float64]


def _dot(a: Array, b: Array) -> Array:
    return np.einsum("...i,...i->...", a, b)


def _norm(a: Array) -> Array:
    return np.sqrt(_dot(a, a))


def cross2(a: Array, b: Array) -> Array:
    """The 2D cross product a₁b₂ − a₂b₁ over the last axis."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def convex(P: Array) -> npt.NDArray[np.bool_]:
    """Whether the counter-clockwise polygons P (k, n, 2) are convex (every turn left, up to round-off)."""
    e = np.roll(P, -1, axis=1) - P
    turn = cross2(e, np.roll(e, -1, axis=1))
    scale = np.max(_dot(e, e), axis=1)
    return (turn >= -1e-10 * scale[:, None]).all(axis=1)


def counter_clockwise(P: Array) -> tuple[Array, Array]:
    """The polygons P (k, n, 2) counter-clockwise, and their (positive) areas."""
    area = 0.5 * np.sum(cross2(P, np.roll(P, -1, axis=1)), axis=1)
    return np.where((area < 0)[:, None, None], P[:, ::-1], P), np.abs(area)


def clip(subject: Array, count: npt.NDArray[np.intp], clipper: Array, tol: Array) -> tuple[Array, npt.NDArray[np.intp]]:
    """Sutherland–Hodgman: the convex polygons ``subject`` (k, s, 2; ``count`` vertices each) clipped by the
    convex counter-clockwise polygons ``clipper`` (k, c, 2); a point within ``tol`` (k,) of an edge's inside
    counts as inside. Returns the clip polygons (k, s + c, 2) and their vertex counts (0 when empty)."""
    k, c = clipper.shape[0], clipper.shape[1]
    width = subject.shape[1] + c
    P = np.zeros((k, width, 2))
    P[:, : subject.shape[1]] = subject
    n = count.astype(np.intp).copy()
    rows = np.arange(k)
    slots = np.arange(width)
    for edge in range(c):
        a, b = clipper[:, edge], clipper[:, (edge + 1) % c]
        t = b - a
        length = _norm(t)
        d = cross2(t[:, None], P - a[:, None]) / np.maximum(length, np.finfo(float).tiny)[:, None]  # > 0: inside
        inside = d >= -tol[:, None]
        nxt = (slots[None, :] + 1) % np.maximum(n, 1)[:, None]
        Pn = P[rows[:, None], nxt]
        dn = d[rows[:, None], nxt]
        inn = inside[rows[:, None], nxt]
        valid = slots[None, :] < n[:, None]
        cross = valid & (inside != inn)
        s = d / np.where(d - dn != 0, d - dn, 1.0)
        hit = P + s[..., None] * (Pn - P)
        out = np.zeros((k, 2 * width, 2))
        keep = np.zeros((k, 2 * width), dtype=bool)
        out[:, 0::2], keep[:, 0::2] = hit, cross
        out[:, 1::2], keep[:, 1::2] = Pn, valid & inn
        # compact the kept vertices to the front, in order (at most width: convex polygons)
        dest = np.cumsum(keep, axis=1) - 1
        row, col = np.nonzero(keep & (dest < width))
        P = np.zeros((k, width, 2))
        P[row, dest[row, col]] = out[row, col]
        n = np.minimum(keep.sum(axis=1), width)
    n = np.where(n >= 3, n, 0)
    return P, n


def clean_polygon(P: Array, count: npt.NDArray[np.intp], tol: Array) -> tuple[Array, npt.NDArray[np.intp]]:
    """The clip polygons without their duplicate and collinear vertices.

    A vertex within ``tol`` (k,) of its predecessor is a duplicate (a master vertex on a slave edge's line comes
    out of the clipping twice); a vertex within ``tol`` of the line through its two neighbours is collinear (of
    two neighbouring collinear vertices the first, then the polygon is looked at again: removed together, two
    vertices a little more than ``tol`` apart at a corner would each be collinear with the other's line and take
    the corner, a whole triangle, with them). Both are removed, so the polygon, its vertex mean and its fan of
    triangles are continuous functions of the geometry: the same, up to the size of a perturbation, for a vertex
    exactly on an edge and for one 1e-9 beside it. A polygon left with fewer than 3 vertices (a sliver or a
    touching edge) is empty.

    Args:
        P: Convex polygons (k, w, 2), the first ``count`` vertices valid.
        count: Vertex counts (k,) (0: empty).
        tol: The merge distance of each polygon (k,).

    Returns:
        The cleaned polygons (k, w, 2) and their vertex counts (k,) (0: empty).
    """
    width = P.shape[1]
    slots = np.arange(width)[None, :]
    valid = slots < count[:, None]
    n = np.maximum(count, 1)[:, None]
    prev = np.take_along_axis(P, ((slots - 1) % n)[..., None], axis=1)
    keep = valid & (_norm(P - prev) > tol[:, None])
    Q, m = _compact(P, keep)
    slots = np.arange(Q.shape[1])[None, :]
    look = np.ones(Q.shape[0], dtype=bool)  # the rows to look at (again)
    for _ in range(Q.shape[1]):
        n = np.maximum(m, 1)[:, None]
        a = np.take_along_axis(Q, ((slots - 1) % n)[..., None], axis=1)
        b = np.take_along_axis(Q, ((slots + 1) % n)[..., None], axis=1)
        ab = b - a
        off = np.abs(cross2(ab, Q - a)) / np.maximum(_norm(ab), np.finfo(float).tiny)
        valid = slots < m[:, None]
        collinear = valid & (off <= tol[:, None]) & (m[:, None] >= 3) & look[:, None]
        # two neighbours are never removed at once: each is measured against a line through the other (two
        # vertices a little more than tol apart near a corner would take the corner with them); of a run of
        # collinear vertices the first goes, and the row is looked at again. A row of collinear vertices only
        # is a sliver: empty.
        after = collinear & np.take_along_axis(collinear, (slots - 1) % n, axis=1)
        sliver = look & (m >= 3) & np.all(collinear | ~valid, axis=1)
        drop = (collinear & ~after) | (sliver[:, None] & valid)
        Q, m = _compact(Q, valid & ~drop)
        look = after.any(axis=1) & ~sliver
        if not look.any():
            break
    return Q, np.where(m >= 3, m, 0)


def _compact(P: Array, keep: npt.NDArray[np.bool_]) -> tuple[Array, npt.NDArray[np.intp]]:
    """The kept vertices of each row moved to the front, in order; their counts."""
    dest = np.cumsum(keep, axis=1) - 1
    row, col = np.nonzero(keep)
    Q = np.zeros_like(P)
    Q[row, dest[row, col]] = P[row, col]
    return Q, keep.sum(axis=1).astype(np.intp)


def polygon_area(P: Array, count: npt.NDArray[np.intp]) -> Array:
    """The (signed, counter-clockwise positive) shoelace areas of the polygons P (k, w, 2) with ``count``
    vertices (exact up to round-off; a duplicate vertex adds nothing)."""
    width = P.shape[1]
    slots = np.arange(width)[None, :]
    valid = slots < count[:, None]
    nxt = np.take_along_axis(P, ((slots + 1) % np.maximum(count, 1)[:, None])[..., None], axis=1)
    return 0.5 * np.sum(cross2(P, nxt) * valid, axis=1)


def polygon_perimeter(P: Array) -> Array:
    """The perimeters of the closed polygons P (k, n, 2) (every vertex valid)."""
    return np.sum(_norm(np.roll(P, -1, axis=1) - P), axis=1)
