r"""Rigid obstacles from a triangulated surface: a die, punch, rail or gear flank from CAD.

``Surface(file="die.stl", side="outward")`` (scene: ``[[obstacle]] type = "surface"``) reads the triangles of
an STL file (ASCII or binary) or of a gmsh ``.msh`` surface mesh (its 3-node triangles), once, on every rank
(the surface is small; every rank holds it), and places them translated by the obstacle's ``displacement`` δ.

Geometry: exactly the two-body master projection of :mod:`fenics_coulomb.model.pairs.projection` on a mesh that is
rigid — the closest point x_m on the triangles (candidates: the triangles whose bounding boxes lie within a
distance bound, :func:`closest_on_surface`; projection on the plane or the closest point of the edges), the tie
rule (facets whose closest point is within 1e-10 h of the best one; the facet with the lexicographically smallest
sorted vertex numbers), the normal n = the facet's outward normal inside a facet, ±(x − x_m)/|x − x_m| at an edge
or vertex (the sign for which ±d lies in the normal cone of the tied facets), the normalized sum of the tied
facets' normals when x is on the surface; g = (x − x_m)·n. A node whose ±d lies in no normal cone (beside an open
surface's outer edge) sees the closest point as a point: n = d/|d|, g = |d| (finite, so the shift stays of the
geometry's size; it touches only after travelling there). The frame is
:func:`~fenics_coulomb.model.frames.frames_from_normals` (the plane/sphere rule).

Which side is solid (``side``): ``"outward"`` (default) — the triangles' normals (right-hand rule of their
vertex order) point out of the solid, toward the body; ``"inward"`` — they point into the solid. The
orientation must be consistent: every edge shared by two triangles is traversed in opposite directions
(checked; an edge shared by more than two triangles is rejected too).

Core: a closed triangulation whose solid side is the bounded one (:func:`surface_core`) has a core — its points
at least 3/4 of its largest depth inside — which the body must never contain: a surface buried in the body, or
moved or turned through it within one step, is refused like a sphere whose centre is
(:meth:`~fenics_coulomb.model.contact_model.ContactModel.check_motion`). An open surface, or a closed one whose
solid is the outside (a cavity), has none; one whose solid side holds the whole body is refused
(:func:`~fenics_coulomb.model.obstacle_checks.check_solid_side`).

Reading the file (STL or .msh, vertices merged, orientation checked, cached by the file's identity):
:mod:`fenics_coulomb.model.triangulation`.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.obstacles import Obstacle, Rotation, register_obstacle
from fenics_coulomb.model.pairs.projection import TIE_TOL, closest_points, empty_closest, select_candidates
from fenics_coulomb.model.pairs.projection import Surface as _Surface
from fenics_coulomb.model.pairs.projection import norm as _norm
from fenics_coulomb.model.triangulation import Source, file_source, read_triangles

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

__all__ = ["SIDES", "CORE_GRID", "CORE_DEPTH", "CORE_POINTS", "SEARCH_BLOCK", "SEARCH_ENTRIES", "Surface",
           "SurfaceIndex", "closest_on_surface", "inside_closed", "surface_core", "surface_index"]

Array = npt.NDArray[np.float64]

#: Which side of the surface is solid: the side the triangles' normals point away from (outward) or into.
SIDES = ("outward", "inward")
#: The closest-point search tests the triangles' bounding boxes against this many points at once
#: (:func:`closest_on_surface`).
SEARCH_BLOCK = 256
#: ... and at most this many (point, triangle) box tests at once (a block of points over a large surface is halved).
SEARCH_ENTRIES = 1 << 20


@dataclass(frozen=True)
class Surface(Obstacle):
    """A rigid obstacle bounded by a triangulated surface (see the module docstring).

    Args:
        file: STL (ASCII or binary) or gmsh ``.msh`` file of the triangles (the scene's path is relative to
            the scene file).
        side: ``"outward"`` (the triangles' normals point out of the solid) or ``"inward"``.
        displacement: The rigid translation δ.
        name: Optional name.
    """

    file: str
    side: str = "outward"
    displacement: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str | None = None
    rotation: Rotation | None = None
    #: The file as read on creation (:data:`Source`; kept by :meth:`moved` and :meth:`rotated`): None reads it now.
    source: Source | None = dataclasses.field(default=None, repr=False)

    kind: ClassVar[str] = "surface"
    keys: ClassVar[tuple[str, ...]] = ("file", "side")
    optional: ClassVar[tuple[str, ...]] = ("side",)

    def __post_init__(self) -> None:
        super().__post_init__()
        source = self.source
        if source is None:
            source = file_source(self.file)
        elif not (isinstance(source, tuple) and len(source) == 3 and isinstance(source[0], str)):
            raise InputError(f"{self.label}: source = {source!r}: leave it out (it records the file as read)")
        object.__setattr__(self, "source", source)
        read_triangles(self.file, source)  # checked on creation: bad input fails before any collective call

    @property
    def placed(self) -> tuple[float, float, float]:
        """The surface's translation δ (it has no scene point)."""
        return tuple(float(c) for c in self.displacement)  # type: ignore[return-value]

    def at_scene_position(self) -> Surface:
        return dataclasses.replace(self, displacement=(0.0, 0.0, 0.0))

    @property
    def closed(self) -> bool:
        """Whether the triangles close a bounded solid on the solid side (:func:`surface_core` is not empty)."""
        return bool(surface_core(self.file, self.source, self.side).size)

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        """The deepest points of a bounded solid (:func:`surface_core`) translated by δ; none for an open surface or
        the unbounded side of a closed one (a cavity, like a plane's half-space, has no core a body could
        swallow)."""
        return surface_core(self.file, self.source, self.side) + np.asarray(self.displacement, dtype=np.float64)

    def _gap_normal(self, x: Array, resolution: float = 0.0) -> tuple[Array, Array]:
        index = surface_index(self.file, self.source, self.side)
        local = x - np.asarray(self.displacement)  # the surface moves by δ: the node moves by −δ relative to it
        out = closest_on_surface(local, index, resolution)
        n = out["normal"]
        d = local - out["closest"]
        # beside an open surface's outer edge (±d in no normal cone): the closest point as a point obstacle,
        # n = d/|d|, g = |d| — finite (the shift d = g n stays of the geometry's size) and never touching
        # unless the node travels the whole distance to that edge
        free = ~out["paired"]
        dn = _norm(d[free])
        n[free] = np.where(dn[:, None] > 0, d[free] / np.where(dn > 0, dn, 1.0)[:, None], n[free])
        return np.einsum("ij,ij->i", d, n), n


@dataclass(frozen=True)
class SurfaceIndex:
    """The triangles of a surface at rest, prepared once for :func:`closest_on_surface`.

    Attributes:
        surface: The triangles with their merged vertex numbers and orientation (+1 outward, −1 inward).
        size: Each triangle's diameter bound h (twice the largest centroid–vertex distance).
        rank: Each triangle's position in the lexicographic order of its sorted vertex numbers (the tie rule).
        centres: The centroids, shape (k, 3).
        lower: The lower corners of the triangles' bounding boxes, shape (k, 3).
        upper: Their upper corners, shape (k, 3).
        normals: The unit normals of the triangles' planes (right-hand rule), shape (k, 3).
        offsets: The planes' offsets n·v₀, shape (k,).
        tree: A KD-tree of the centroids (the first distance bound).
    """

    surface: _Surface
    size: Array
    rank: npt.NDArray[np.intp]
    centres: Array
    lower: Array
    upper: Array
    normals: Array
    offsets: Array
    tree: cKDTree


@functools.lru_cache(maxsize=16)
def surface_index(file: str, source: Source, side: str) -> SurfaceIndex:
    """The :class:`SurfaceIndex` of a surface file as read (``source``) with its solid ``side`` (cached: every
    moved or rotated copy of an obstacle shares it)."""
    from scipy.spatial import cKDTree  # scipy only where used (fenics_coulomb/__init__.py)

    X, V = read_triangles(file, source)
    sign = np.full(X.shape[0], 1.0 if side == "outward" else -1.0)
    centres = X.mean(axis=1)
    size = _norm(X - centres[:, None]).max(axis=1) * 2.0  # the facet's diameter bound h
    order = np.lexsort(np.sort(V, axis=1).T[::-1])
    rank = np.empty(V.shape[0], dtype=np.intp)
    rank[order] = np.arange(V.shape[0])
    normals = np.asarray(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), dtype=np.float64)
    normals /= _norm(normals)[:, None]
    return SurfaceIndex(_Surface(X, V, sign), size, rank, centres, X.min(axis=1), X.max(axis=1), normals,
                        np.einsum("ij,ij->i", normals, X[:, 0]), cKDTree(centres))


def _box_candidates(x: Array, bound: Array, index: SurfaceIndex) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """The (point, triangle) pairs whose bounding-box distance is at most ``bound`` of the point, sorted by point
    then triangle. The box distance never exceeds the triangle's distance, so every triangle within ``bound`` is
    among them. The points are taken in blocks of at most SEARCH_BLOCK, in a coarse spatial order within each size
    class of their bounds (powers of 2); each block tests only the triangles whose boxes meet the block's own box
    widened by its largest bound, and a block whose test would exceed SEARCH_ENTRIES (point, triangle) entries is
    halved (NumPy, no loop over points)."""
    m = x.shape[0]
    lo, hi = x.min(axis=0), x.max(axis=0)
    cells = np.floor(8.0 * (x - lo) / np.where(hi > lo, hi - lo, 1.0)).astype(np.int64)
    # a far point's bound does not widen the box of its near neighbours' block
    level = np.floor(np.log2(np.maximum(bound, np.finfo(float).tiny))).astype(np.int64)
    order = np.lexsort((*cells.T[::-1], level))
    blocks = [order[start:start + SEARCH_BLOCK] for start in range(0, m, SEARCH_BLOCK)][::-1]
    points_l, facets_l = [], []
    while blocks:
        sel = blocks.pop()
        xb, ub = x[sel], bound[sel]
        reach = float(ub.max())
        near = np.flatnonzero(np.all(index.lower <= xb.max(axis=0) + reach, axis=1)
                              & np.all(index.upper >= xb.min(axis=0) - reach, axis=1))
        if sel.size > 1 and sel.size * near.size > SEARCH_ENTRIES:
            half = sel.size // 2
            blocks += [sel[half:], sel[:half]]
            continue
        distance = np.zeros((sel.size, near.size))
        for axis in range(3):  # the squared distance from each point to each box, one axis at a time
            gap = np.maximum(np.maximum(index.lower[near, axis][None] - xb[:, axis, None],
                                        xb[:, axis, None] - index.upper[near, axis][None]), 0.0)
            distance += gap * gap
        point, facet = np.nonzero(distance <= (ub * ub)[:, None])
        points_l.append(sel[point])
        facets_l.append(near[facet])
    point = np.concatenate(points_l)
    facet = np.concatenate(facets_l)
    keep = np.lexsort((facet, point))
    return point[keep], facet[keep]


def closest_on_surface(x: Array, index: SurfaceIndex, resolution: float = 0.0) -> dict[str, npt.NDArray[Any]]:
    """Closest points, weights, facets, normals and cone membership of the points x (m, 3) on a surface at rest:
    the two-body master projection with its tie and normal-cone rules
    (:mod:`fenics_coulomb.model.pairs.projection`), the same numbers as its search over every facet.

    Candidates: a bound U on each point's distance from its 4 nearest triangle centroids (the pairing's), then
    every triangle whose bounding box (:func:`_box_candidates`) and plane lie within U — a triangle nearer than U,
    or tied with the nearest (U carries the tie tolerance), is among them. Thin triangles (a prism's sides, a fan's
    spokes) do not widen the search of every point, as a bound through their centroids' radius does, and the planes
    keep a curved surface's far facets out.
    """
    surface = index.surface
    m, nv = x.shape[0], surface.X.shape[1]
    out = empty_closest(m, nv)
    nf = surface.X.shape[0]
    if m == 0 or nf == 0:
        return out
    size = index.size
    hmax = float(size.max())
    k0 = min(nf, 4)
    _, ii = index.tree.query(x, k=k0)
    ii = ii.reshape(m, k0)
    _, _, dist = closest_points(np.repeat(x, k0, axis=0), surface.X[ii.ravel()])
    bound = dist.reshape(m, k0).min(axis=1) + max(TIE_TOL * hmax, resolution) + 1e-12 * (hmax + np.abs(x).max())
    # the boxes' and the planes' distances (each at most the triangle's) are compared with a bound widened by its
    # own round-off
    bound = bound * (1.0 + 1e-12)
    node, facet = _box_candidates(x, bound, index)
    plane = np.abs(np.einsum("ij,ij->i", index.normals[facet], x[node]) - index.offsets[facet])
    near = plane <= bound[node]
    node, facet = node[near], facet[near]
    select_candidates(x, node, facet, surface, size, index.rank, out, resolution)
    return out


#: The grid of :func:`surface_core`: points per axis of the solid's bounding box.
CORE_GRID = 32
#: The core of a bounded solid: its points at least this fraction of its largest depth inside (a ball: the ball of
#: radius R/4 about its centre; a slab: its middle quarter). A solid indenting the body deeper than 3/4 of its
#: largest inscribed radius is rejected as buried (an analytic sphere: deeper than R).
CORE_DEPTH = 0.75
#: At most this many core points (every k-th of the grid's, in grid order): the motion check tests each along the
#: obstacle's path.
CORE_POINTS = 64


def _crossings(X: Array, xy: Array) -> tuple[npt.NDArray[np.intp], Array]:
    """The crossings of the vertical lines through ``xy`` (m, 2) with the triangles X (k, 3, 3): (line index, height)
    per crossing (barycentric test in the projection on x₁x₂, vectorized in blocks; triangles parallel to e₃ are
    never crossed)."""
    a, b, c = X[:, 0], X[:, 1], X[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    keep = det != 0.0
    a, b, c, det = a[keep], b[keep], c[keep], det[keep]
    lines, heights = [], []
    block = max(1, 500_000 // max(a.shape[0], 1))
    for start in range(0, xy.shape[0], block):
        p = xy[start:start + block, None, :]
        l1 = ((p[..., 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (p[..., 1] - a[:, 1])) / det
        l2 = ((b[:, 0] - a[:, 0]) * (p[..., 1] - a[:, 1]) - (p[..., 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
        l0 = 1.0 - l1 - l2
        line, tri = np.nonzero((l0 >= 0.0) & (l1 >= 0.0) & (l2 >= 0.0))
        lines.append(line + start)
        heights.append(l0[line, tri] * a[tri, 2] + l1[line, tri] * b[tri, 2] + l2[line, tri] * c[tri, 2])
    return np.concatenate(lines), np.concatenate(heights)


def inside_closed(X: Array, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Which ``points`` (m, 3) lie inside the closed triangulation X (k, 3, 3): an odd number of crossings of the
    ray from the point in the direction +e₃ (points in general position: a ray through an edge or a vertex would
    count the crossing twice)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    line, z = _crossings(X, points[:, :2])
    above = z > points[line, 2]
    return np.bincount(line[above], minlength=points.shape[0]) % 2 == 1


def _inside_grid(X: Array, axes: list[Array]) -> npt.NDArray[np.bool_]:
    """:func:`inside_closed` for the grid of ``axes`` (x₁, x₂, x₃ values), shape (n₁, n₂, n₃): the crossings
    are found once per vertical line and counted above each height by a cumulative sum."""
    xy = np.stack(np.meshgrid(axes[0], axes[1], indexing="ij"), axis=-1).reshape(-1, 2)
    line, z = _crossings(X, xy)
    levels = axes[2]
    below = np.searchsorted(levels, z, side="left")  # the levels 0 .. below − 1 lie under the crossing
    counts = np.zeros((xy.shape[0], levels.size + 1), dtype=np.int64)
    np.add.at(counts, (line, np.zeros_like(line)), 1)
    np.add.at(counts, (line, below), -1)
    inside = np.cumsum(counts, axis=1)[:, :-1] % 2 == 1
    return inside.reshape(axes[0].size, axes[1].size, levels.size)


@functools.lru_cache(maxsize=16)
def surface_core(file: str, source: Source, side: str) -> Array:
    """The core of a surface obstacle at rest, shape (k, 3): when its triangles are closed (every edge shared by two
    triangles) and the solid side is the bounded one (the signed volume Σ det(v₀, v₁, v₂)/6 positive for
    ``outward``, negative for ``inward``), the points of a :data:`CORE_GRID`³ grid over its bounding box that lie
    inside (:func:`inside_closed`) at least :data:`CORE_DEPTH` of the deepest one's distance from the triangles (the
    deepest included); otherwise no point. The grid is shifted off the box by irrational fractions of its step, so
    no ray meets an edge of a mesh generator's round coordinates."""
    X, V = read_triangles(file, source)
    undirected = np.sort(np.concatenate([V[:, [0, 1]], V[:, [1, 2]], V[:, [2, 0]]]), axis=1)
    _, counts = np.unique(undirected, axis=0, return_counts=True)
    volume = float(np.sum(np.linalg.det(X))) / 6.0
    if np.any(counts != 2) or volume == 0.0 or (volume > 0.0) != (side == "outward"):
        return np.zeros((0, 3))
    lo, hi = X.reshape(-1, 3).min(axis=0), X.reshape(-1, 3).max(axis=0)
    step = (hi - lo) / CORE_GRID
    axes = [lo[i] + step[i] * (np.arange(CORE_GRID) + shift) for i, shift in enumerate((0.5 / np.sqrt(2.0),
                                                                                       0.5 / np.sqrt(3.0),
                                                                                       0.5 / np.sqrt(5.0)))]
    inside = _inside_grid(X, axes)
    if not np.any(inside):
        return np.zeros((0, 3))
    # the depth: the distance to the nearest grid point outside (within a grid step of the distance to the
    # triangles), padded so the box's border counts as outside
    from scipy.ndimage import distance_transform_edt  # scipy only where used (fenics_coulomb/__init__.py)

    depth = distance_transform_edt(np.pad(inside, 1), sampling=step)[1:-1, 1:-1, 1:-1]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    core = grid[inside & (depth >= CORE_DEPTH * depth.max())]
    return core[:: -(-core.shape[0] // CORE_POINTS)]  # every k-th in grid order: at most CORE_POINTS


def _check_file(value: object, owner: str) -> str:
    if not isinstance(value, str) or not value:
        raise InputError(f"{owner}: file = {value!r}: give the path of an .stl or .msh file")
    return value


def _check_side(value: object, owner: str) -> str:
    if value not in SIDES:
        raise InputError(f"{owner}: side = {value!r}: choose one of {', '.join(SIDES)}")
    return str(value)


register_obstacle(Surface, file=_check_file, side=_check_side)
