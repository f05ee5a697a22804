"""The node-to-surface method of a contact pair: each slave node against the closest point of the master surface.

The stencil of slave node j is the master facet's shape functions φ_j at the closest point x_m (Φ_jl = φ_j(x_l)),
the gap g = (x_s − x_m)·n, the frame from n; a node is a contact node when it lies in the normal cone of x_m and
|g| <= the search distance (the rules: :mod:`fenics_coulomb.model.pairs.projection`). Registered as
``"node-to-surface"`` (:mod:`fenics_coulomb.model.pairs.registry`).
"""

from __future__ import annotations

import numpy as np

from fenics_coulomb.model.frames import frames_from_normals
from fenics_coulomb.model.pairs.projection import dot, project
from fenics_coulomb.model.pairs.stencils import PairInput, Stencils

__all__ = ["stencils"]


def stencils(pair: PairInput) -> Stencils:
    """The node-to-surface stencils of the candidate nodes of ``pair`` (no collective call)."""
    x, nodes, master = pair.x, pair.nodes, pair.master
    nv = master.X.shape[1]
    res = project(x[nodes], master, pair.size, pair.rank)
    frames = frames_from_normals(res["normal"]) if nodes.size else np.zeros((0, 3, 3))
    g = dot(x[nodes] - res["closest"], res["normal"])
    contact = np.asarray(res["paired"], dtype=bool) & (np.abs(g) <= pair.search)
    others = np.setdiff1d(pair.owned_slave, nodes[contact]).astype(np.int32)
    return Stencils(gap=g, frames=frames, contact=contact, closest=res["closest"],
                    master_blocks=master.blocks[res["facet"]] if nodes.size else np.zeros((0, nv), np.int64),
                    weights=res["weights"], area=np.full(nodes.size, np.nan),
                    pointwise=np.where(res["paired"], g, np.inf), others=others,
                    projected=project(x[others], master, pair.size, pair.rank))
