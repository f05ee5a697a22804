r"""Rigid obstacles from a triangulated surface (issue 26): a die, punch, rail or gear flank from CAD.

``Surface(file="die.stl", side="outward")`` (scene: ``[[obstacle]] type = "surface"``) reads the triangles of
an STL file (ASCII or binary) or of a gmsh ``.msh`` surface mesh (its 3-node triangles), once, on every rank
(the surface is small; every rank holds it), and places them translated by the obstacle's ``displacement`` δ.

Geometry: exactly the two-body master projection of :mod:`fenics_coulomb.model.pairing` on a mesh that is
rigid — the closest point x_m on the triangles (KD-tree candidates, projection on the plane or the closest
point of the edges), the tie rule (facets whose closest point is within 1e-10 h of the best one; the facet
with the lexicographically smallest sorted vertex numbers), the normal n = the facet's outward normal inside a
facet, ±(x − x_m)/|x − x_m| at an edge or vertex (the sign for which ±d lies in the normal cone of the tied
facets), the normalized sum of the tied facets' normals when x is on the surface; g = (x − x_m)·n. A node
whose ±d lies in no normal cone (beside an open surface's outer edge) sees the closest point as a point:
n = d/|d|, g = |d| (finite, so the shift stays of the geometry's size; it touches only after travelling there). The
frame is :func:`~fenics_coulomb.model.frames.frames_from_normals` (the plane/sphere rule).

Which side is solid (``side``): ``"outward"`` (default) — the triangles' normals (right-hand rule of their
vertex order) point out of the solid, toward the body; ``"inward"`` — they point into the solid. The
orientation must be consistent: every edge shared by two triangles is traversed in opposite directions
(checked; an edge shared by more than two triangles is rejected too).

Vertices: the file's vertices are merged when they coincide to 1e-12 of the bounding box's diagonal (STL
repeats them per triangle); the merged numbering (lexicographic in the coordinates) fixes the tie rule, so the
result does not depend on the file's vertex order or on the ranks.

Bad input — an unreadable or empty file, a non-finite coordinate, a degenerate triangle (area below 1e-12 of
the squared diagonal), an inconsistent orientation — is an :class:`~fenics_coulomb.errors.InputError` naming
the file and the triangle (1-based, in the file's order).
"""

from __future__ import annotations

import dataclasses
import functools
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.obstacles import _CHECKS, OBSTACLE_TYPES, Obstacle, Rotation
from fenics_coulomb.model.pairing import _norm, _pair_nodes, _Surface

__all__ = ["SIDES", "Surface", "read_triangles"]

Array = npt.NDArray[np.float64]

#: Which side of the surface is solid: the side the triangles' normals point away from (outward) or into.
SIDES = ("outward", "inward")
#: Coincident vertices are merged to this fraction of the bounding box's diagonal.
MERGE_TOL = 1e-12
#: A triangle of area below this fraction of the squared diagonal is degenerate.
DEGENERATE_TOL = 1e-12


def _read_stl(path: Path) -> Array:
    data = path.read_bytes()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count:  # binary: 80-byte header, count, 50 bytes per triangle
            record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            return np.frombuffer(data, dtype=record, count=count, offset=84)["v"].astype(np.float64)
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        raise InputError(f"surface {path}: neither a binary STL (size 84 + 50 × triangles) nor ASCII STL") from None
    if not text.lstrip().lower().startswith("solid"):
        raise InputError(f"surface {path}: an ASCII STL starts with 'solid'")
    vertices = []
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split()
        if words and words[0].lower() == "vertex":
            try:
                vertices.append([float(w) for w in words[1:4]])
            except ValueError:
                raise InputError(f"surface {path}: line {number}: a vertex needs three numbers") from None
            if len(words) != 4:
                raise InputError(f"surface {path}: line {number}: a vertex needs three numbers")
    if len(vertices) % 3:
        raise InputError(f"surface {path}: {len(vertices)} vertices are not whole triangles")
    return np.asarray(vertices, dtype=np.float64).reshape(-1, 3, 3)


def _read_msh(path: Path) -> Array:
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.open(str(path))
        except Exception as err:  # gmsh raises a bare Exception with its log's last line
            raise InputError(f"surface {path}: gmsh cannot read it ({err})") from None
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, nodes = gmsh.model.mesh.getElementsByType(2)  # 3-node triangles
        index = np.empty(int(tags.max(initial=0)) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(tags.size)
        x = coords.reshape(-1, 3)
        return x[index[nodes.astype(np.int64)]].reshape(-1, 3, 3)
    finally:
        gmsh.finalize()


@functools.lru_cache(maxsize=16)
def read_triangles(file: str) -> tuple[Array, npt.NDArray[np.int64]]:
    """The checked triangles of a surface file: (vertex coordinates (k, 3, 3), merged vertex numbers (k, 3)).

    Raises:
        InputError: Unreadable, empty, non-finite, degenerate or inconsistently oriented (see the module doc).
    """
    path = Path(file)
    if not path.is_file():
        raise InputError(f"surface {file}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".stl":
        X = _read_stl(path)
    elif suffix == ".msh":
        X = _read_msh(path)
    else:
        raise InputError(f"surface {file}: give an .stl (ASCII or binary) or a gmsh .msh file")
    if X.shape[0] == 0:
        raise InputError(f"surface {file}: no triangles")
    bad = np.flatnonzero(~np.isfinite(X).all(axis=(1, 2)))
    if bad.size:
        raise InputError(f"surface {file}: triangle {bad[0] + 1} has a non-finite coordinate {X[bad[0]].tolist()}")
    points = X.reshape(-1, 3)
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    area = 0.5 * _norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]))
    bad = np.flatnonzero(area <= DEGENERATE_TOL * diagonal**2)
    if bad.size:
        raise InputError(f"surface {file}: triangle {bad[0] + 1} is degenerate (area {area[bad[0]]:.3g})")
    key = np.round((points - points.min(axis=0)) / (MERGE_TOL * diagonal))
    _, number = np.unique(key, axis=0, return_inverse=True)
    V = number.reshape(-1, 3).astype(np.int64)
    if np.any((V[:, 0] == V[:, 1]) | (V[:, 1] == V[:, 2]) | (V[:, 0] == V[:, 2])):
        k = int(np.flatnonzero((V[:, 0] == V[:, 1]) | (V[:, 1] == V[:, 2]) | (V[:, 0] == V[:, 2]))[0])
        raise InputError(f"surface {file}: triangle {k + 1} is degenerate (two vertices coincide)")
    # orientation: each directed edge at most once; each undirected edge in at most two triangles
    directed = np.concatenate([V[:, [0, 1]], V[:, [1, 2]], V[:, [2, 0]]])
    owner = np.tile(np.arange(V.shape[0]), 3)
    _, first, counts = np.unique(directed, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        e = directed[first[np.flatnonzero(counts > 1)[0]]]
        both = np.sort(owner[np.flatnonzero((directed == e).all(axis=1))]) + 1
        raise InputError(f"surface {file}: triangles {both[0]} and {both[1]} are oriented inconsistently (they "
                         "traverse their common edge in the same direction)")
    undirected = np.sort(directed, axis=1)
    _, first, counts = np.unique(undirected, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 2):
        raise InputError(f"surface {file}: triangle {owner[first[np.flatnonzero(counts > 2)[0]]] + 1} shares an "
                         "edge with two or more others (not a surface)")
    return X, V


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

    kind: ClassVar[str] = "surface"
    keys: ClassVar[tuple[str, ...]] = ("file", "side")
    optional: ClassVar[tuple[str, ...]] = ("side",)

    def __post_init__(self) -> None:
        super().__post_init__()
        read_triangles(self.file)  # checked on creation: bad input fails before any collective call

    @property
    def placed(self) -> tuple[float, float, float]:
        """The surface's translation δ (it has no scene point)."""
        return tuple(float(c) for c in self.displacement)  # type: ignore[return-value]

    def at_scene_position(self) -> Surface:
        return dataclasses.replace(self, displacement=(0.0, 0.0, 0.0))

    @functools.cached_property
    def _surface(self) -> tuple[_Surface, Array, npt.NDArray[np.intp]]:
        X, V = read_triangles(self.file)
        sign = np.full(X.shape[0], 1.0 if self.side == "outward" else -1.0)
        size = _norm(X - X.mean(axis=1)[:, None]).max(axis=1) * 2.0  # the facet's diameter bound h
        order = np.lexsort(np.sort(V, axis=1).T[::-1])
        rank = np.empty(V.shape[0], dtype=np.intp)
        rank[order] = np.arange(V.shape[0])
        return _Surface(X, V, sign), size, rank

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        surface, size, rank = self._surface
        local = x - np.asarray(self.displacement)  # the surface moves by δ: the node moves by −δ relative to it
        out = _pair_nodes(local, surface, size, rank)
        n = out["normal"]
        d = local - out["closest"]
        # beside an open surface's outer edge (±d in no normal cone): the closest point as a point obstacle,
        # n = d/|d|, g = |d| — finite (the shift d = g n stays of the geometry's size) and never touching
        # unless the node travels the whole distance to that edge
        free = ~out["paired"]
        dn = _norm(d[free])
        n[free] = np.where(dn[:, None] > 0, d[free] / np.where(dn > 0, dn, 1.0)[:, None], n[free])
        return np.einsum("ij,ij->i", d, n), n


def _check_file(value: object, owner: str) -> str:
    if not isinstance(value, str) or not value:
        raise InputError(f"{owner}: file = {value!r}: give the path of an .stl or .msh file")
    return value


def _check_side(value: object, owner: str) -> str:
    if value not in SIDES:
        raise InputError(f"{owner}: side = {value!r}: choose one of {', '.join(SIDES)}")
    return str(value)


_CHECKS.update(file=_check_file, side=_check_side)
OBSTACLE_TYPES["surface"] = Surface
