"""The node-to-surface method of a contact pair: each slave node against the closest point of the master surface.

The stencil of slave node j is the master facet's shape functions φ_j at the closest point x_m (Φ_jl = φ_j(x_l)),
the gap g = (x_s − x_m)·n, the frame from n; a node is a contact node when it lies in the normal cone of x_m and
|g| <= the search distance (the rules: :mod:`fenics_coulomb.model.pairs.projection`). Registered as
``"node-to-surface"`` (:mod:`fenics_coulomb.model.pairs.registry`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.frames import frames_from_normals
from fenics_coulomb.model.pairs.projection import CONE_TOL, TIE_TOL, dot, norm, project
from fenics_coulomb.model.pairs.stencils import PairInput, Stencils

__all__ = ["stencils"]

Array = npt.NDArray[np.float64]


def _held_cone(x: Array, res: dict[str, Array], held: npt.NDArray[np.bool_], size: Array) -> npt.NDArray[np.bool_]:
    """The normal-cone test of :func:`~fenics_coulomb.model.pairs.projection.project` again for the nodes it left
    unpaired that a support holds in a component in which the node shares its closest point's coordinate (the node
    on the plane where the master surface ends, which it cannot leave — a symmetry plane, beyond which the master
    goes on as its mirror image): x − x_m along the facet's normal n once those components are taken out of both.
    A node held on the shrink fit's quarter planes, its closest point on the shaft's border edge in the plane, lay
    off n by n's tilt out of the plane (2.6e-7 against the cone's 1e-8 of a facet, the shaft's facets tilted by
    4.7e-4). A held node beyond the master's border (x_i ≠ x_m,i) stays unpaired: the master does not go on there."""
    paired = np.asarray(res["paired"], dtype=bool).copy()
    retry = np.flatnonzero(~paired & held.any(axis=1))
    if retry.size:
        h = size[res["facet"][retry]]
        d = x[retry] - res["closest"][retry]
        mirror = held[retry] & (np.abs(d) <= TIE_TOL * h[:, None])  # on the plane x_i = x_m,i it cannot leave
        free = (~mirror).astype(np.float64)
        d, n = free * d, free * res["normal"][retry]
        n /= np.maximum(norm(n), np.finfo(float).tiny)[:, None]
        paired[retry] = mirror.any(axis=1) & (norm(d - dot(d, n)[:, None] * n) <= CONE_TOL * h)
    return paired


def stencils(pair: PairInput) -> Stencils:
    """The node-to-surface stencils of the candidate nodes of ``pair`` (no collective call)."""
    x, nodes, master = pair.x, pair.nodes, pair.master
    nv = master.X.shape[1]
    tied = 0.0 if pair.ties is None else pair.tie_width(pair.global_slave[np.searchsorted(pair.owned_slave, nodes)])
    res = project(x[nodes], master, pair.size, pair.rank, tied, pair.reach)
    paired = _held_cone(x[nodes], res, pair.held[nodes], pair.size) if pair.held is not None else \
        np.asarray(res["paired"], dtype=bool)
    frames = frames_from_normals(res["normal"]) if nodes.size else np.zeros((0, 3, 3))
    g = dot(x[nodes] - res["closest"], res["normal"])
    contact = paired & (np.abs(g) <= pair.search)
    others = np.setdiff1d(pair.owned_slave, nodes[contact]).astype(np.int32)
    return Stencils(gap=g, frames=frames, contact=contact, closest=res["closest"],
                    master_blocks=master.blocks[res["facet"]] if nodes.size else np.zeros((0, nv), np.int64),
                    weights=res["weights"], area=np.full(nodes.size, np.nan),
                    pointwise=np.where(paired, g, np.inf), others=others,
                    projected=project(x[others], master, pair.size, pair.rank),
                    partner_size=pair.size[res["facet"]] if nodes.size else np.zeros(0))
