r"""The slave nodes of a contact pair that no part of the master surface lies beneath, against the master body.

A pair constrains a slave node when the master surface lies beneath it: its closest point in a master facet's
normal cone (a contact node; beyond the search distance, or a mortar node not fully covered, a free node whose
penetration the checks measure). A slave node beyond the master surface's border — the master tagged on part of the
partner's face, a slave larger than the master surface — is kept out of the master body by nothing: pressed, it sinks
into it unseen (the pressed blocks with the master surface tagged where x < 1: the slave nodes over the rest end
0.0098 inside the lower block, converged, exit 0).

:func:`uncovered_depth` finds them after a solve: every slave node of a pair that is neither a contact node of a pair
with the same master body, nor a free node, nor given to an obstacle, nor supported, located in a cell of a body of
the pair's master tag in X + u (DOLFINx's collision test: an absolute tolerance, a hexahedron's convex hull), and its
depth there: minus its :func:`signed_distance` to the exterior facets of the body's cells (all of them: the surface
the node crossed may be untagged) but the symmetry planes (:func:`_boundary`); a node outside by the signed distance
has none.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.fem
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.mesh_checks import displaced_geometry
from fenics_coulomb.model.pairs.pair import ContactPair, Pairing
from fenics_coulomb.model.pairs.projection import (Surface, candidate_facets, closest_points, facet_data,
                                                   gather_surface, local_facets, outward_normals)

__all__ = ["bodies_of_facets", "deepest_point", "in_body", "signed_distance", "uncovered_depth"]

Array = npt.NDArray[np.float64]

#: A facet is a symmetry plane when the held components at each vertex carry this much of |n|² but 1.
MIRROR_TOL = 1e-8
#: Facets within this × (their radius + the point's coordinates) of the nearest one are tied at a point.
TIE = 1e-10
#: Depths within this fraction of the deepest are tied (the node named is then the same on any partition).
DEPTH_TIE = 1e-6


def bodies_of_facets(V: dolfinx.fem.FunctionSpace, body_of_block: npt.NDArray[np.int64],
                     facets: npt.NDArray[np.int32]) -> list[int]:
    """The bodies (indices of :func:`fenics_coulomb.model.pairs.two_body.connected_bodies`) whose boundary holds
    any of ``facets`` (this rank's), the same ascending list on every rank (collective)."""
    tdim = V.mesh.topology.dim
    f2c = V.mesh.topology.connectivity(tdim - 1, tdim)
    cells = f2c.array[f2c.offsets[facets]] if facets.size else np.zeros(0, np.int32)
    mine = np.unique(body_of_block[V.dofmap.list[cells, 0]]) if cells.size else np.zeros(0, np.int64)
    return sorted({int(b) for part in V.mesh.comm.allgather(mine) for b in part})


def in_body(V: dolfinx.fem.FunctionSpace, x: Array, body_of_block: npt.NDArray[np.int64], body: int,
            points: Array) -> npt.NDArray[np.bool_]:
    """Which of this rank's ``points`` lie in a cell of ``body`` in the configuration ``x`` (the positions of V's
    local DOF blocks; collective: the points of every rank are located in every rank's cells; nothing is built when
    no rank has any)."""
    comm = V.mesh.comm
    counts = comm.allgather(points.shape[0])
    if not sum(counts):
        return np.zeros(0, dtype=bool)
    everyone = np.concatenate(comm.allgather(np.ascontiguousarray(points.reshape(-1, 3))))
    msh = V.mesh
    tdim = msh.topology.dim
    num = msh.topology.index_map(tdim).size_local
    cells = np.flatnonzero(body_of_block[V.dofmap.list[:num, 0]] == body).astype(np.int32)
    inside = np.zeros(everyone.shape[0], dtype=np.int32)
    with displaced_geometry(V, (x - V.tabulate_dof_coordinates()).ravel()):
        tree = dolfinx.geometry.bb_tree(msh, tdim, cells)
        candidates = dolfinx.geometry.compute_collisions_points(tree, everyone)
        inside[:] = np.diff(dolfinx.geometry.compute_colliding_cells(msh, candidates, everyone).offsets) > 0
    comm.Allreduce(MPI.IN_PLACE, inside, op=MPI.MAX)
    start = sum(counts[:comm.rank])
    return inside[start:start + points.shape[0]].astype(bool)


def _boundary(V: dolfinx.fem.FunctionSpace, x: Array, body_of_block: npt.NDArray[np.int64], body: int,
              held: npt.NDArray[np.bool_]) -> Surface:
    """The exterior facets of ``body``'s cells in the configuration ``x`` but its symmetry planes — a facet whose
    every vertex a support holds along the facet's normal (``held``: the held components of V's local blocks), beyond
    which the body goes on — gathered on every rank (collective)."""
    msh = V.mesh
    tdim = msh.topology.dim
    exterior = dolfinx.mesh.exterior_facet_indices(msh.topology)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    cells = f2c.array[f2c.offsets[exterior]] if exterior.size else np.zeros(0, np.int32)
    facets = exterior[body_of_block[V.dofmap.list[cells, 0]] == body] if cells.size else exterior
    nv = 4 if msh.topology.cell_name() == "hexahedron" else 3
    local = facet_data(V, facets.astype(np.int32), x)
    if facets.size:
        normal = outward_normals(local.X, np.full((facets.size, nv), 1.0 / nv), local.sign)
        blocks = V.dofmap.index_map.global_to_local(local.blocks.ravel()).reshape(local.blocks.shape)
        along = np.einsum("fvi,fi->fv", held[blocks].astype(np.float64), normal**2)  # |n|² in the held components
        kept = ~np.all(along >= 1.0 - MIRROR_TOL, axis=1)
        local = Surface(local.X[kept], local.blocks[kept], local.sign[kept])
    return gather_surface(msh.comm, local, nv)


def _corner_angles(X: Array, w: Array) -> Array:
    """The interior angle of each facet X (k, nv, 3) at the vertex its closest point's weights w (k, nv) sit on (1
    where the point is no vertex: inside the facet or on an edge, where the facets' weights are equal)."""
    k, nv = w.shape
    vertex = np.argmax(w, axis=1)
    at = w[np.arange(k), vertex] >= 1.0 - 1e-12
    # the two neighbours of each vertex: triangles the other two; quadrilaterals (0 1 / 2 3) along the edges
    neighbours = np.array([[1, 2], [0, 2], [0, 1]]) if nv == 3 else np.array([[1, 2], [0, 3], [0, 3], [1, 2]])
    rows = np.arange(k)
    a = X[rows, neighbours[vertex, 0]] - X[rows, vertex]
    b = X[rows, neighbours[vertex, 1]] - X[rows, vertex]
    cosine = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1),
                                                      np.finfo(float).tiny)
    return np.where(at, np.arccos(np.clip(cosine, -1.0, 1.0)), 1.0)


def signed_distance(points: Array, surface: Surface) -> Array:
    """The distance of each point to the ``surface`` (facets oriented outward of a body), negative inside the body:
    the sign of (x − x_q)·n with x_q the closest point and n the pseudo-normal there — the sum of the outward normals
    at x_q of the facets whose closest point is x_q, each weighted by its angle at x_q where x_q is a vertex
    (Bærentzen and Aanæs' angle-weighted normal, which tells inside from outside at any vertex of a closed surface).
    The candidate facets as in :func:`~fenics_coulomb.model.pairs.projection.project`: a bound from the 8 nearest
    facet centres, then, per class of facet radius (powers of 2, so that a graded surface's small facets are not
    searched with its largest radius), the facets whose centre lies within the bound + their radius (+inf without
    facets)."""
    m, nf = points.shape[0], surface.X.shape[0]
    if m == 0 or nf == 0:
        return np.full(m, np.inf)
    radius = np.linalg.norm(surface.X - surface.X.mean(axis=1)[:, None], axis=2).max(axis=1)
    scale = np.abs(points).max(axis=1)
    node, facet = candidate_facets(points, surface, 8, (TIE * (radius.max() + scale), 1e-12 * (1.0 + scale)))
    q, w, dist = closest_points(points[node], surface.X[facet])
    nearest = np.full(m, np.inf)
    np.minimum.at(nearest, node, dist)
    first = np.zeros(m, np.intp)
    order = np.lexsort((dist, node))
    first[node[order][::-1]] = order[::-1]  # each point's nearest candidate
    tol = TIE * (radius[facet] + np.abs(points[node]).max(axis=1))
    tied = (dist <= nearest[node] + tol) & (np.linalg.norm(q - q[first][node], axis=1) <= tol)
    normal = outward_normals(surface.X[facet], w, surface.sign[facet])
    weight = _corner_angles(surface.X[facet], w)
    pseudo = np.zeros((m, 3))
    np.add.at(pseudo, node[tied], weight[tied, None] * normal[tied])
    side = np.einsum("ij,ij->i", points - q[first], pseudo)
    return np.where(side < 0.0, -nearest, nearest)


def uncovered_depth(V: dolfinx.fem.FunctionSpace, pairs: list[ContactPair], pairing: Pairing, x: Array,
                    body_of_block: npt.NDArray[np.int64], excluded: npt.NDArray[np.int32],
                    held: npt.NDArray[np.bool_]) -> tuple[float, Array | None]:
    """The deepest slave node without a partner on the master surface (the module docstring) inside its pair's
    master body in the configuration ``x`` (the positions of V's local DOF blocks, owned and ghost), over every pair
    and rank, and where that node is (None when none lies inside; collective). ``excluded``: the local blocks that
    are no contact nodes (held by a support); ``held``: the held components of every local block (owned and
    ghost)."""
    comm = V.mesh.comm
    tdim = V.mesh.topology.dim
    V.mesh.topology.create_connectivity(tdim - 1, tdim)
    lo, hi = V.dofmap.index_map.local_range
    nv = 4 if V.mesh.topology.cell_name() == "hexahedron" else 3
    others = np.concatenate([*(np.asarray(d.get("blocks", np.zeros(0, np.int32)))
                               for d in (pairing.free, pairing.to_obstacles)), excluded])
    masters = [bodies_of_facets(V, body_of_block, local_facets(pair.facet_tags, pair.master_tags)) for pair in pairs]
    depths: list[Array] = [np.zeros(0)]
    points: list[Array] = [np.zeros((0, 3))]
    for pair, bodies in zip(pairs, masters, strict=True):
        slave = gather_surface(comm, facet_data(V, local_facets(pair.facet_tags, pair.slave_tags), x), nv)
        nodes = np.unique(slave.blocks)
        nodes = nodes[(nodes >= lo) & (nodes < hi)] - lo
        # a contact node is kept out of the bodies of its own pair's master, not out of another pair's
        kept_out = [j for j, other in enumerate(masters) if set(other) & set(bodies)]
        paired = pairing.blocks[np.isin(pairing.pair_index, kept_out)]
        nodes = nodes[~np.isin(nodes, paired) & ~np.isin(nodes, others)]
        y = x[nodes]
        for body in bodies:
            located = in_body(V, x, body_of_block, body, y)  # DOLFINx's test: a tolerance of its own, hulls
            if not comm.allreduce(int(located.sum()), op=MPI.SUM):
                continue
            depth = np.zeros(y.shape[0])
            depth[located] = -signed_distance(y[located], _boundary(V, x, body_of_block, body, held))
            depths.append(depth[depth > 0.0])
            points.append(y[depth > 0.0])
    extent = comm.allreduce(float(np.abs(x).max(initial=0.0)), op=MPI.MAX)
    return deepest_point(comm, np.concatenate(depths), np.concatenate(points), extent)


def deepest_point(comm: MPI.Comm, depth: Array, y: Array, extent: float) -> tuple[float, Array | None]:
    """The largest of every rank's ``depth`` (> 0) and where: of the points ``y`` within DEPTH_TIE of it, the
    lexicographically smallest with its coordinates rounded to 1e-6 of ``extent`` — the same node on any partition,
    whose round-off tells mirror nodes' depths apart by 1e-14 and their positions by ~1e-12 (collective; (0, None)
    when no depth is positive)."""
    deepest = comm.allreduce(float(np.max(depth, initial=0.0)), op=MPI.MAX)
    if deepest <= 0.0:
        return 0.0, None
    near = y[depth >= deepest * (1.0 - DEPTH_TIE)]
    key = np.round(near / (extent or 1.0), 6)
    first = int(np.lexsort(key.T[::-1])[0]) if near.size else -1
    mine = (tuple(float(c) for c in key[first]), near[first]) if near.size else None
    candidates = [c for c in comm.allgather(mine) if c is not None]
    return deepest, np.asarray(min(candidates, key=lambda c: c[0])[1])
