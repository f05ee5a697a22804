"""Finite sliding of contact pairs: how the pairs' slave nodes change from the model's pairing to the pairing of
X + u (the rules and their derivation: :mod:`fenics_coulomb.model.sliding`; the obstacles' nodes are there too).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.coupling import StencilChange
from fenics_coulomb.model.pairs.two_body import coupling_matrix
from fenics_coulomb.model.sliding import _tangential

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel
    from fenics_coulomb.model.pairs.pair import Pairing

__all__ = ["supports", "stencil_change"]

Array = npt.NDArray[np.float64]


def supports(master_blocks: npt.NDArray[np.int64], weights: Array, threshold: Array | float = 0.0
             ) -> npt.NDArray[np.int64]:
    """Each node's stencil support as a sorted row (−1 padding): the master nodes with |Φ_jl| > ``threshold``
    (per node, or one value)."""
    mb = np.where(np.abs(weights) > np.reshape(threshold, (-1, 1)), master_blocks, -1)
    return -np.sort(-mb, axis=1) if mb.size else mb


def _same_supports(a: npt.NDArray[np.int64], b: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
    width = max(a.shape[1], b.shape[1], 1)
    pa = np.full((a.shape[0], width), -1, np.int64)
    pb = np.full((b.shape[0], width), -1, np.int64)
    pa[:, :a.shape[1]], pb[:, :b.shape[1]] = a, b
    return np.all(pa == pb, axis=1)


def stencil_change(model: ContactModel, old: Pairing, pairing: Pairing, held: npt.NDArray[np.bool_],
                   paired: npt.NDArray[np.bool_], u: Array, z: Array, previous: Array | None, tolerance: float,
                   pressed: npt.NDArray[np.bool_]) -> StencilChange:
    """The change of the paired nodes from ``old`` (the model's pairing, its nodes ``paired`` among the contact
    map's) to ``pairing`` (of X + u, with the held components ``held`` of its nodes), ``u`` physical and ``z`` in
    the model's unknown, ``pressed`` per contact node (collective).

    A node counts when the solution presses it or it penetrates in the new geometry (gap < −``tolerance``): a
    pressed node that lost its partner or changed its stencil support moved; a new candidate that penetrates is
    gained; a node that kept its partner has Δ_j = ((g_j^new − g_j^lin)² + |P^new s^new − P^old s^old|²)^{1/2}
    with s the step's relative displacement increment through the node's stencil.
    """
    cmap = model.contact
    size = cmap.size
    U = model.ghosted(u).reshape(-1, 3)
    r0 = model.V.dofmap.index_map.local_range[0]
    moved = np.zeros(size, dtype=bool)
    delta = np.zeros(size)
    sel = np.flatnonzero(paired)  # the paired nodes of the contact map, in the order of old.blocks
    threshold = np.asarray(tolerance / model.node_size()[old.blocks], dtype=np.float64)
    old_support = supports(old.master_blocks, old.weights, threshold)
    new_support = supports(pairing.master_blocks, pairing.weights,
                           np.asarray(tolerance / model.node_size()[pairing.blocks], dtype=np.float64))
    _, i_old, i_new = np.intersect1d(old.blocks, pairing.blocks, assume_unique=True, return_indices=True)
    lost = np.ones(old.blocks.size, dtype=bool)
    lost[i_old] = False
    gained = np.ones(pairing.blocks.size, dtype=bool)
    gained[i_new] = False
    penetrating = pairing.gap < -tolerance  # in the new geometry, at X + u
    relevant = pressed[sel][i_old] | penetrating[i_new]
    moved[sel[i_old]] = ~_same_supports(old_support[i_old], new_support[i_new]) & relevant
    moved[sel[lost]] = pressed[sel][lost]  # a pressed node lost its partner
    gained &= penetrating  # a new candidate that penetrates
    gained_at = model.V.tabulate_dof_coordinates()[pairing.blocks[gained]] + U[pairing.blocks[gained]]
    step = u if previous is None else u - np.asarray(previous, dtype=np.float64)
    n_old = cmap.frames[sel][:, :, 2]
    dofs = cmap.local_dofs[sel]
    linear = cmap.gap[sel] + np.einsum("ij,ij->i", n_old, np.asarray(z).reshape(-1)[dofs])
    s_old = model.coupling.relative(step)[dofs]
    size_local = model.V.dofmap.index_map.size_local
    M = coupling_matrix(model.V, pairing.blocks, pairing.master_blocks, pairing.weights,
                        f"{model.prefix}geometry_", held)  # collective
    x, y = M.createVecs()
    x.array[:] = step[:3 * size_local]
    M.mult(x, y)
    new_dofs = 3 * pairing.blocks[:, None] + np.arange(3)
    s_new = (2.0 * step - y.getArray(readonly=True))[new_dofs]
    for obj in (x, y, M):
        obj.destroy()
    dt = _tangential(pairing.frames[i_new][:, :, 2], s_new[i_new]) - _tangential(n_old[i_old], s_old[i_old])
    change = np.sqrt((pairing.gap[i_new] - linear[i_old]) ** 2 + np.einsum("ij,ij->i", dt, dt))
    delta[sel[i_old]] = np.where(relevant, change, 0.0)
    return StencilChange(moved, delta, gained_at, pairing.blocks[gained].astype(np.int32),
                         old_nodes=[old.blocks + r0], new_nodes=[pairing.blocks + r0], old_rows=[old_support],
                         new_rows=[new_support], pairing=pairing)
