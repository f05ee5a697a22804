"""A deterministic mesh partitioner: the same mesh on the same ranks gives the same partition every run.

DOLFINx's default partitioner in the Debian build (PT-Scotch) does not repeat: the parts and the rank they
go to change from run to run, and with them the DOF numbering, the GAMG aggregates, the block-Jacobi blocks
and the order of every parallel sum, so Newton and Krylov counts and the last bits of the solution change.
This module partitions the cells by recursive coordinate bisection (RCB) of their vertex midpoints instead:

* every bisection cuts the current group of cells across the longest side of its midpoints' bounding box,
  at the cell count proportional to the parts on either side (cells sorted by the midpoint coordinate, ties
  broken by the global input cell index), so the parts differ in size by at most one cell per level;
* the computation uses only the input (cell vertices, vertex coordinates, input order) and integer or
  exactly-repeatable floating-point operations, never timing, threads or random numbers;
* with ghosting (``GhostMode.shared_facet``) every cell also lists the parts of its facet neighbours, as
  DOLFINx's own graph partitioners do.

The bisection runs on rank 0 of the mesh's communicator (the cell midpoints are gathered there: 24 bytes a
cell); everything else is distributed.

Reproducible runs with your own mesh (e.g. for ``ContactProblem``): pass a partitioner from this module to
every DOLFINx call that creates or reads the mesh, on every rank::

    from fenics_coulomb.scenes.partition import create_partitioner

    # your own cells (input vertex indices) and this rank's rows x of the input vertex coordinates
    msh = dolfinx.mesh.create_mesh(comm, cells, x, domain, partitioner=create_partitioner(comm, x))
    # a gmsh model (x: the coordinates gmsh holds on the reading rank, an empty (0, 3) array elsewhere)
    x = dolfinx.io.gmshio.extract_geometry(gmsh.model) if comm.rank == 0 else np.zeros((0, 3))
    msh, ct, ft = dolfinx.io.gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3,
                                                  partitioner=create_partitioner(comm, x))
    # a box
    msh = dolfinx.mesh.create_box(comm, points, n, cell_type, ghost_mode=mode,
                                  partitioner=box_partitioner(points, n, ghost_mode=mode))

A mesh partitioned by DOLFINx's default (or read from XDMF, which uses it) gives results that may change in
the last bits, and in iteration counts, from run to run on more than one rank. The partition depends on the
number of ranks, so runs on different rank counts agree to the solver tolerance, not bitwise.
"""

from __future__ import annotations

import typing

from mpi4py import MPI

import dolfinx
import numpy as np
import numpy.typing as npt
from dolfinx import cpp as _cpp

from fenics_coulomb.errors import InputError, check_all

__all__ = ["box_partitioner", "create_partitioner", "partition_cells", "recursive_bisection"]

#: A DOLFINx cell partitioner: (comm, nparts, cell types, cells per type) -> destination ranks per cell.
CellPartitioner = typing.Callable[[MPI.Comm, int, list, list], _cpp.graph.AdjacencyList_int32]


def recursive_bisection(points: npt.NDArray[np.floating], nparts: int) -> npt.NDArray[np.int32]:
    """Partition ``points`` (one row per cell, in input order) into ``nparts`` parts by recursive
    coordinate bisection; return the part of each point.

    A group of points destined for parts [lo, hi) is cut across the longest side of its bounding box
    (the first such axis on a tie) into ⌊k/2⌋ and ⌈k/2⌉ parts (k = hi − lo), with the point counts in the
    same proportion; points are ordered by the coordinate on that axis, ties by their input index. The
    result depends only on the points and their order.
    """
    points = np.asarray(points, dtype=np.float64)
    n = points.shape[0]
    parts = np.zeros(n, dtype=np.int32)
    stack: list[tuple[npt.NDArray[np.int64], int, int]] = [(np.arange(n, dtype=np.int64), 0, int(nparts))]
    while stack:  # at most nparts - 1 bisections
        idx, lo, hi = stack.pop()
        k = hi - lo
        if k == 1 or idx.size == 0:
            parts[idx] = lo
            continue
        k_left = k // 2
        n_left = (idx.size * k_left) // k
        p = points[idx]
        axis = int(np.argmax(p.max(axis=0) - p.min(axis=0)))
        order = np.lexsort((idx, p[:, axis]))  # primary key: coordinate; ties: input index
        stack.append((idx[order[n_left:]], lo + k_left, hi))
        stack.append((idx[order[:n_left]], lo, lo + k_left))
    return parts


def _offsets(comm: MPI.Comm, n_local: int) -> npt.NDArray[np.int64]:
    """Global offsets of each rank's block when rank blocks are concatenated in rank order."""
    sizes = np.asarray(comm.allgather(int(n_local)), dtype=np.int64)
    return np.concatenate(([0], np.cumsum(sizes)))


def _fetch(comm: MPI.Comm, local: npt.NDArray, queries: npt.NDArray[np.int64]) -> npt.NDArray:
    """Rows ``queries`` (global indices into the rank-ordered concatenation of every rank's ``local``)."""
    local = np.ascontiguousarray(local)
    width = int(np.prod(local.shape[1:], dtype=np.int64))
    offsets = _offsets(comm, local.shape[0])
    rank = comm.rank
    uq, inverse = np.unique(np.asarray(queries, dtype=np.int64), return_inverse=True)
    if comm.size == 1:
        return local[uq][inverse]
    owner = np.searchsorted(offsets[1:], uq, side="right")
    send_counts = np.bincount(owner, minlength=comm.size).astype(np.int64)
    recv_counts = np.empty_like(send_counts)
    comm.Alltoall(send_counts, recv_counts)
    requests = np.empty(int(recv_counts.sum()), dtype=np.int64)
    comm.Alltoallv([uq, send_counts], [requests, recv_counts])
    answers = np.ascontiguousarray(local.reshape(local.shape[0], width)[requests - offsets[rank]])
    values = np.empty((uq.size, width), dtype=local.dtype)
    comm.Alltoallv([answers, recv_counts * width], [values, send_counts * width])
    return values.reshape((uq.size, *local.shape[1:]))[inverse]


class _Bisection:
    """Cell partitioner (RCB of cell midpoints) with DOLFINx's dual graph for the ghost destinations."""

    def __init__(self, vertex_coordinates: typing.Callable[[MPI.Comm, npt.NDArray[np.int64]], npt.NDArray],
                 ghost_mode: dolfinx.mesh.GhostMode) -> None:
        self._coordinates = vertex_coordinates
        self._midpoints = np.zeros((0, 3))
        self._graph_partitioner = _cpp.mesh.create_cell_partitioner(self._partition_graph, ghost_mode)

    def __call__(self, comm: MPI.Comm, nparts: int, cell_types: list, cells: list) -> _cpp.graph.AdjacencyList_int32:
        mids = []
        for cell_type, c in zip(cell_types, cells, strict=True):
            nv = _cpp.mesh.cell_num_vertices(cell_type)
            c = np.asarray(c, dtype=np.int64).reshape(-1, nv)
            xv = self._coordinates(comm, c.ravel())
            x = xv.reshape(c.shape[0], nv, xv.shape[-1])
            mids.append(x.mean(axis=1))
        self._midpoints = np.concatenate(mids) if mids else np.zeros((0, 3))
        return self._graph_partitioner(comm, nparts, cell_types, cells)

    def _partition_graph(self, comm: MPI.Comm, nparts: int, graph: _cpp.graph.AdjacencyList_int64,
                         ghosting: bool) -> _cpp.graph.AdjacencyList_int32:
        n = graph.num_nodes
        assert self._midpoints.shape[0] == n, "dual graph nodes must be the local cells in input order"
        parts = partition_cells(comm, self._midpoints, nparts)
        if not ghosting:
            return _cpp.graph.AdjacencyList_int32(parts)
        return _cpp.graph.AdjacencyList_int32(*_with_ghosts(comm, parts, graph, nparts))


def partition_cells(comm: MPI.Comm, midpoints: npt.NDArray[np.floating], nparts: int) -> npt.NDArray[np.int32]:
    """Parts of this rank's cells (rows of ``midpoints``, rank blocks in global input order) by
    :func:`recursive_bisection` on rank 0 of ``comm``."""
    mid = np.ascontiguousarray(midpoints, dtype=np.float64)
    gdim = mid.shape[1]
    counts = np.asarray(comm.allgather(mid.shape[0]), dtype=np.int64)
    if comm.size == 1:
        return recursive_bisection(mid, nparts)
    all_mid = np.empty((int(counts.sum()), gdim)) if comm.rank == 0 else None
    comm.Gatherv(mid, [all_mid, counts * gdim] if comm.rank == 0 else None, root=0)
    all_parts = recursive_bisection(all_mid, nparts) if all_mid is not None else None  # rank 0's
    parts = np.empty(mid.shape[0], dtype=np.int32)
    comm.Scatterv([all_parts, counts] if comm.rank == 0 else None, parts, root=0)
    return parts


def _with_ghosts(comm: MPI.Comm, parts: npt.NDArray[np.int32], graph: _cpp.graph.AdjacencyList_int64,
                 nparts: int) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
    """Destinations per cell: its part first, then the other parts of its dual-graph neighbours (sorted)."""
    n = parts.size
    degree = np.diff(graph.offsets)
    neighbour_parts = _fetch(comm, parts, graph.array).astype(np.int64)
    node = np.repeat(np.arange(n, dtype=np.int64), degree)
    other = neighbour_parts != parts[node]
    keys = np.unique(node[other] * nparts + neighbour_parts[other])
    gnode, gpart = keys // nparts, keys % nparts
    counts = 1 + np.bincount(gnode, minlength=n)
    offsets = np.concatenate(([0], np.cumsum(counts))).astype(np.int32)
    data = np.empty(offsets[-1], dtype=np.int32)
    data[offsets[:-1]] = parts
    if keys.size:
        first = np.searchsorted(gnode, gnode)  # first entry of each node's group (gnode is sorted)
        data[offsets[gnode] + 1 + (np.arange(keys.size) - first)] = gpart
    return data, offsets


def create_partitioner(comm: MPI.Comm, x: npt.NDArray[np.floating],
                       ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none) -> CellPartitioner:
    """A deterministic cell partitioner for ``dolfinx.mesh.create_mesh`` (or ``gmshio.model_to_mesh``).

    Args:
        comm: The mesh's communicator (collective: call on every rank).
        x: This rank's rows of the input vertex coordinates, exactly the ``x`` given to ``create_mesh``
            (rank blocks concatenated in rank order give the global input vertex numbering the cells use).
        ghost_mode: The ghost mode of the mesh (``none`` for ``create_mesh``'s default).

    Returns:
        A partitioner: the same cells and coordinates on the same number of ranks give the same
        partition in every run.
    """
    if not isinstance(comm, MPI.Comm):
        raise InputError(f"create_partitioner: comm = {type(comm).__name__}: give the mesh's MPI communicator")
    _check_ghost_mode("create_partitioner", ghost_mode)
    try:
        x = np.asarray(x, dtype=np.float64)
        ok = x.ndim == 2 and x.shape[1] in (2, 3) and bool(np.all(np.isfinite(x)))
    except (TypeError, ValueError):
        ok = False
    check_all(comm, ok, "create_partitioner: x: give this rank's vertex coordinates, finite, one row per vertex "
                        "(k × 3, or k × 2 in 2D), as given to create_mesh")
    local = np.ascontiguousarray(x)

    def coordinates(c: MPI.Comm, vertices: npt.NDArray[np.int64]) -> npt.NDArray:
        return _fetch(c, local, vertices)

    return _Bisection(coordinates, ghost_mode)


def box_partitioner(points: typing.Sequence[npt.ArrayLike], n: typing.Sequence[int],
                    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.shared_facet) -> CellPartitioner:
    """A deterministic cell partitioner for ``dolfinx.mesh.create_box(comm, points, n, ...)``
    (hexahedra or tetrahedra).

    Args:
        points: The box's two opposite corners, as given to create_box.
        n: Cells per direction (n0, n1, n2), as given to create_box.
        ghost_mode: The ghost mode given to create_box.

    create_box numbers the vertex (i, j, k) as i + (n0+1)(j + (n1+1)k) at p0 + (p1 − p0)·(i/n0, j/n1, k/n2);
    the partitioner computes the vertex coordinates from their indices the same way.
    """
    _check_ghost_mode("box_partitioner", ghost_mode)
    if isinstance(n, str | bytes) or not isinstance(n, typing.Sequence | np.ndarray) or len(n) != 3 or not all(
            isinstance(v, int | np.integer) and not isinstance(v, bool) and v >= 1 for v in n):
        raise InputError(f"box_partitioner: n = {n!r}: give 3 positive integers, the cells per direction given to "
                         "create_box")
    try:
        corners = np.asarray(points, dtype=np.float64)
        ok = corners.shape == (2, 3) and bool(np.all(np.isfinite(corners))) and bool(np.all(corners[1] != corners[0]))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(f"box_partitioner: points = {points!r}: give the box's two opposite corners (3 finite "
                         "coordinates each, apart in every direction), as given to create_box")
    n_ = np.asarray([int(v) for v in n], dtype=np.int64)
    p0 = corners[0]
    h = (corners[1] - p0) / n_

    def coordinates(c: MPI.Comm, vertices: npt.NDArray[np.int64]) -> npt.NDArray:
        v = np.asarray(vertices, dtype=np.int64)
        ijk = np.stack([v % (n_[0] + 1), (v // (n_[0] + 1)) % (n_[1] + 1), v // ((n_[0] + 1) * (n_[1] + 1))],
                       axis=1)
        return p0 + ijk * h

    return _Bisection(coordinates, ghost_mode)


def _check_ghost_mode(where: str, ghost_mode: object) -> None:
    """InputError unless ``ghost_mode`` is a dolfinx.mesh.GhostMode (it must be the one given to the mesh)."""
    if not isinstance(ghost_mode, dolfinx.mesh.GhostMode):
        raise InputError(f"{where}: ghost_mode = {ghost_mode!r}: give a dolfinx.mesh.GhostMode, the one given to the "
                         "mesh")
