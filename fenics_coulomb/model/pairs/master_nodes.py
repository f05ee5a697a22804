r"""The master nodes of a contact pair against its slave body after a solve: what a one-pass pair does not see.

A pair keeps its slave nodes out of the master body (node-to-surface: each node against the master surface; dual
mortar: the weighted gaps of the fully covered nodes); nothing keeps the master's nodes out of the slave body. Where
the master surface ends over the slave surface — a master smaller than the slave, the master's border under a slave
that hangs over it — a master node sinks into the slave body unseen: the slide-off blocks pressed with the roles
swapped (the larger lower block's top the slave) end with the upper block's border 4.1e-3 inside the lower block
and the normal force −16 % (node-to-surface), −76 % (mortar), exit 0.

:func:`master_excess` measures it in the configuration X + u: every owned master node over the gathered slave surface
S — its closest point on S in S's normal cone, within the pair's search distance and within the thickness of the
slave's cell layer under that point (the rules of the reference-configuration overlap check,
:func:`fenics_coulomb.model.pairs.pairing.pair_surfaces`) — and its depth −g inside the slave body, less what the
facetting of two curved surfaces gives a master node without any error of the solve:

* the slave nodes rest on the master facets (g = 0 where they press); two of them on the facets either side of a
  master vertex V, at distances a and b from V, span a chord that passes below V by a·b·sin α / |AB| ≈ a b α/(a + b)
  ≤ h_s α/4 (α the turn of the master's normals at V, h_s ≥ a + b the slave facet's size);
* taken with a factor 2 for slave facets that are no straight chords (bilinear quadrilaterals, a triangle around
  V): the allowance h_s α/2, with α = twice the largest angle between a master facet's normal at V and their mean
  (an upper bound of the largest angle between two of them). A flat master has α = 0: its nodes get no allowance.

Derived on the slide-off blocks (flat: no allowance) and measured against curved pairs with the slave the finer
or the larger surface (tests/model/test_master_nodes.py): the Hertz pair and the shrink fit stay below the bound.
"""

from __future__ import annotations

from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.pairs.pair import ContactPair
from fenics_coulomb.model.pairs.projection import (Surface, dot, facet_data, facet_ranks, facet_sizes,
                                                   gather_surface, layer_thickness, local_facets, norm, outward_normals,
                                                   project)
from fenics_coulomb.model.pairs.uncovered import bodies_of_facets, in_body

__all__ = ["FACETTING_ALLOWANCE", "SLAVE_FACTOR", "FACING", "turn_angles", "master_excess"]

Array = npt.NDArray[np.float64]

#: The allowance of a master node is this × (the slave facet's size) × (the master's turn α at the node): twice the
#: chord's h_s α/4 (the module docstring).
FACETTING_ALLOWANCE = 0.5
#: ... and at least this × the deepest pointwise penetration of the pair's own contact nodes into the master body
#: (dual mortar meets the gaps weakly: both sides' nodes then lie inside the other by the method's own error; as the
#: reference-configuration overlap check of :func:`fenics_coulomb.model.pairs.pairing.pair_surfaces`).
SLAVE_FACTOR = 2.0
#: The facets of a master vertex that count for its turn face the slave: their normal within 45° of the slave's
#: inward normal there (a master surface naming a body's bottom and sides turns by 90° at the edge, which is no
#: facetting: with the sides counted the allowance hid a border 4.1e-3 inside the slave, 0.41 of the scale).
FACING = float(np.cos(np.pi / 4))


def turn_angles(surface: Surface, towards: Array | None = None) -> tuple[npt.NDArray[np.int64], Array]:
    """(the surface's vertices as global blocks, ascending; α at each): twice the largest angle between the outward
    normal of a facet at its centre and the mean of those normals over the facets sharing the vertex (0 where one
    facet, or coplanar facets, meet). ``towards`` (per vertex, shape (vertices, 3)): only the facets whose normal lies
    within 45° of it count — the facets that face the slave surface, not the master body's sides behind an edge (a
    zero row: none)."""
    k, nv = surface.blocks.shape
    if k == 0:
        return np.zeros(0, np.int64), np.zeros(0)
    normals = outward_normals(surface.X, np.full((k, nv), 1.0 / nv), surface.sign)
    vertices, inverse = np.unique(surface.blocks.ravel(), return_inverse=True)
    per = np.repeat(normals, nv, axis=0)
    counted = np.ones(per.shape[0], dtype=bool) if towards is None else dot(per, towards[inverse]) >= FACING
    mean = np.zeros((vertices.size, 3))
    np.add.at(mean, inverse[counted], per[counted])
    mean /= np.maximum(norm(mean), np.finfo(float).tiny)[:, None]
    angle = np.zeros(vertices.size)
    np.maximum.at(angle, inverse[counted], np.arccos(np.clip(dot(per[counted], mean[inverse[counted]]), -1.0, 1.0)))
    return vertices, 2.0 * angle


def _slave_depth(y: Array, master: Surface, search: float) -> float:
    """The deepest of the points ``y`` (a pair's contact nodes) inside the master body, pointwise (their
    node-to-surface gap on the master surface, where they lie in its normal cone within the search distance)."""
    if y.shape[0] == 0:
        return 0.0
    res = project(y, master, facet_sizes(master), facet_ranks(master))
    g = dot(y - res["closest"], res["normal"])
    inside = np.asarray(res["paired"], dtype=bool) & (np.abs(g) <= search)
    return float(np.max(-g[inside], initial=0.0))


def master_excess(V: dolfinx.fem.FunctionSpace, pairs: list[ContactPair], x: Array,
                  slave_nodes: list[npt.NDArray[np.int32]], body_of_block: npt.NDArray[np.int64]
                  ) -> tuple[float, Array | None, float]:
    """The deepest excess depth of a master node inside its pair's slave body (the module docstring's depth less
    its allowance) over every pair and rank in the configuration ``x`` (the positions of V's local DOF blocks, owned
    and ghost), where that master node is (None when no master node is inside beyond its allowance), and the largest
    excess over the size of the slave facet above the node (a depth the displacement scale hides when the body also
    slides far: 3.2e-3 inside after a slide of 0.45 is 0.007 of the scale, 1.6 % of the facet; collective).
    ``slave_nodes[i]``: the owned contact nodes (local blocks) of pair i, whose own depth inside the master body
    bounds the allowance from below; ``body_of_block``: the body of every local DOF block (owned and ghost)."""
    comm = V.mesh.comm
    tdim = V.mesh.topology.dim
    V.mesh.topology.create_connectivity(tdim - 1, tdim)
    imap = V.dofmap.index_map
    lo, hi = imap.local_range
    nv = 4 if V.mesh.topology.cell_name() == "hexahedron" else 3
    best: tuple[float, Array | None] = (0.0, None)
    per_facet = 0.0
    for pair, nodes in zip(pairs, slave_nodes, strict=True):
        facets = local_facets(pair.facet_tags, pair.slave_tags)
        slave, thickness = gather_surface(comm, facet_data(V, facets, x), nv), layer_thickness(comm, V, facets, x)
        master = gather_surface(comm, facet_data(V, local_facets(pair.facet_tags, pair.master_tags), x), nv)
        if slave.X.shape[0] == 0 or master.X.shape[0] == 0:
            continue
        points = master.X.reshape(-1, 3)
        search = pair.search_distance if pair.search_distance is not None else \
            0.1 * float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
        floor = comm.allreduce(_slave_depth(x[nodes], master, search), op=MPI.MAX)
        vertices, first = np.unique(master.blocks.ravel(), return_index=True)
        mine = (vertices >= lo) & (vertices < hi)
        y = points[first[mine]]
        sizes = facet_sizes(slave)
        res = project(y, slave, sizes, facet_ranks(slave))
        towards = np.zeros((vertices.size, 3))
        towards[mine] = -res["normal"]  # into the slave body: the master facets that face it
        alpha = turn_angles(master, towards)[1][mine]
        depth = -dot(y - res["closest"], res["normal"])
        over = np.asarray(res["paired"], dtype=bool) & (np.abs(depth) <= search)
        deep = over & (depth >= thickness[res["facet"]])  # below the slave's cell layer: located in its body
        over &= ~deep
        # deeper than the slave's cell layer, a master node's side of the slave surface does not tell inside the
        # body from beyond a thin one (a 0.004 top layer hid a border 9.1e-3 inside): the deformed cells do
        located = np.zeros(int(deep.sum()), dtype=bool)
        for body in bodies_of_facets(V, body_of_block, local_facets(pair.facet_tags, pair.slave_tags)):
            located |= in_body(V, x, body_of_block, body, y[deep])
        over[deep] = located
        allowed = np.maximum(FACETTING_ALLOWANCE * sizes[res["facet"]] * alpha, SLAVE_FACTOR * floor)
        excess = np.where(over, depth - allowed, 0.0)
        if excess.size and excess.max() > best[0]:
            k = int(np.argmax(excess))
            best = (float(excess[k]), y[k])
        if excess.size:
            per_facet = max(per_facet, float(np.max(excess / sizes[res["facet"]])))
    everyone: list[tuple[float, Any]] = comm.allgather(best)
    deepest, at = max(everyone, key=lambda item: item[0])
    per_facet = comm.allreduce(per_facet, op=MPI.MAX)
    return (float(deepest), np.asarray(at), per_facet) if at is not None else (0.0, None, 0.0)
