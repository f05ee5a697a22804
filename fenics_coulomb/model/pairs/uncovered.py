r"""The slave nodes of a contact pair that no part of the master surface lies beneath, against the master body.

A pair constrains a slave node when the master surface lies beneath it: its closest point in a master facet's
normal cone (a contact node; beyond the search distance, or a mortar node not fully covered, a free node whose
penetration the checks measure). A slave node beyond the master surface's border — the master tagged on part of the
partner's face, a slave larger than the master surface — is kept out of the master body by nothing: pressed, it sinks
into it unseen (the pressed blocks with the master surface tagged where x < 1: the slave nodes over the rest end
0.0098 inside the lower block, converged, exit 0).

:func:`uncovered_depth` finds them after a solve: every slave node of a pair that is neither a contact node, nor a
free node, nor given to an obstacle (nor held by a support), located in a cell of the pair's master body in X + u, and
its depth there: its distance to the nearest exterior facet of the body's cells (all of them: the surface the node
crossed may be untagged) that is no symmetry plane (a face held along its normal, beyond which the body goes on).
"""

from __future__ import annotations

from typing import Any

from mpi4py import MPI

import dolfinx.fem
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.mesh_checks import displaced_geometry
from fenics_coulomb.model.pairs.pair import ContactPair, Pairing
from fenics_coulomb.model.pairs.projection import (Surface, closest_points, facet_data, gather_surface, local_facets,
                                                   outward_normals)

__all__ = ["body_of_facets", "in_body", "uncovered_depth"]

Array = npt.NDArray[np.float64]

#: A facet is a symmetry plane when the held components at each vertex carry this much of |n|² but 1.
MIRROR_TOL = 1e-8
#: Points × facets per batch of the brute-force depth inside the body.
_BATCH = 200_000


def body_of_facets(V: dolfinx.fem.FunctionSpace, body_of_block: npt.NDArray[np.int64],
                   facets: npt.NDArray[np.int32]) -> int:
    """The body (index of :func:`fenics_coulomb.model.pairs.two_body.connected_bodies`) whose boundary holds
    ``facets`` (this rank's; −1 when no rank has any; collective)."""
    tdim = V.mesh.topology.dim
    f2c = V.mesh.topology.connectivity(tdim - 1, tdim)
    cells = f2c.array[f2c.offsets[facets]] if facets.size else np.zeros(0, np.int32)
    return int(V.mesh.comm.allreduce(int(body_of_block[V.dofmap.list[cells[0], 0]]) if cells.size else -1,
                                     op=MPI.MAX))


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


def _depth(V: dolfinx.fem.FunctionSpace, x: Array, body_of_block: npt.NDArray[np.int64], body: int,
           held: npt.NDArray[np.bool_], points: Array) -> Array:
    """The depth of each of this rank's ``points`` inside ``body`` in the configuration ``x``: the distance to the
    nearest exterior facet of the body's cells that is no mirror — a facet whose every vertex a support holds along
    the facet's normal (``held``: the held components of V's local blocks) is a symmetry plane, beyond which the body
    goes on: a bore node on a quarter model's symmetry plane lies on the shaft's face there, 2.1e-4 inside the shaft
    (the shrink fit's other state). Collective: every rank's facets of the body gathered; brute force in batches."""
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
    surface = gather_surface(msh.comm, local, nv)
    k = surface.X.shape[0]
    out = np.full(points.shape[0], np.inf)
    step = max(1, _BATCH // max(k, 1))
    for start in range(0, points.shape[0] if k else 0, step):  # batches of points, each against every facet
        p = points[start:start + step]
        _, _, dist = closest_points(np.repeat(p, k, axis=0), np.tile(surface.X, (p.shape[0], 1, 1)))
        out[start:start + step] = dist.reshape(p.shape[0], k).min(axis=1)
    return out


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
    covered = np.concatenate([pairing.blocks, *(np.asarray(d.get("blocks", np.zeros(0, np.int32)))
                                                for d in (pairing.free, pairing.to_obstacles)), excluded])
    best: tuple[float, Any] = (0.0, None)
    for pair in pairs:
        slave = gather_surface(comm, facet_data(V, local_facets(pair.facet_tags, pair.slave_tags), x), nv)
        nodes = np.unique(slave.blocks)
        nodes = nodes[(nodes >= lo) & (nodes < hi)] - lo
        nodes = nodes[~np.isin(nodes, covered)]
        body = body_of_facets(V, body_of_block, local_facets(pair.facet_tags, pair.master_tags))
        if body < 0:
            continue
        y = x[nodes]
        inside = in_body(V, x, body_of_block, body, y)
        if not comm.allreduce(int(inside.sum()), op=MPI.SUM):
            continue
        depth = _depth(V, x, body_of_block, body, held, y[inside])
        if depth.size and depth.max() > best[0]:
            best = (float(depth.max()), y[inside][int(np.argmax(depth))])
    everyone: list[tuple[float, Any]] = comm.allgather(best)
    deepest, at = max(everyone, key=lambda item: item[0])
    return (float(deepest), np.asarray(at)) if at is not None else (0.0, None)
