"""The checks of rigid obstacles against the body they meet.

* At the scene position (δ = 0): an obstacle that overlaps the body (:func:`find_overlap`,
  :func:`check_not_overlapping`; an overlap caused by δ is an indentation, valid input), and a body that lies
  wholly on an obstacle's solid side (:func:`check_solid_side`: a plane's normal or a surface's side given the
  wrong way round).
* Along a rigid motion between two placements (:func:`motion_placements`: translation and rotation blended as a
  load path's substeps do): the obstacle's core swept through the body's box (:func:`core_path`), which
  :class:`~fenics_coulomb.model.placement.ObstaclePlacement` tests for an obstacle buried in the body or moved or
  turned through it; :func:`rotation_text` for its messages.
* After a solve: how deep the nodes of the contact boundary end inside any obstacle (:func:`obstacle_depths`): a
  contact node meets the constraint of one obstacle (the smallest gap) and must not end inside another (a corner
  between two obstacles), and a node that a support holds is no contact node and must not end inside one either.

The obstacles themselves (geometry, registry, parsing): :mod:`fenics_coulomb.model.obstacles`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.obstacles import Obstacle, _points

__all__ = ["find_overlap", "check_not_overlapping", "check_solid_side", "motion_placements", "core_path",
           "rotation_text", "obstacle_depths", "same_point"]

Array = npt.NDArray[np.float64]


def find_overlap(obstacles: Sequence[Obstacle], x: npt.ArrayLike, tol: float) -> tuple[float, str] | None:
    """The deepest overlap of the body's nodes x with the obstacles at their SCENE positions (δ = 0).

    Returns None, or (depth, message) for the deepest node with g < −tol over all obstacles (the first
    obstacle on ties), the message naming the obstacle, the node's coordinates and its depth.
    """
    x = _points(x)
    worst: tuple[float, str] | None = None
    for k, obstacle in enumerate(obstacles):
        g = obstacle.at_scene_position().signed_distance(x)
        if g.size == 0:
            continue
        i = int(np.argmin(g))
        depth = -float(g[i])
        if depth > tol and (worst is None or depth > worst[0]):
            where = ", ".join(f"{c:.6g}" for c in x[i])
            worst = (depth, f"obstacle {k + 1} ({obstacle.label}) overlaps the body at its scene position: "
                            f"node ({where}) lies {depth:.6g} inside it (move the body or the obstacle; "
                            "only its displacement may push into the body)")
    return worst


def check_not_overlapping(obstacles: Sequence[Obstacle], x: npt.ArrayLike, tol: float | None = None,
                          comm: Any = None) -> None:
    """Raise InputError if an obstacle at its scene position (δ = 0) overlaps the body (g < −tol).

    The obstacles' displacements are ignored (an overlap caused by δ is an indentation, valid input).

    Args:
        obstacles: The scene's obstacles.
        x: This rank's contact-node REFERENCE positions, shape (m, 3).
        tol: Tolerated depth (round-off of mesh generators); default 1e-12 × the largest |coordinate|
            (global when ``comm`` is given).
        comm: An MPI communicator: then collective, and every rank raises the same message, that of the
            deepest node over all ranks.
    """
    x = _points(x)
    if tol is None:
        size = float(np.abs(x).max(initial=0.0))
        if comm is not None:
            size = comm.allreduce(size, op=_mpi_max())
        tol = 1e-12 * size
    worst = find_overlap(obstacles, x, tol)
    if comm is not None:
        everyone = [w for w in comm.allgather(worst) if w is not None]
        worst = max(everyone, key=lambda w: w[0]) if everyone else None
    if worst is not None:
        raise InputError(worst[1])


def _rotations(axis: Array, angles: Array) -> Array:
    """Rodrigues' matrices about the unit ``axis`` by ``angles`` (radians), shape (n, 3, 3)."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return (np.eye(3) + np.sin(angles)[:, None, None] * K + (1.0 - np.cos(angles))[:, None, None] * (K @ K))


def _axis_angle(R: Array) -> tuple[Array, float]:
    """The unit axis and the angle in [0, π] of a rotation matrix."""
    angle = float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-12:
        return np.array([0.0, 0.0, 1.0]), 0.0
    if np.pi - angle < 1e-6:  # a half turn: R + I = 2 a aᵀ
        B = R + np.eye(3)
        column = B[:, int(np.argmax(np.diag(B)))]
        return column / np.linalg.norm(column), angle
    return w / np.linalg.norm(w), angle


def same_point(a: Any, b: Any) -> bool:
    """Whether two points (a rotation's centres) are one up to the round-off of their coordinates: within 1e-12 of
    the larger's distance from the origin (a length: no absolute tolerance, which would depend on the unit)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return bool(np.linalg.norm(a - b) <= 1e-12 * max(float(np.linalg.norm(a)), float(np.linalg.norm(b))))


def motion_placements(before: Obstacle, after: Obstacle) -> tuple[Any, float, Array, Array, Array]:
    """The rigid motion from ``before``'s placement to ``after``'s as a path y ↦ R(t)(y − p) + p + e(t), t in
    [0, 1]: (placements(t) → (R (n, 3, 3), c (n, 3)) with c = p − R p + e, the angle turned (radians), the pivot
    p, e(0), e(1)). Rotations about one axis and centre (or none on one side) blend their angles and translations
    linearly, as a load path's substeps do (p the centre, e = δ); otherwise the relative rotation R₁R₀ᵀ is turned
    at a constant rate about the after placement's centre p while e moves on a straight line."""
    rb, ra = getattr(before, "rotation", None), getattr(after, "rotation", None)
    d0 = np.asarray(before.displacement, dtype=np.float64)
    d1 = np.asarray(after.displacement, dtype=np.float64)
    same = rb is None or ra is None or (np.allclose(rb[1], ra[1], rtol=0.0, atol=1e-12) and same_point(rb[2], ra[2]))
    if same:
        given = ra if ra is not None else rb
        axis = np.asarray(given[1] if given else (0.0, 0.0, 1.0), dtype=np.float64)
        pivot = np.asarray(given[2] if given else (0.0, 0.0, 0.0), dtype=np.float64)
        a0, a1 = math.radians(rb[0]) if rb else 0.0, math.radians(ra[0]) if ra else 0.0
        e0, e1 = d0, d1

        def placements(t: Array) -> tuple[Array, Array]:
            R = _rotations(axis, a0 + t * (a1 - a0))
            return R, pivot - R @ pivot + e0 + t[:, None] * (e1 - e0)

        return placements, abs(a1 - a0), pivot, e0, e1
    assert ra is not None  # not the same rotation: both rotated
    R0, c0 = before.placement()
    R1, c1 = after.placement()
    axis, angle = _axis_angle(R1 @ R0.T)
    pivot = np.asarray(ra[2], dtype=np.float64)
    e0, e1 = c0 - pivot + R0 @ pivot, c1 - pivot + R1 @ pivot

    def turning(t: Array) -> tuple[Array, Array]:
        R = _rotations(axis, t * angle) @ R0
        return R, pivot - R @ pivot + e0 + t[:, None] * (e1 - e0)

    return turning, angle, pivot, e0, e1


def rotation_text(obstacle: Obstacle) -> str:
    """An obstacle's rotation for messages: "none" or "[angle, axis, centre]"."""
    rotation = getattr(obstacle, "rotation", None)
    return "none" if rotation is None else f"[{rotation[0]:g}, {list(rotation[1])}, {list(rotation[2])}]"


def _box_distance(points: Array, lo: Array, hi: Array) -> Array:
    """The distance of each point (..., 3) from the box [lo, hi] (0 inside)."""
    return np.linalg.norm(np.maximum(np.maximum(lo - points, points - hi), 0.0), axis=-1)


def core_path(before: Obstacle, after: Obstacle, lo: Array, hi: Array, spacing: float,
              limit: int = 1_000_000) -> tuple[Array, Array]:
    """The cores (:meth:`Obstacle.core`) of an obstacle along its rigid motion from ``before`` to ``after``
    (:func:`motion_placements`: the translation and the rotation), sampled so that no core point moves more than
    ``spacing`` between two samples while it is near the body's box [lo, hi] — far from the box the path is
    skipped, so a long move costs no more than a short one: (points (k, 3), their path parameters t (k,)).

    Sampling: a core point moves at most S = |Δθ|·r + |Δc| over the path (r its largest distance from the pivot);
    a sample t stands for the part of the path within h of it, and is refined (16 times finer) only when some core
    point lies within S·h of the box; it stops at S·h <= ``spacing`` (at most about ``limit`` points).
    """
    rest = after._at_rest()
    placements, angle, pivot, e0, e1 = motion_placements(before, after)
    corners = np.array([[a, b, d] for a in (lo[0], hi[0]) for b in (lo[1], hi[1]) for d in (lo[2], hi[2])])
    diagonal = float(np.linalg.norm(hi - lo))
    axis_samples = max(2, min(int(np.ceil(diagonal / max(spacing, 1e-300))) + 1, 200))

    def cores(t: npt.ArrayLike) -> Array:
        R, c = placements(np.asarray(t, dtype=np.float64))
        if not rest.box_core:
            return np.einsum("nij,kj->nki", R, rest.core(lo, hi, axis_samples)) + c[:, None, :]
        out = []
        for Rn, cn in zip(R, c, strict=True):  # the core across the body's box seen from the obstacle at rest
            back = (corners - cn) @ Rn
            out.append(rest.core(back.min(axis=0), back.max(axis=0), axis_samples) @ Rn.T + cn)
        return np.stack(out)

    ends = cores(np.array([0.0, 1.0]))
    if not ends.size:
        return np.zeros((0, 3)), np.zeros(0)
    # a core point R(t)(q − p) + p + e(t) moves at most |Δθ|·|q − p| + |e₁ − e₀|
    reach = max(float(np.linalg.norm(ends[0] - pivot - e0, axis=-1).max()),
                float(np.linalg.norm(ends[1] - pivot - e1, axis=-1).max()))
    if rest.box_core:  # the part of an unbounded core that meets the box: within the box's reach of it
        reach = max(reach, float(np.linalg.norm(corners - pivot - e0, axis=-1).max()),
                    float(np.linalg.norm(corners - pivot - e1, axis=-1).max())) + diagonal
    speed = angle * reach + float(np.linalg.norm(e1 - e0))
    if speed <= spacing:
        t = np.array([0.0, 1.0])
        return ends.reshape(-1, 3), np.repeat(t, ends.shape[1])
    t, h = np.linspace(0.0, 1.0, 17), 1.0 / 16.0
    while True:
        points = cores(t)
        if speed * h <= spacing:
            return points.reshape(-1, 3), np.repeat(t, points.shape[1])
        near = _box_distance(points, lo, hi).min(axis=1) <= speed * h
        if np.count_nonzero(near) * 33 * points.shape[1] > limit:  # no finer: the samples so far
            return points.reshape(-1, 3), np.repeat(t, points.shape[1])
        t = np.unique(np.clip((t[near][:, None] + h * np.linspace(-1.0, 1.0, 33)).ravel(), 0.0, 1.0))
        h /= 16.0
        if not t.size:
            return np.zeros((0, 3)), np.zeros(0)


def check_solid_side(obstacles: Sequence[Obstacle], x: npt.ArrayLike, comm: Any, size: float) -> None:
    """InputError on every rank when the whole body lies inside an obstacle at its scene position (δ = 0): every
    node x (this rank's, shape (m, 3)) at g <= 1e-9·``size`` — a plane or an open surface whose solid side was
    given as the body's side, or a solid that swallows the body — which would solve to "no contact" (collective;
    a deterministic sample of the nodes is tested first, all of them only when the whole sample is inside)."""
    x = _points(x)
    tol = 1e-9 * size
    for k, obstacle in enumerate(obstacles):
        placed = obstacle.at_scene_position()
        sample = x[:: max(1, x.shape[0] // 2000)]
        outside = bool(sample.size and np.any(placed.signed_distance(sample) > tol))
        if comm.allreduce(outside, op=_mpi_lor()):
            continue
        g = placed.signed_distance(x) if x.size else np.zeros(0)
        outside = bool(np.any(g > tol))
        deepest = float(-g.min(initial=0.0))
        if comm.allreduce(outside, op=_mpi_lor()) or comm.allreduce(deepest, op=_mpi_max()) <= tol:
            continue
        if obstacle.kind == "plane":
            normal = list(getattr(obstacle, "normal", ()))
            how = (f"its normal {normal} must point from the obstacle toward the body (the solid is the side it "
                   "points away from): flip it")
        elif obstacle.kind == "surface":
            side = getattr(obstacle, "side", "outward")
            how = (f"side = {side!r} makes the body's side solid: use side = "
                   f"{'inward' if side == 'outward' else 'outward'!r} or reorient the triangles")
        else:
            how = "the body lies inside it: move or shrink it"
        raise InputError(f"obstacle {k + 1} ({obstacle.label}): every node of the body lies inside the obstacle at "
                         f"its scene position (the body is on its solid side, no contact could form); {how}")


def obstacle_depths(obstacles: Sequence[Obstacle], x: npt.ArrayLike, u: npt.ArrayLike, contact: npt.ArrayLike,
                    finite: bool = False, roundoff: float = 0.0) -> tuple[Array, Array]:
    """How deep each node ends inside each obstacle, max(−g_o, 0) over the obstacles o: under finite sliding g_o the
    signed distance of x + u from o, under small sliding its linearization about the reference, g_o(x) +
    n_o(x)·u (the small-sliding model's gap). For the obstacle a contact node belongs to this is (to the geometry's
    tolerance) the model's own gap, which the penetration check measures; for the others, and for nodes that are no
    contact nodes, it is the constraint the node was not given.

    Args:
        obstacles: The obstacles as placed.
        x: Reference positions of the nodes, shape (m, 3).
        u: Their displacements, shape (m, 3).
        contact: Which nodes are contact nodes, shape (m,).
        finite: Finite sliding (the distance at x + u) or small sliding (linearized about x).
        roundoff: Depths up to this count as touching (round-off below a surface: mesh generators place nodes
            1e-17 below a plane they lie on, as the placement forgives).

    Returns:
        (the deepest of each contact node over the obstacles, the deepest of each other node), shapes
        (contact nodes,) and (other nodes,).
    """
    x, u = _points(x), _points(u)
    contact = np.asarray(contact, dtype=bool)
    depth = np.zeros(x.shape[0])
    for obstacle in obstacles:
        if finite:
            g = obstacle.evaluate(x + u)[0]
        else:
            g, n, _ = obstacle.evaluate(x)
            g = g + np.einsum("ij,ij->i", n, u)
        np.maximum(depth, -g, out=depth)
    depth[depth <= roundoff] = 0.0
    return depth[contact], depth[~contact]


def _mpi_lor() -> Any:
    from mpi4py import MPI

    return MPI.LOR


def _mpi_max() -> Any:
    from mpi4py import MPI

    return MPI.MAX
