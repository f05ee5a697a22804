r"""Rigid obstacles of any placement and shape — planes, spheres, cylinders — and per-node contact frames.

Geometry
--------
Each obstacle is placed at its scene position translated by its ``displacement`` δ (default 0):

* :class:`Plane` (``point`` p, unit ``normal`` ν pointing from the obstacle toward the body): the obstacle
  is {x : (x − p − δ)·ν ≤ 0}; g = (x − p − δ)·ν, n = ν.
* :class:`Sphere` (``center`` c, ``radius`` R, the solid ball): g = ‖x − c − δ‖ − R,
  n = (x − c − δ)/‖x − c − δ‖.
* :class:`Cylinder` (``point`` p, unit ``axis`` a, ``radius`` R, the infinite solid cylinder): with
  d = x − p − δ and its radial part ρ = d − (d·a)a, g = ‖ρ‖ − R, n = ρ/‖ρ‖.

g is the signed distance from a contact node's REFERENCE position x to the placed surface (> 0 outside)
and n the outward unit normal at the closest point x − g·n. With several obstacles a node belongs to the one
with the smallest g (ties: the first). Given normals and axes are normalized; zero or non-finite vectors and
radii R <= 0 are rejected (:class:`~fenics_coulomb.errors.InputError`).

The contact frames of the nodes and the SCD method in those frames: :mod:`fenics_coulomb.model.frames`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.frames import _E, _NOISE, _perpendicular, frames_from_normals

__all__ = ["Obstacle", "Plane", "Sphere", "Cylinder", "DEFAULT_PLANE", "OBSTACLE_TYPES", "register_obstacle",
           "closest_obstacle", "find_overlap", "check_not_overlapping", "check_solid_side", "core_path",
           "motion_placements", "rotation_text", "obstacle_from_dict", "obstacles_from_list", "obstacle_names"]

Array = npt.NDArray[np.float64]
Vector = tuple[float, float, float]


# -- validation helpers --------------------------------------------------------------------------------
def _label(name: str | None, kind: str) -> str:
    return f"{kind} {name!r}" if name else kind


def _vector(value: Any, key: str, owner: str) -> Vector:
    """Three finite numbers as a tuple of floats (bool is not a number)."""
    ok = isinstance(value, (list, tuple, np.ndarray)) and len(value) == 3
    if ok:
        ok = all(isinstance(c, (int, float, np.integer, np.floating)) and not isinstance(c, (bool, np.bool_))
                 for c in value)
    if ok:
        vec = tuple(float(c) for c in value)
        if all(math.isfinite(c) for c in vec):
            return vec  # type: ignore[return-value]
    raise InputError(f"{owner}: {key} = {_show(value)}: must be 3 finite numbers")


def _unit(value: Any, key: str, owner: str) -> Vector:
    """A finite non-zero 3-vector, normalized (scaled first, so tiny vectors do not underflow)."""
    given = _vector(value, key, owner)
    vec = np.asarray(given)
    if abs(float(np.linalg.norm(vec)) - 1.0) <= 4.0 * np.finfo(np.float64).eps:
        return given  # already a unit vector: keep it bit for bit (normalizing is idempotent)
    big = float(np.max(np.abs(vec)))
    if big == 0.0:
        raise InputError(f"{owner}: {key} = {_show(value)}: a zero vector has no direction")
    vec = vec / big
    vec = vec / np.linalg.norm(vec)
    return tuple(float(c) for c in vec)  # type: ignore[return-value]


def _radius(value: Any, owner: str) -> float:
    if (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
            and math.isfinite(float(value)) and float(value) > 0.0):
        return float(value)
    raise InputError(f"{owner}: radius = {_show(value)}: must be a finite number > 0")


def _show(value: Any) -> str:
    """A value as the user wrote it, on one line."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    text = repr(value).replace("\n", " ")
    return text if len(text) <= 80 else text[:77] + "..."


def _points(x: npt.ArrayLike) -> Array:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"node positions must have shape (m, 3), got {x.shape}")
    return x


# -- obstacles ------------------------------------------------------------------------------------------
#: How each geometry key is checked (and normalized).
#: A rigid rotation (angle in degrees, unit axis, centre): y ↦ R(y − centre) + centre, before the translation δ.
Rotation = tuple[float, Vector, Vector]


def _rotation(value: Any, owner: str) -> Rotation | None:
    """[angle_deg, [ax, ay, az], [cx, cy, cz]] (or None) checked: a finite angle, a non-zero axis, a centre."""
    if value is None:
        return None
    if not isinstance(value, (list, tuple)) or len(value) != 3 or isinstance(value[0], (list, tuple, bool)):
        raise InputError(f"{owner}: rotation = {_show(value)}: give [angle_deg, [ax, ay, az], [cx, cy, cz]]")
    try:
        angle = float(value[0])
    except (TypeError, ValueError):
        raise InputError(f"{owner}: rotation = {_show(value)}: the angle must be a number") from None
    if not math.isfinite(angle):
        raise InputError(f"{owner}: rotation angle {_show(value[0])}: must be finite")
    return (angle, _unit(value[1], "rotation axis", owner), _vector(value[2], "rotation centre", owner))


def rotation_matrix(rotation: Rotation | None) -> Array:
    """R of a rotation (Rodrigues: the angle in degrees about the unit axis), the identity for None."""
    if rotation is None:
        return np.eye(3)
    angle, axis, _ = rotation
    a = np.asarray(axis, dtype=np.float64)
    t = math.radians(angle)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(t) * K + (1.0 - math.cos(t)) * (K @ K)


_CHECKS = {
    "point": lambda value, owner: _vector(value, "point", owner),
    "center": lambda value, owner: _vector(value, "center", owner),
    "normal": lambda value, owner: _unit(value, "normal", owner),
    "axis": lambda value, owner: _unit(value, "axis", owner),
    "radius": lambda value, owner: _radius(value, owner),
    "displacement": lambda value, owner: _vector(value, "displacement", owner),
    "rotation": lambda value, owner: _rotation(value, owner),
}


@dataclass(frozen=True)
class Obstacle:
    """Base of the rigid obstacles: the geometry of the subclass, a rigid translation δ and a name.

    Subclasses are frozen dataclasses whose fields are checked (and normals/axes normalized) on creation.
    """

    kind: ClassVar[str] = ""
    #: The geometry keys (fields and scene-table keys) besides ``displacement`` and ``name``.
    keys: ClassVar[tuple[str, ...]] = ()
    #: The key of the scene position that δ translates.
    position_key: ClassVar[str] = "point"
    #: Whether :meth:`core` depends on the box it is asked for (a cylinder's axis across the body).
    box_core: ClassVar[bool] = False
    #: Whether the gap is affine in the position and the frame constant (a plane): then g(X + u) − n·u = g(X),
    #: and finite sliding evaluates it at X, bit for bit the small-sliding model.
    affine: ClassVar[bool] = False

    def __post_init__(self) -> None:
        name = getattr(self, "name", None)
        owner = _label(name, self.kind)
        _check_name(name, owner)
        for key in (*self.keys, "displacement", "rotation"):
            object.__setattr__(self, key, _CHECKS[key](getattr(self, key, None), owner))

    @property
    def label(self) -> str:
        """How messages name the obstacle, e.g. "sphere 'indenter'" or "plane"."""
        return _label(getattr(self, "name", None), self.kind)

    @property
    def placed(self) -> Vector:
        """The placed position (plane/cylinder point, sphere centre) = scene position + δ."""
        fields = vars(self)
        position, displacement = fields[self.position_key], fields["displacement"]
        return tuple(float(a + b) for a, b in zip(position, displacement, strict=True))  # type: ignore[return-value]

    def at_scene_position(self) -> Obstacle:
        """The same obstacle with δ = 0."""
        return dataclasses.replace(self, displacement=(0.0, 0.0, 0.0))  # type: ignore[call-arg]

    def rotated(self, rotation: Any) -> Obstacle:
        """The same obstacle with its rotation [angle_deg, axis, centre] replaced (None: no rotation)."""
        return dataclasses.replace(self, rotation=_rotation(rotation, self.label))  # type: ignore[call-arg]

    def moved(self, displacement: npt.ArrayLike) -> Obstacle:
        """The same obstacle with its displacement δ replaced."""
        value = np.asarray(displacement, dtype=np.float64).tolist()
        return dataclasses.replace(self, displacement=value)  # type: ignore[call-arg]

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        raise NotImplementedError

    def _tangent(self, n: Array) -> Array:
        return _perpendicular(n, 0, 1)

    def placement(self) -> tuple[Array, Array]:
        """(R, c) of the rigid map y ↦ R y + c that places the obstacle: its rotation about its centre, then the
        translation δ (R = I, c = δ without a rotation)."""
        delta = np.asarray(self.displacement, dtype=np.float64)
        rotation = getattr(self, "rotation", None)
        if rotation is None:
            return np.eye(3), delta
        R = rotation_matrix(rotation)
        centre = np.asarray(rotation[2], dtype=np.float64)
        return R, centre - R @ centre + delta

    def _at_rest(self) -> Obstacle:
        """The obstacle at its scene position, neither translated nor rotated."""
        return dataclasses.replace(self, displacement=(0.0, 0.0, 0.0), rotation=None)  # type: ignore[call-arg]

    def _placed_gap_normal(self, x: Array) -> tuple[Array, Array]:
        """g, n at x for the placed obstacle: without a rotation the subclass's own formulas (bit for bit); with
        one, those of the obstacle at rest at y = Rᵀ(x − c), the normal rotated back: n = R n(y) (g is invariant
        under the rigid map)."""
        if getattr(self, "rotation", None) is None:
            return self._gap_normal(x)
        R, c = self.placement()
        g, n0 = self._at_rest()._gap_normal((x - c) @ R)
        return g, n0 @ R.T

    def motion(self, previous: Obstacle, points: npt.ArrayLike) -> Array:
        """How far the obstacle's material points at ``points`` (placed as ``previous``) move to this placement:
        T_k(T_{k−1}⁻¹(p)) − p = R_k R_{k−1}ᵀ(p − c_{k−1}) + c_k − p, shape (m, 3). Without rotations it is
        δ_k − δ_{k−1} for every point."""
        p = _points(points)
        if getattr(self, "rotation", None) is None and getattr(previous, "rotation", None) is None:
            step = np.asarray(self.displacement, dtype=np.float64) - np.asarray(previous.displacement, dtype=np.float64)
            return np.broadcast_to(step, p.shape).copy()
        Rk, ck = self.placement()
        Rp, cp = previous.placement()
        return (p - cp) @ Rp @ Rk.T + ck - p

    def signed_distance(self, x: npt.ArrayLike) -> Array:
        """g of each REFERENCE position x (m, 3), shape (m,): signed distance to the placed surface, > 0 outside."""
        return self._placed_gap_normal(_points(x))[0]

    def normals(self, x: npt.ArrayLike) -> Array:
        """n of each position, shape (m, 3): the outward unit normal at the closest surface point."""
        return self._placed_gap_normal(_points(x))[1]

    def frames(self, x: npt.ArrayLike) -> Array:
        """The frames R = (t₁, t₂, n) (columns) of each position, shape (m, 3, 3)."""
        return self.evaluate(x)[2]

    def evaluate(self, x: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """(g, n, R) of each position: shapes (m,), (m, 3), (m, 3, 3); R = (t₁, t₂, n) as columns. A rotated
        obstacle's frames are those of the obstacle at rest, rotated with it."""
        if getattr(self, "rotation", None) is None:
            g, n = self._gap_normal(_points(x))
            return g, n, frames_from_normals(n, self._tangent(n))
        rest = self._at_rest()
        R, c = self.placement()
        g, n0 = rest._gap_normal((_points(x) - c) @ R)
        frames = np.einsum("ij,mjk->mik", R, frames_from_normals(n0, rest._tangent(n0)))
        return g, n0 @ R.T, frames

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        """Points deep inside the placed obstacle that must never lie inside the body, shape (k, 3): the sphere's
        centre, the cylinder's axis across the box [lo, hi] (``samples`` points); none for a plane (a half-space
        has no core a body could swallow). An obstacle whose core is inside the body is buried in it, or has been
        moved through it (:func:`core_path`)."""
        return np.zeros((0, 3))

    def closest_point(self, x: npt.ArrayLike) -> Array:
        """The closest point x − g·n on the placed surface, shape (m, 3)."""
        x = _points(x)
        g, n = self._placed_gap_normal(x)
        return x - g[:, None] * n

    def placed_core(self, lo: Array, hi: Array, samples: int) -> Array:
        """:meth:`core` of the placed obstacle, its rotation included (the box is the body's)."""
        if getattr(self, "rotation", None) is None:
            return self.core(lo, hi, samples)
        R, c = self.placement()
        corners = np.array([[a, b, d] for a in (lo[0], hi[0]) for b in (lo[1], hi[1]) for d in (lo[2], hi[2])])
        back = (corners - c) @ R  # the body's box seen from the obstacle at rest
        return self._at_rest().core(back.min(axis=0), back.max(axis=0), samples) @ R.T + c


@dataclass(frozen=True)
class Plane(Obstacle):
    """The half-space {x : (x − p − δ)·ν <= 0}; ν (normalized) points from the obstacle toward the body.

    The defaults are the paper's obstacle, the half-space x3 <= 0 (p = 0, ν = e3)."""

    point: Vector = (0.0, 0.0, 0.0)
    normal: Vector = (0.0, 0.0, 1.0)
    displacement: Vector = (0.0, 0.0, 0.0)
    name: str | None = None
    rotation: Rotation | None = None

    kind: ClassVar[str] = "plane"
    keys: ClassVar[tuple[str, ...]] = ("point", "normal")
    affine: ClassVar[bool] = True

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        nu = np.asarray(self.normal)
        g = (x - np.asarray(self.placed)) @ nu
        return g, np.broadcast_to(nu, x.shape).copy()


@dataclass(frozen=True)
class Sphere(Obstacle):
    """The solid ball ‖x − c − δ‖ <= R."""

    center: Vector
    radius: float
    displacement: Vector = (0.0, 0.0, 0.0)
    name: str | None = None
    rotation: Rotation | None = None

    kind: ClassVar[str] = "sphere"
    keys: ClassVar[tuple[str, ...]] = ("center", "radius")
    position_key: ClassVar[str] = "center"

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        return np.asarray(self.placed, dtype=np.float64)[None, :]

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        c = np.asarray(self.placed)
        d = x - c
        dist = np.linalg.norm(d, axis=1)
        n = np.empty_like(d)
        centre = dist <= _NOISE * (np.linalg.norm(x, axis=1) + np.linalg.norm(c))
        n[~centre] = d[~centre] / dist[~centre, None]
        n[centre] = _E[2]
        return dist - self.radius, n


@dataclass(frozen=True)
class Cylinder(Obstacle):
    """The infinite solid cylinder of radius R around the line p + δ + s·a (a normalized)."""

    point: Vector
    axis: Vector
    radius: float
    displacement: Vector = (0.0, 0.0, 0.0)
    name: str | None = None
    rotation: Rotation | None = None

    kind: ClassVar[str] = "cylinder"
    keys: ClassVar[tuple[str, ...]] = ("point", "axis", "radius")
    box_core: ClassVar[bool] = True

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        a = np.asarray(self.axis)
        d = x - np.asarray(self.placed)
        radial = d - (d @ a)[:, None] * a
        dist = np.linalg.norm(radial, axis=1)
        n = np.empty_like(d)
        on_axis = dist <= _NOISE * (np.linalg.norm(x, axis=1) + np.linalg.norm(np.asarray(self.placed)))
        n[~on_axis] = radial[~on_axis] / dist[~on_axis, None]
        n[on_axis] = _perpendicular(a[None, :], 2, 0)[0]
        return dist - self.radius, n

    def _tangent(self, n: Array) -> Array:
        return np.broadcast_to(np.asarray(self.axis), n.shape).copy()

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        p, a = np.asarray(self.placed, dtype=np.float64), np.asarray(self.axis)
        centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
        s0 = float((centre - p) @ a)  # the axis parameter nearest the box's centre
        return p + (s0 + np.linspace(-radius, radius, max(samples, 2)))[:, None] * a


def _check_name(name: Any, owner: str) -> None:
    if name is not None and (not isinstance(name, str) or not name):
        raise InputError(f"{owner}: name = {_show(name)}: must be a non-empty string")


#: The paper's obstacle, used when a scene gives none: the plane x3 = 0 with normal e₃ (frame = identity).
DEFAULT_PLANE = Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))

OBSTACLE_TYPES: dict[str, type[Obstacle]] = {"plane": Plane, "sphere": Sphere, "cylinder": Cylinder}


def obstacle_names(obstacles: Sequence[Obstacle]) -> list[str]:
    """The name of each obstacle in the outputs (report, summary.json, CSV columns, figures): its ``name``, or
    ``"<kind> <i>"`` (1-based position) for an unnamed one, e.g. ``"sphere 1"``."""
    return [getattr(o, "name", None) or f"{o.kind} {i + 1}" for i, o in enumerate(obstacles)]


def register_obstacle(cls: type[Obstacle], **checks: Callable[[Any, str], Any]) -> type[Obstacle]:
    """Make ``cls`` the ``[[obstacle]]`` type ``cls.kind``, with the checks of its own keys (``key=check(value,
    owner)``, applied on creation and to scene tables); a new obstacle type is its module and this call."""
    taken = [key for key in checks if key in _CHECKS]
    if cls.kind in OBSTACLE_TYPES or taken:
        raise ValueError(f"obstacle type {cls.kind!r} or key(s) {taken} registered twice")
    _CHECKS.update(checks)
    OBSTACLE_TYPES[cls.kind] = cls
    return cls


# -- several obstacles ---------------------------------------------------------------------------------
def closest_obstacle(obstacles: Sequence[Obstacle], x: npt.ArrayLike) -> tuple[npt.NDArray[np.intp], Array,
                                                                               Array, Array]:
    """Assign each node to the obstacle with the smallest g (ties: the first in ``obstacles``).

    Args:
        obstacles: At least one obstacle (placed at their displacements).
        x: REFERENCE node positions, shape (m, 3).

    Returns:
        (index, g, n, R): the obstacle index per node and that obstacle's g, n and frame R.
    """
    if not obstacles:
        raise ValueError("closest_obstacle needs at least one obstacle (DEFAULT_PLANE for the paper's)")
    x = _points(x)
    results = [o.evaluate(x) for o in obstacles]
    gaps = np.stack([r[0] for r in results])  # (k, m)
    index = np.argmin(gaps, axis=0)  # first minimum on ties
    nodes = np.arange(x.shape[0])
    g = gaps[index, nodes]
    n = np.stack([r[1] for r in results])[index, nodes]
    R = np.stack([r[2] for r in results])[index, nodes]
    return index, g, n, R


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


def motion_placements(before: Obstacle, after: Obstacle) -> tuple[Any, float, Array, Array, Array]:
    """The rigid motion from ``before``'s placement to ``after``'s as a path y ↦ R(t)(y − p) + p + e(t), t in
    [0, 1]: (placements(t) → (R (n, 3, 3), c (n, 3)) with c = p − R p + e, the angle turned (radians), the pivot
    p, e(0), e(1)). Rotations about one axis and centre (or none on one side) blend their angles and translations
    linearly, as a load path's substeps do (p the centre, e = δ); otherwise the relative rotation R₁R₀ᵀ is turned
    at a constant rate about the after placement's centre p while e moves on a straight line."""
    rb, ra = getattr(before, "rotation", None), getattr(after, "rotation", None)
    d0 = np.asarray(before.displacement, dtype=np.float64)
    d1 = np.asarray(after.displacement, dtype=np.float64)
    same = rb is None or ra is None or (np.allclose(rb[1], ra[1], rtol=0.0, atol=1e-12)
                                        and np.allclose(rb[2], ra[2], rtol=1e-12, atol=1e-300))
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
    R0, c0 = before.placement()
    R1, c1 = after.placement()
    axis, angle = _axis_angle(R1 @ R0.T)
    pivot = np.asarray(ra[2], dtype=np.float64)
    e0, e1 = c0 - pivot + R0 @ pivot, c1 - pivot + R1 @ pivot

    def placements(t: Array) -> tuple[Array, Array]:  # noqa: F811 (one of the two paths)
        R = _rotations(axis, t * angle) @ R0
        return R, pivot - R @ pivot + e0 + t[:, None] * (e1 - e0)

    return placements, angle, pivot, e0, e1


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

    def cores(t: Array) -> Array:
        R, c = placements(t)
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


def _mpi_lor() -> Any:
    from mpi4py import MPI

    return MPI.LOR


def _mpi_max() -> Any:
    from mpi4py import MPI

    return MPI.MAX


# -- scenes ---------------------------------------------------------------------------------------------
def obstacle_from_dict(table: Mapping[str, Any], index: int | None = None) -> Obstacle:
    """An obstacle from a scene's ``[[obstacle]]`` table (TOML), every key type-checked.

    Keys: ``type`` (plane | sphere | cylinder | surface), ``name`` (optional), ``displacement`` (optional,
    default [0, 0, 0]) and the type's own: plane ``point``, ``normal``; sphere ``center``, ``radius``; cylinder
    ``point``, ``axis``, ``radius``; surface ``file`` and ``side`` (:mod:`fenics_coulomb.model.surface`).

    Args:
        table: The parsed table.
        index: 1-based position in the scene, used in messages.

    Raises:
        InputError: One line naming the obstacle and the bad key or value.
    """
    where = "[[obstacle]]" if index is None else f"[[obstacle]] {index}"
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table, got {_show(table)}")
    name = table.get("name")
    if name is not None and (not isinstance(name, str) or not name):
        raise InputError(f"{where}: name = {_show(name)}: must be a non-empty string")
    if name:
        where = f"{where} ({name!r})"
    if "type" not in table:
        raise InputError(f"{where}: missing type (choose one of {sorted(OBSTACLE_TYPES)})")
    kind = table["type"]
    if not isinstance(kind, str) or kind not in OBSTACLE_TYPES:
        raise InputError(f"{where}: type = {_show(kind)}: choose one of {sorted(OBSTACLE_TYPES)}")
    cls = OBSTACLE_TYPES[kind]
    allowed = ("type", "name", "displacement", "rotation", *cls.keys)
    for key in table:
        if key not in allowed:
            raise InputError(f"{where}: unknown key {key!r} for a {kind} (allowed: {', '.join(allowed)})")
    optional = getattr(cls, "optional", ())
    for key in cls.keys:
        if key not in table and key not in optional:
            raise InputError(f"{where}: a {kind} needs {key}")
    args = {key: _CHECKS[key](table[key], where) for key in cls.keys if key in table}
    displacement = _CHECKS["displacement"](table.get("displacement", [0.0, 0.0, 0.0]), where)
    rotation = _CHECKS["rotation"](table.get("rotation"), where)
    return cls(**args, displacement=displacement, name=name, rotation=rotation)


def obstacles_from_list(tables: Iterable[Mapping[str, Any]]) -> list[Obstacle]:
    """The obstacles of a scene's ``[[obstacle]]`` array; names must be unique (load paths move them by name)."""
    if isinstance(tables, Mapping) or isinstance(tables, (str, bytes)):
        raise InputError(f"obstacle = {_show(tables)}: must be an array of tables ([[obstacle]])")
    obstacles = [obstacle_from_dict(t, i + 1) for i, t in enumerate(tables)]
    seen: set[str] = set()
    for i, o in enumerate(obstacles):
        name = getattr(o, "name", None)
        if name is not None:
            if name in seen:
                raise InputError(f"[[obstacle]] {i + 1}: name {name!r} is used by an earlier obstacle")
            seen.add(name)
    return obstacles
