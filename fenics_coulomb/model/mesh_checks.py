r"""Checks of a mesh before anything is assembled on it: finite coordinates, no degenerate or inverted cell.

A zero-volume cell makes the stiffness matrix singular in a way no preconditioner reports (the solve
"converges" to u = 0 with the equilibrium 87.5 % off); a NaN coordinate turns every residual into
NaN. Both are rejected with an :class:`~fenics_coulomb.errors.InputError` naming the cell (its index in the
mesh as read, e.g. the gmsh file's order, and its vertices) or the node.

Cell measure. P1 tetrahedra: the signed volume det(x₁ − x₀, x₂ − x₀, x₃ − x₀)/6 — a cell is degenerate when
|det| <= DEGENERATE·h³ (h its longest edge). Q1 hexahedra (DOLFINx's tensor-product vertex order,
vertex i at (i & 1, (i >> 1) & 1, (i >> 2) & 1) of the reference cube): the Jacobian determinant of the
trilinear map at each of the 8 corners, det(∂x/∂ξ, ∂x/∂η, ∂x/∂ζ) with the edge vectors leaving that corner; the
map is invertible on the cell only if these have one sign (checking the corners is the usual test of mesh
generators), so a cell is degenerate or inverted when min/max of the 8 determinants (taken with the sign of
their sum) is <= DEGENERATE·h³ after normalization.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from mpi4py import MPI

import dolfinx.fem
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import check_all

__all__ = ["DEGENERATE", "BodyLocator", "check_mesh", "displaced_geometry", "first_interior_facet"]

#: A cell whose (smallest corner) Jacobian determinant is at most this fraction of h³ is degenerate.
DEGENERATE = 1e-10

Array = npt.NDArray[np.float64]


def _where(x: Array) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in x) + ")"


#: For each corner c = a + 2b + 4c' of a hexahedron (DOLFINx's vertex numbering x + 2y + 4z): the vertex pairs of
#: its three edges along ξ, η, ζ (the Jacobian's columns at that corner).
_CORNER = np.arange(8)
_A, _B, _C = _CORNER & 1, (_CORNER >> 1) & 1, (_CORNER >> 2) & 1
_HEX_EDGES = ((1 | (_B << 1) | (_C << 2), _B << 1 | (_C << 2)),
              (_A | 2 | (_C << 2), _A | (_C << 2)),
              (_A | (_B << 1) | 4, _A | (_B << 1)))


def corner_determinants(cell_type: str, X: Array) -> Array:
    """The Jacobian determinants of each cell's map at its corners, shape (cells, corners), from the vertex
    coordinates X of shape (cells, vertices, 3) (tetrahedra: one value, the map is affine); the triple product
    a·(b × c) of the corner's three edge vectors, all corners at once (on the coordinates laid out component by
    component, so that every product runs over contiguous memory)."""
    Xt = np.ascontiguousarray(np.asarray(X, dtype=np.float64).transpose(2, 1, 0))  # (3, vertices, cells)
    if cell_type == "tetrahedron":
        a, b, c = (Xt[:, k] - Xt[:, 0] for k in (1, 2, 3))
    else:
        a, b, c = (Xt[:, hi] - Xt[:, lo] for hi, lo in _HEX_EDGES)
    det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
    return det[:, None] if cell_type == "tetrahedron" else det.T


def _diameters(X: Array) -> Array:
    """Each cell's largest vertex distance (its diameter), from the vertex coordinates (cells, vertices, 3): one
    vertex pair at a time (28 for hexahedra), so that no (cells, pairs, 3) temporary is made."""
    Xt = np.ascontiguousarray(np.asarray(X, dtype=np.float64).transpose(2, 1, 0))  # (3, vertices, cells)
    best = np.zeros(X.shape[0])
    for i, j in zip(*np.triu_indices(X.shape[1], 1), strict=True):
        d = Xt[:, i] - Xt[:, j]
        np.maximum(best, np.einsum("kc,kc->c", d, d), out=best)
    return np.sqrt(best)


def check_mesh(msh: dolfinx.mesh.Mesh) -> None:
    """InputError on every rank for a non-finite node coordinate or a degenerate or inverted cell (collective;
    the first by the cells' input index over all ranks is named).

    Raises:
        InputError: naming the node or the cell (input index and vertices).
    """
    comm = msh.comm
    x = msh.geometry.x
    bad = np.flatnonzero(~np.all(np.isfinite(x), axis=1))
    message = ""
    if bad.size:
        message = f"the mesh has a node with non-finite coordinates: {_where(x[bad[0]])}"
    check_all(comm, not message, message)
    cell_type = msh.topology.cell_name()
    if cell_type not in ("tetrahedron", "hexahedron"):
        return
    num = msh.topology.index_map(msh.topology.dim).size_local
    dofmap = msh.geometry.dofmap[:num]
    if dofmap.shape[1] not in (4, 8):  # a higher-order geometry: its cells are not checked here
        return
    X = x[dofmap]
    h = _diameters(X)
    det = corner_determinants(cell_type, X)
    if cell_type == "hexahedron":
        sign = np.where(det.sum(axis=1) < 0.0, -1.0, 1.0)
        worst = np.min(det * sign[:, None], axis=1)
    else:
        worst = np.abs(det[:, 0])
    failing = np.flatnonzero(~(worst > DEGENERATE * h**3))
    original = np.asarray(msh.topology.original_cell_index, dtype=np.int64)[:num]
    found = None
    if failing.size:
        i = failing[np.argmin(original[failing])]
        kind = "zero volume" if cell_type == "tetrahedron" or abs(worst[i]) <= DEGENERATE * h[i] ** 3 else \
            "an inverted corner (its Jacobian changes sign)"
        found = (int(original[i]), f"mesh cell {int(original[i])} ({cell_type}, vertices "
                                   f"{', '.join(_where(v) for v in X[i])}) has {kind}: a degenerate or inverted cell")
    everyone = [f for f in comm.allgather(found) if f is not None]
    if everyone:
        message = min(everyone)[1]
    check_all(comm, not everyone, message)


@contextlib.contextmanager
def displaced_geometry(V: dolfinx.fem.FunctionSpace, u: npt.NDArray[np.float64]) -> Iterator[None]:
    """The mesh of V with its nodes at X + u for the duration (``u``: the displacement of every local DOF of the P1/Q1
    space V, owned and ghost, unrolled), its geometry restored bit for bit afterwards (not collective)."""
    msh = V.mesh
    x = msh.geometry.x
    saved = np.array(x, copy=True)
    cells = V.dofmap.list
    geometry = msh.geometry.dofmap[: cells.shape[0]]
    values = np.asarray(u, dtype=np.float64).reshape(-1, 3)
    try:
        if geometry.shape[1] == cells.shape[1]:  # P1 on a first-order mesh: node k of a cell ↔ its DOF k
            nodes = np.empty(values.shape[0], dtype=np.int64)
            nodes[cells.ravel()] = geometry.ravel()
            x[nodes] = saved[nodes] + values
        else:  # a higher-order geometry: every node moved by the P1 displacement interpolated at it
            moved = dolfinx.fem.Function(dolfinx.fem.functionspace(msh, ("Lagrange", msh.geometry.cmap.degree,
                                                                             (3,))))
            source = dolfinx.fem.Function(V)
            source.x.array[:] = values.ravel()
            moved.interpolate(source)
            node_of = np.empty(moved.x.array.size // 3, dtype=np.int64)
            node_of[moved.function_space.dofmap.list.ravel()] = geometry.ravel()
            x[node_of] = saved[node_of] + moved.x.array.reshape(-1, 3)
        yield
    finally:
        x[:] = saved


class BodyLocator:
    """Answers "which of these points lie inside the body?" for a mesh (its bounding-box tree, built once; the
    queries are local to each rank and combined with one allreduce)."""

    def __init__(self, msh: dolfinx.mesh.Mesh) -> None:
        self.mesh = msh
        tdim = msh.topology.dim
        num = msh.topology.index_map(tdim).size_local
        self.tree = dolfinx.geometry.bb_tree(msh, tdim, np.arange(num, dtype=np.int32))
        x = msh.geometry.x
        comm = msh.comm
        #: The global bounding box of the body (lower, upper corner).
        self.lo = np.array(x.min(axis=0) if x.size else np.full(3, np.inf), dtype=np.float64)
        self.hi = np.array(x.max(axis=0) if x.size else np.full(3, -np.inf), dtype=np.float64)
        comm.Allreduce(MPI.IN_PLACE, self.lo, op=MPI.MIN)
        comm.Allreduce(MPI.IN_PLACE, self.hi, op=MPI.MAX)
        edges = x[msh.geometry.dofmap[:num, 1]] - x[msh.geometry.dofmap[:num, 0]] if num else np.zeros((0, 3))
        shortest = float(np.min(np.linalg.norm(edges, axis=1), initial=np.inf))
        #: The shortest first edge of any cell: a sampling step that no part of the body is thinner than.
        self.spacing = comm.allreduce(shortest, op=MPI.MIN)

    def first_inside(self, points: Array) -> int:
        """The index of the first of ``points`` (the same on every rank) inside the body, or −1 (collective)."""
        points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        inside: npt.NDArray[np.int32] = np.zeros(points.shape[0], dtype=np.int32)
        if points.size:
            candidates = dolfinx.geometry.compute_collisions_points(self.tree, points)
            cells = dolfinx.geometry.compute_colliding_cells(self.mesh, candidates, points)
            inside = (np.diff(cells.offsets) > 0).astype(np.int32)
        if points.size:
            self.mesh.comm.Allreduce(MPI.IN_PLACE, inside, op=MPI.MAX)
        hits = np.flatnonzero(inside)
        return int(hits[0]) if hits.size else -1


def first_interior_facet(msh: dolfinx.mesh.Mesh, facets: npt.NDArray[np.int32],
                         exterior: npt.NDArray[np.int32] | None = None) -> npt.NDArray[np.float64] | None:
    """The midpoint of the first of ``facets`` (local indices) that this rank owns and that does not lie on the mesh's
    boundary (its vertices would be contact nodes inside the body), or None; ``exterior``: the owned exterior facets
    when known (each rank checks its own facets)."""
    tdim = msh.topology.dim
    if exterior is None:
        msh.topology.create_connectivity(tdim - 1, tdim)
        exterior = dolfinx.mesh.exterior_facet_indices(msh.topology)
    facets = np.asarray(facets, dtype=np.int32)
    inner = np.setdiff1d(facets[facets < msh.topology.index_map(tdim - 1).size_local], exterior)
    return dolfinx.mesh.compute_midpoints(msh, tdim - 1, inner[:1])[0] if inner.size else None
