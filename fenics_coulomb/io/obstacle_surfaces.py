"""The rigid obstacles as triangulated surfaces over time: ``obstacles.xdmf`` + ``obstacles.h5`` of a result set.

Every obstacle is tessellated once, at rest (its scene geometry, neither translated nor rotated), then each time of
the series places those points with the obstacle's placement y ↦ R y + c of that time (its rotation about its
centre, then its displacement δ: :meth:`~fenics_coulomb.model.obstacles.Obstacle.placement`), so that a rolling
obstacle's surface turns with it and the series has one triangulation and one point set per time:

* a plane: a square patch of the plane, centred where the body's bounding box projects onto it, of side
  1.5 × the box's diagonal (:data:`PLANE_CELLS` squares a side, two triangles each);
* a sphere: a latitude–longitude triangulation (:data:`SPHERE_RINGS` latitudes, :data:`SPHERE_SEGMENTS`
  meridians; its vertices lie on the sphere, its edges within 0.5 % of the radius);
* a cylinder (infinite): a tube of :data:`CYLINDER_SEGMENTS` sides over the body's extent along the axis plus an
  eighth of it at each end;
* a triangulated surface (STL, .msh): its triangles as given (coincident vertices merged).

The body's box is the reference configuration's, seen from each obstacle at rest in its first placement of the
series (a rotated plane or cylinder covers the body where it is placed).

Point fields (constant over time, written once): ``obstacle`` (int32: 1, 2, … in the order of the problem's
obstacles; the grid's ``obstacles`` information item names them), ``rest_position`` (the point of the obstacle at
rest, L: the material point that moves with it) and ``octant`` (int32 0/1: the parity of the signs of the rest
position's components about the obstacle's reference point in its own frame, a beach-ball pattern that turns
with a rolling obstacle). HDF5 layout: ``/Mesh/triangles`` (T × 3 int64), ``/Mesh/geometry/<k>`` (N × 3 float64,
the placed points of the k-th time), ``/Function/<field>``. Written on rank 0 alone (every rank holds the same
obstacles); the times are those of ``solution.xdmf``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.io.results import rank0_file
from fenics_coulomb.io.xdmf import _number_type, _write_xml
from fenics_coulomb.model.frames import _perpendicular
from fenics_coulomb.model.obstacles import Obstacle, obstacle_names

__all__ = ["CYLINDER_SEGMENTS", "PLANE_CELLS", "SPHERE_RINGS", "SPHERE_SEGMENTS", "TESSELLATIONS", "ObstacleSeries",
           "body_box", "tessellate"]

Array = npt.NDArray[np.float64]
Triangles = npt.NDArray[np.int64]

#: Squares per side of a plane's patch.
PLANE_CELLS = 16
#: Latitudes (between the poles) and meridians of a sphere's triangulation.
SPHERE_RINGS, SPHERE_SEGMENTS = 23, 48
#: Sides of a cylinder's tube (and its rings along the axis).
CYLINDER_SEGMENTS, CYLINDER_RINGS = 64, 16


def body_box(x: npt.ArrayLike, comm: MPI.Comm) -> tuple[Array, Array]:
    """The bounding box (lo, hi) of the points ``x`` of every rank (collective)."""
    x = np.asarray(x, dtype=np.float64).reshape(-1, 3)
    lo, hi = np.empty(3), np.empty(3)
    comm.Allreduce(np.ascontiguousarray(x.min(axis=0, initial=np.inf)), lo, op=MPI.MIN)
    comm.Allreduce(np.ascontiguousarray(x.max(axis=0, initial=-np.inf)), hi, op=MPI.MAX)
    return lo, hi


def _grid_triangles(rows: int, columns: int, closed: bool) -> Triangles:
    """Two triangles per quad of a (rows × columns) point grid numbered row by row; ``closed`` joins the last
    column to the first."""
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(columns if closed else columns - 1), indexing="ij")
    a = i * columns + j
    b = i * columns + (j + 1) % columns
    c, d = a + columns, b + columns
    return np.concatenate([np.stack([a, b, d], axis=-1).reshape(-1, 3),
                           np.stack([a, d, c], axis=-1).reshape(-1, 3)]).astype(np.int64)


def _frame(normal: npt.ArrayLike) -> Array:
    """Rows t₁, t₂, n of a right-handed frame with the unit ``normal`` as n."""
    n = np.asarray(normal, dtype=np.float64)
    t1 = _perpendicular(n[None, :], 0, 1)[0]
    return np.stack([t1, np.cross(n, t1), n])


def _plane(obstacle: Obstacle, lo: Array, hi: Array) -> tuple[Array, Triangles, Array, Array]:
    frame = _frame(obstacle.normal)  # type: ignore[attr-defined]
    centre = 0.5 * (lo + hi)
    centre = centre - float((centre - np.asarray(obstacle.point)) @ frame[2]) * frame[2]  # type: ignore[attr-defined]
    s = np.linspace(-0.75, 0.75, PLANE_CELLS + 1) * float(np.linalg.norm(hi - lo))
    u, v = np.meshgrid(s, s, indexing="ij")
    points = centre + u.reshape(-1, 1) * frame[0] + v.reshape(-1, 1) * frame[1]
    return points, _grid_triangles(PLANE_CELLS + 1, PLANE_CELLS + 1, closed=False), centre, frame


def _sphere(obstacle: Obstacle, lo: Array, hi: Array) -> tuple[Array, Triangles, Array, Array]:
    centre, radius = np.asarray(obstacle.center, dtype=np.float64), float(obstacle.radius)  # type: ignore[attr-defined]
    theta = np.pi * np.arange(1, SPHERE_RINGS + 1) / (SPHERE_RINGS + 1)
    phi = 2.0 * np.pi * np.arange(SPHERE_SEGMENTS) / SPHERE_SEGMENTS
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    points = centre + radius * np.concatenate([[[0.0, 0.0, 1.0]], ring, [[0.0, 0.0, -1.0]]])
    j = np.arange(SPHERE_SEGMENTS)
    north = np.stack([np.zeros_like(j), 1 + j, 1 + (j + 1) % SPHERE_SEGMENTS], axis=-1)
    last, south = 1 + (SPHERE_RINGS - 1) * SPHERE_SEGMENTS, points.shape[0] - 1
    south_cap = np.stack([last + (j + 1) % SPHERE_SEGMENTS, last + j, np.full_like(j, south)], axis=-1)
    middle = 1 + _grid_triangles(SPHERE_RINGS, SPHERE_SEGMENTS, closed=True)[:, ::-1]  # outward
    return points, np.concatenate([north, middle, south_cap]).astype(np.int64), centre, np.eye(3)


def _cylinder(obstacle: Obstacle, lo: Array, hi: Array) -> tuple[Array, Triangles, Array, Array]:
    a = np.asarray(obstacle.axis, dtype=np.float64)  # type: ignore[attr-defined]
    p, radius = np.asarray(obstacle.point, dtype=np.float64), float(obstacle.radius)  # type: ignore[attr-defined]
    frame = _frame(a)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    along = (corners - p) @ a
    first, last = float(along.min()), float(along.max())
    margin = 0.125 * max(last - first, radius)
    s = np.linspace(first - margin, last + margin, CYLINDER_RINGS + 1)
    phi = 2.0 * np.pi * np.arange(CYLINDER_SEGMENTS) / CYLINDER_SEGMENTS
    circle = radius * (np.cos(phi)[:, None] * frame[0] + np.sin(phi)[:, None] * frame[1])
    points = (p + s[:, None, None] * a + circle[None, :, :]).reshape(-1, 3)
    centre = p + 0.5 * (s[0] + s[-1]) * a
    return points, _grid_triangles(CYLINDER_RINGS + 1, CYLINDER_SEGMENTS, closed=True), centre, frame


def _surface(obstacle: Obstacle, lo: Array, hi: Array) -> tuple[Array, Triangles, Array, Array]:
    from fenics_coulomb.model.triangulation import read_triangles

    X, V = read_triangles(obstacle.file, obstacle.source)  # type: ignore[attr-defined]
    points = np.empty((int(V.max()) + 1, 3))
    points[V.ravel()] = X.reshape(-1, 3)
    return points, np.asarray(V, dtype=np.int64), points.mean(axis=0), np.eye(3)


#: Obstacle kind → its tessellation at rest: (obstacle at rest, body box lo, hi) → (points, triangles, the
#: reference point and frame (rows) of its ``octant`` field).
TESSELLATIONS: dict[str, Callable[[Obstacle, Array, Array], tuple[Array, Triangles, Array, Array]]] = {
    "plane": _plane, "sphere": _sphere, "cylinder": _cylinder, "surface": _surface}


def tessellate(obstacle: Obstacle, lo: npt.ArrayLike, hi: npt.ArrayLike) -> tuple[Array, Triangles, Array]:
    """The surface of ``obstacle`` at rest for a body in the box [lo, hi] (placed as ``obstacle``).

    Returns:
        The points at rest (N, 3), the triangles (T, 3) and the ``octant`` field (N,) int32.

    Raises:
        ValueError: for an obstacle kind without a tessellation in :data:`TESSELLATIONS`.
    """
    if obstacle.kind not in TESSELLATIONS:
        raise ValueError(f"{obstacle.label}: no surface for the obstacle kind {obstacle.kind!r}")
    R, c = obstacle.placement()
    low, high = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    back = (corners - c) @ R  # the body's box seen from the obstacle at rest
    points, triangles, centre, frame = TESSELLATIONS[obstacle.kind](obstacle._at_rest(), back.min(axis=0),
                                                                    back.max(axis=0))
    signs = ((points - centre) @ frame.T) > 0.0
    return points, triangles, (np.sum(signs, axis=1) % 2).astype(np.int32)


class ObstacleSeries:
    """The obstacles' surfaces over time as ONE XDMF file (a temporal collection of triangle grids sharing one
    triangulation and the point fields, one point set per time) with its data in ONE HDF5 file, on rank 0.

    Example::

        series = ObstacleSeries(Path("out/obstacles.xdmf"), model.obstacles, body_box(x, comm), comm)
        series.write(0.0, model.obstacles)

    Args:
        path: The ``.xdmf`` file (the ``.h5`` beside it).
        obstacles: The obstacles as first placed (their kinds and geometry at rest fix the triangulation).
        box: The body's bounding box (lo, hi) in the reference configuration (:func:`body_box`).
        comm: The result set's communicator (rank 0 writes).
    """

    def __init__(self, path: Path | str, obstacles: Sequence[Obstacle], box: tuple[npt.ArrayLike, npt.ArrayLike],
                 comm: MPI.Comm, length: str = "L") -> None:
        self.path = Path(path).with_suffix(".xdmf")
        #: The mesh's length unit (the rest positions' unit in the grids' ``units`` item).
        self.length = length
        self.h5_path = self.path.with_suffix(".h5")
        self.comm = comm
        self.names = obstacle_names(obstacles)
        self._rest: list[Obstacle] = [o._at_rest() for o in obstacles]
        self._times: list[float] = []
        self._sizes: list[int] = []
        self.points: npt.NDArray[np.float64] = np.zeros((0, 3))
        self.triangles: npt.NDArray[np.int64] = np.zeros((0, 3), dtype=np.int64)
        if comm.rank != 0:
            return
        lo, hi = (np.asarray(b, dtype=np.float64) for b in box)
        parts = [tessellate(o, lo, hi) for o in obstacles]
        offsets = np.cumsum([0, *(p.shape[0] for p, _, _ in parts)])
        self.points = np.concatenate([p for p, _, _ in parts])
        self.triangles = np.concatenate([t + offsets[i] for i, (_, t, _) in enumerate(parts)])
        self._sizes = [p.shape[0] for p, _, _ in parts]
        self._fields: dict[str, npt.NDArray[Any]] = {
            "obstacle": np.repeat(np.arange(1, len(parts) + 1, dtype=np.int32), self._sizes),
            "rest_position": self.points,
            "octant": np.concatenate([o for _, _, o in parts]),
        }
        self._create(self.h5_path)

    @property
    def times(self) -> list[float]:
        """The times written so far."""
        return list(self._times)

    def placed_points(self, obstacles: Sequence[Obstacle]) -> Array:
        """The surface points of ``obstacles`` (the series' obstacles, placed anew) on rank 0, (N, 3)."""
        if len(obstacles) != len(self._rest) or any(o._at_rest() != r for o, r in zip(obstacles, self._rest)):
            raise ValueError("ObstacleSeries.write: the obstacles differ from the series' (only their displacements "
                             "and rotations may change)")
        if self.comm.rank != 0:
            return np.zeros((0, 3))
        placed = np.empty_like(self.points)
        start = 0
        for obstacle, size in zip(obstacles, self._sizes, strict=True):
            R, c = obstacle.placement()
            placed[start:start + size] = self.points[start:start + size] @ R.T + c
            start += size
        return placed

    def write(self, t: float, obstacles: Sequence[Obstacle]) -> None:
        """Append the grid of time ``t`` with ``obstacles`` (the series' obstacles, placed for that time) (every
        rank calls it; rank 0 writes, no communication)."""
        points = self.placed_points(obstacles)
        self._times.append(float(t))
        if self.comm.rank == 0:
            self._append(self.h5_path, points)

    @rank0_file
    def _create(self, path: Path) -> None:
        import h5py

        path.parent.mkdir(parents=True, exist_ok=True)
        with h5py.File(path, "w") as h5:
            h5["/Mesh/triangles"] = self.triangles
            for name, values in self._fields.items():
                h5[f"/Function/{name}"] = values

    @rank0_file
    def _append(self, path: Path, points: Array) -> None:
        import h5py

        with h5py.File(path, "a") as h5:
            h5[f"/Mesh/geometry/{len(self._times) - 1}"] = points
        _write_xml(self.path, self._xml())

    def _item(self, parent: ET.Element, dataset: str, shape: tuple[int, ...], dtype: npt.DTypeLike) -> None:
        number, precision = _number_type(np.dtype(dtype))
        item = ET.SubElement(parent, "DataItem", Dimensions=" ".join(map(str, shape)), NumberType=number,
                             Precision=precision, Format="HDF")
        item.text = f"{self.h5_path.name}:{dataset}"

    def _xml(self) -> str:
        root = ET.Element("Xdmf", Version="3.0")
        series = ET.SubElement(ET.SubElement(root, "Domain"), "Grid", Name="obstacles", GridType="Collection",
                               CollectionType="Temporal")
        n, m = self.points.shape[0], self.triangles.shape[0]
        for k, t in enumerate(self._times):
            grid = ET.SubElement(series, "Grid", Name=f"obstacles t={t:g}", GridType="Uniform")
            ET.SubElement(grid, "Time", Value=repr(float(t)))
            ET.SubElement(grid, "Information", Name="obstacles",
                          Value=", ".join(f"{i + 1} {name}" for i, name in enumerate(self.names)))
            ET.SubElement(grid, "Information", Name="units", Value=f"rest_position {self.length}, obstacle 1, octant 1")
            topology = ET.SubElement(grid, "Topology", TopologyType="Triangle", NumberOfElements=str(m),
                                     NodesPerElement="3")
            self._item(topology, "/Mesh/triangles", (m, 3), np.int64)
            self._item(ET.SubElement(grid, "Geometry", GeometryType="XYZ"), f"/Mesh/geometry/{k}", (n, 3),
                       np.float64)
            for name, values in self._fields.items():
                kind = "Vector" if values.ndim == 2 else "Scalar"
                attribute = ET.SubElement(grid, "Attribute", Name=name, AttributeType=kind, Center="Node")
                self._item(attribute, f"/Function/{name}", values.shape, values.dtype)
        ET.indent(root)
        return ('<?xml version="1.0" encoding="utf-8"?>\n<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n'
                + ET.tostring(root, encoding="unicode") + "\n")

