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
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.frames import _E, _NOISE, _perpendicular, frames_from_normals

__all__ = ["Obstacle", "Plane", "Sphere", "Cylinder", "DEFAULT_PLANE", "OBSTACLE_TYPES", "register_obstacle",
           "closest_obstacle", "obstacle_from_dict", "obstacles_from_list", "obstacle_names", "check_obstacle_names"]

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
    if not isinstance(value[0], (int, float, np.integer, np.floating)) or isinstance(value[0], np.bool_):
        raise InputError(f"{owner}: rotation = {_show(value)}: the angle must be a number")
    angle = float(value[0])
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
    if TYPE_CHECKING:  # fields of every subclass, declared there after its geometry (the order of its arguments)
        @property
        def displacement(self) -> Vector:
            """The rigid translation δ of the scene position."""

        @property
        def name(self) -> str | None:
            """The name in messages, outputs and load paths (None: "sphere 1", ...)."""

        @property
        def rotation(self) -> Rotation | None:
            """The rotation [angle_deg, axis, centre] about the centre, or None."""

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

    def _gap_normal(self, x: Array, resolution: float = 0.0) -> tuple[Array, Array]:
        """g, n at x (``resolution``: the points' own position error; only a faceted surface's ties use it)."""
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

    def _placed_gap_normal(self, x: Array, resolution: float = 0.0) -> tuple[Array, Array]:
        """g, n at x for the placed obstacle: without a rotation the subclass's own formulas (bit for bit); with
        one, those of the obstacle at rest at y = Rᵀ(x − c), the normal rotated back: n = R n(y) (g is invariant
        under the rigid map)."""
        if getattr(self, "rotation", None) is None:
            return self._gap_normal(x, resolution)
        R, c = self.placement()
        g, n0 = self._at_rest()._gap_normal((x - c) @ R, resolution)
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

    def evaluate(self, x: npt.ArrayLike, resolution: float = 0.0) -> tuple[Array, Array, Array]:
        """(g, n, R) of each position: shapes (m,), (m, 3), (m, 3, 3); R = (t₁, t₂, n) as columns. A rotated
        obstacle's frames are those of the obstacle at rest, rotated with it. ``resolution``: the positions' own
        error (a length; 0: exact — a configuration X + u is known to its solve's accuracy): a triangulated
        surface decides its ties and "on the surface" (the tied facets' mean normal, not the noise's direction
        d/|d| at a vertex or an edge) within it."""
        if isinstance(resolution, bool) or not isinstance(resolution, (int, float, np.floating, np.integer)) \
                or not 0.0 <= float(resolution) < np.inf:
            raise InputError(f"{self.label}: resolution = {_show(resolution)}: must be a finite length >= 0")
        if getattr(self, "rotation", None) is None:
            g, n = self._gap_normal(_points(x), resolution)
            return g, n, frames_from_normals(n, self._tangent(n))
        rest = self._at_rest()
        R, c = self.placement()
        g, n0 = rest._gap_normal((_points(x) - c) @ R, resolution)
        frames = np.einsum("ij,mjk->mik", R, frames_from_normals(n0, rest._tangent(n0)))
        return g, n0 @ R.T, frames

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        """Points deep inside the placed obstacle that must never lie inside the body, shape (k, 3): the sphere's
        centre, the cylinder's axis across the box [lo, hi] (``samples`` points); none for a plane (a half-space
        has no core a body could swallow). An obstacle whose core is inside the body is buried in it, or has been
        moved through it (:func:`~fenics_coulomb.model.obstacle_checks.core_path`)."""
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

    def _gap_normal(self, x: Array, resolution: float = 0.0) -> tuple[Array, Array]:
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

    def _gap_normal(self, x: Array, resolution: float = 0.0) -> tuple[Array, Array]:
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

    def _gap_normal(self, x: Array, resolution: float = 0.0) -> tuple[Array, Array]:
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


def check_obstacle_names(obstacles: Sequence[Obstacle], where: str = "obstacles",
                         reserved: Sequence[str] = ()) -> None:
    """InputError unless the obstacles' output names (:func:`obstacle_names`) are distinct, and distinct from the
    contact pairs' (``reserved``: "pair NAME", or "pair N" unnamed): a repeated name kept one entry in summary.json,
    path.csv and the report and lost the other's force (pure)."""
    names = obstacle_names(obstacles)
    clash = [name for name in names if name in reserved]
    if clash:
        raise InputError(f"{where}: obstacle {names.index(clash[0]) + 1} is called {clash[0]!r}, the name of a contact "
                         "pair in the outputs: give it another name")
    for i, name in enumerate(names):
        if name in names[:i]:
            j = names.index(name)
            raise InputError(f"{where}: obstacles {j + 1} and {i + 1} are both called {name!r} in the outputs (an "
                             "unnamed obstacle is called '<type> <position>'): give them distinct names")


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
def closest_obstacle(obstacles: Sequence[Obstacle], x: npt.ArrayLike, resolution: float = 0.0
                     ) -> tuple[npt.NDArray[np.intp], Array, Array, Array]:
    """Assign each node to the obstacle with the smallest g (ties: the first in ``obstacles``).

    Args:
        obstacles: At least one obstacle (placed at their displacements).
        x: REFERENCE node positions, shape (m, 3).
        resolution: The positions' own error (a length; 0: exact), see :meth:`Obstacle.evaluate`.

    Returns:
        (index, g, n, R): the obstacle index per node and that obstacle's g, n and frame R.
    """
    if not obstacles:
        raise ValueError("closest_obstacle needs at least one obstacle (DEFAULT_PLANE for the paper's)")
    x = _points(x)
    results = [o.evaluate(x, resolution) for o in obstacles]
    gaps = np.stack([r[0] for r in results])  # (k, m)
    index = np.argmin(gaps, axis=0)  # first minimum on ties
    nodes = np.arange(x.shape[0])
    g = gaps[index, nodes]
    n = np.stack([r[1] for r in results])[index, nodes]
    R = np.stack([r[2] for r in results])[index, nodes]
    return index, g, n, R


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
    create: Callable[..., Obstacle] = cls  # a subclass: its geometry, then displacement, name and rotation
    return create(**args, displacement=displacement, name=name, rotation=rotation)


def obstacles_from_list(tables: Iterable[Mapping[str, Any]]) -> list[Obstacle]:
    """The obstacles of a scene's ``[[obstacle]]`` array; names must be unique (load paths move them by name)."""
    if isinstance(tables, Mapping) or isinstance(tables, (str, bytes)):
        raise InputError(f"obstacle = {_show(tables)}: must be an array of tables ([[obstacle]])")
    obstacles = [obstacle_from_dict(t, i + 1) for i, t in enumerate(tables)]
    check_obstacle_names(obstacles, "[[obstacle]]")
    return obstacles
