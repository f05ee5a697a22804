"""The dual mortar method of a contact pair (the default): Φ_jl = M_jl / D_j, the nodal gap g̃_j / D_j, the slave
nodal normals (the segmentation and integration, their derivation and the exact definitions:
:mod:`fenics_coulomb.model.pairs.segmentation`). Registered as ``"mortar"``
(:mod:`fenics_coulomb.model.pairs.registry`).

Which slave nodes are segmented: those within 2 × the search distance + 4 h of M (their node-to-surface
distance, h the largest diameter of their slave facets); the others cannot have |g_j| <= the search distance.
Contact nodes: fully covered, with |g_j| <= the search distance.
"""

from __future__ import annotations

import numpy as np

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.frames import frames_from_normals
from fenics_coulomb.model.pairs.projection import dot, node_size, norm, project
from fenics_coulomb.model.pairs.segmentation import mortar_nodes
from fenics_coulomb.model.pairs.stencils import PairInput, Stencils

__all__ = ["stencils"]


def stencils(pair: PairInput) -> Stencils:
    """The dual mortar stencils of the candidate nodes of ``pair`` (collective: the slave surface is gathered, and a
    facet refused on one rank is an InputError on every rank)."""
    x, nodes, owned_slave, master, search = pair.x, pair.nodes, pair.owned_slave, pair.master, pair.search
    slave = pair.gather_slave()
    # the node-to-surface projection of every vertex of the slave facets at this rank's owned slave nodes, once:
    # the nodes to segment, the facets' anchors, the free nodes' penetration check
    g_owned = pair.global_slave
    touch = np.isin(slave.blocks, g_owned).any(axis=1)
    verts, first = np.unique(slave.blocks[touch].ravel(), return_index=True)
    projected = project(slave.X[touch].reshape(-1, 3)[first], master, pair.size, pair.rank)
    position = np.searchsorted(verts, g_owned)  # owned slave node i ↔ vertex position[i]
    at_nodes = position[np.searchsorted(owned_slave, nodes)]
    gn = g_owned[np.searchsorted(owned_slave, nodes)]
    near = norm(x[nodes] - projected["closest"][at_nodes]) <= 2 * search + 4 * node_size(slave, gn)
    try:  # a rank's facets may be bad where another's are not: every rank raises, before the next collective
        mortar = mortar_nodes((slave.X, slave.blocks, slave.sign), (master.X, master.blocks, master.sign),
                              gn[near], (verts, projected["closest"]), pair.resolution, pair.reach)
        failure = ""
    except InputError as err:
        failure = f"{pair.label}: {err}"
    check_all(pair.comm, not failure, failure)
    g = np.full(nodes.size, np.inf)
    g[near] = mortar.gap
    normal = np.tile([0.0, 0.0, 1.0], (nodes.size, 1))
    normal[near] = mortar.normal
    frames = frames_from_normals(normal) if nodes.size else np.zeros((0, 3, 3))
    contact = np.zeros(nodes.size, dtype=bool)
    contact[near] = mortar.fully_covered & (np.abs(mortar.gap) <= search)
    closest = x[nodes] - np.where(np.isfinite(g), g, 0.0)[:, None] * normal
    # the overlap check's pointwise gap: the node-to-surface distance where the node lies over M
    pointwise = np.where(projected["paired"][at_nodes],
                         dot(x[nodes] - projected["closest"][at_nodes], projected["normal"][at_nodes]), np.inf)
    width = mortar.stencil.shape[1]
    master_blocks = np.full((nodes.size, width), -1, np.int64)
    weights = np.zeros((nodes.size, width))
    master_blocks[near], weights[near] = mortar.stencil_blocks, mortar.stencil
    D = np.zeros(nodes.size)
    D[near] = mortar.D
    others = np.setdiff1d(owned_slave, nodes[contact]).astype(np.int32)
    partner_size = pair.size[projected["facet"][at_nodes]] if nodes.size else np.zeros(0)
    at = position[np.searchsorted(owned_slave, others)]
    return Stencils(gap=g, frames=frames, contact=contact, closest=closest, master_blocks=master_blocks,
                    weights=weights, area=D, pointwise=pointwise, others=others,
                    projected={key: value[at] for key, value in projected.items()}, partner_size=partner_size)
