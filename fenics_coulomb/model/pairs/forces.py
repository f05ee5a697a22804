"""The forces of a solve on each body of every contact pair (post-processing in the model's terms)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel
    from fenics_coulomb.scd.records import SolveResult

__all__ = ["balance_sum", "pair_forces"]


def pair_forces(model: ContactModel, result: SolveResult,
                pairs: Sequence[Any] | None = None) -> list[dict[str, Any]]:
    """Per contact pair, the total force it exerts on its slave body and on its master body (collective; the
    same list on all ranks; empty for one body).

    The contact nodes of a problem are the pairs' slave nodes and, with rigid obstacles as well, the obstacles'
    contact nodes; a pair's slave nodes j are those of the pairing with its index, and f_j is the solver's
    contact force on them. The force on the slave body is Σ_j f_j. The force on the master body comes from THIS
    pair's stencil only: the master node l receives f_l = −Σ_{j in pair} Φ_jl f_j, so
    Σ_l f_l = −Σ_j (Σ_l Φ_jl) f_j. A master node shared by several pairs' stencils counts each pair's share
    once, and the master forces of the pairs on one body add up to what its supports carry (with the obstacles
    and the load). ``balance`` = ‖slave + master‖ / ‖slave‖ measures the stencil's row sums Σ_l Φ_jl = 1 (round-off
    when every pair's stencil passes its whole force on).

    ``slave_equilibrium`` checks the pair's force against the slave body's own residual r = K u − l̃⁰ assembled
    WITHOUT boundary conditions (:func:`fenics_coulomb.model.checks.unconstrained_residual`): at a slave node,
    r − f_master (f_master: what the node receives as a master node of other pairs, usually 0) is the contact
    force the solve balanced there (in a component a boundary condition holds, the residual holds the support's
    reaction too, and f_j is taken); ‖Σ_j (r_j − f_master,j) − Σ_j f_j‖ / ‖Σ_j f_j‖ is the equilibrium of the
    slave nodes, at the level of the solve's tolerance.

    Args:
        model: The model of a solve with contact pairs.
        result: Its result (``displacement`` = the physical u, ``contact_force`` per contact node,
            ``master_force`` = the master nodes' reaction to all pairs, on the owned DOFs).
        pairs: The :class:`~fenics_coulomb.model.pairs.pair.ContactPair` s in the order given to the problem, for
            their names and tags (default: the model's).

    Returns:
        One dict per pair: ``pair`` (index), ``name``, ``slave``/``master`` tags and ``method``,
        ``contact_nodes``, ``master_nodes`` (the master nodes of the pair's stencils), ``prescribed_nodes`` (of
        those, the ones with a constrained component), ``force_on_slave_body`` and ``force_on_master_body``
        (3-vectors), ``contact_force`` (= ``force_on_slave_body``), ``balance`` and ``slave_equilibrium``.
    """
    from fenics_coulomb.model.checks import constrained_mask, unconstrained_residual

    pairing = model.coupling.pairing
    if pairing is None:
        return []
    comm = model.comm
    imap = model.V.dofmap.index_map
    n, r0 = imap.size_local, int(imap.local_range[0])
    pairs = list(pairs if pairs is not None else getattr(model, "pairs", None) or [])
    count = max(len(pairs), comm.allreduce(int(pairing.pair_index.max(initial=-1)) + 1, op=MPI.MAX))
    # the pairing's nodes among the contact nodes (obstacle nodes are the others), both in ascending block order
    paired = np.flatnonzero(model.coupling.paired_mask(model.contact.size))
    assert np.array_equal(model.contact.blocks[paired], pairing.blocks), "pairing and contact map disagree"
    force = np.asarray(result.contact_force, dtype=np.float64).reshape(-1, 3)[paired]
    held = constrained_mask(model)
    received = np.zeros((n, 3))
    if getattr(result, "master_force", None) is not None:
        received = np.asarray(result.master_force, dtype=np.float64).reshape(-1, 3)[:n]
    residual = unconstrained_residual(model, result.displacement) - received
    from_residual = np.where(held[pairing.blocks], force, residual[pairing.blocks])
    # −Σ_l Φ_jl f_j per slave node j (the weights are 0 on the stencil's padding)
    on_master_nodes = -pairing.weights.sum(axis=1)[:, None] * force
    out: list[dict[str, Any]] = []
    for k in range(count):
        mine = pairing.pair_index == k
        stencil = pairing.master_blocks[mine]
        used = np.unique(stencil[stencil >= 0])
        used = np.unique(np.concatenate(comm.allgather(used))).astype(np.int64)
        master = (used[(used >= r0) & (used < r0 + n)] - r0).astype(np.int32)
        local = np.concatenate([force[mine].sum(axis=0), on_master_nodes[mine].sum(axis=0),
                                from_residual[mine].sum(axis=0),
                                [np.count_nonzero(mine), master.size, np.count_nonzero(held[master].any(axis=1))]])
        total = np.asarray(comm.allreduce(local, op=MPI.SUM))
        on_slave, on_master = total[0:3], total[3:6]
        scale = float(np.linalg.norm(on_slave))
        entry: dict[str, Any] = {"pair": k}
        if k < len(pairs):
            q = pairs[k]
            entry["name"] = getattr(q, "name", None) or f"pair {k + 1}"  # as the report and path.csv name it
            entry["slave"] = [int(t) for t in np.atleast_1d(q.slave)]
            entry["master"] = [int(t) for t in np.atleast_1d(q.master)]
            entry["method"] = getattr(q, "method", None)
        entry.update({
            "contact_nodes": int(total[9]),
            "master_nodes": int(total[10]),
            "prescribed_nodes": int(total[11]),
            "force_on_slave_body": [float(c) for c in on_slave],
            "force_on_master_body": [float(c) for c in on_master],
            "contact_force": [float(c) for c in on_slave],
            "balance": float(np.linalg.norm(on_slave + on_master) / scale) if scale > 0 else 0.0,
            "slave_equilibrium": float(np.linalg.norm(total[6:9] - on_slave) / scale) if scale > 0 else 0.0,
        })
        out.append(entry)
    return out


Array = npt.NDArray[np.float64]


def balance_sum(model: ContactModel, residual: Array, contact_force: Array, master_force: Array,
                clamped_blocks: npt.NDArray[np.int32]) -> Array:
    """This rank's share of the global balance of a model with pairs: the supports' reactions (``residual``, K u − l̃⁰
    per owned block, on ``clamped_blocks``) and the contact forces of the solver's multipliers on both sides — on the
    contact nodes (``contact_force``: slave and obstacle nodes) and on the master nodes (``master_force``, per owned
    DOF: −Σ_s φ_sj f_s) — each where no support's reaction already holds it. A pair's own forces cancel
    (Σ_j φ_sj = 1), so the balance compares the free nodes' residual with the multipliers (the residual summed over
    every node, as before 2026-11-27, balanced the load for any u)."""
    n = model.V.dofmap.index_map.size_local
    master = np.array(master_force, dtype=np.float64).reshape(-1, 3)[:n]
    master[clamped_blocks[clamped_blocks < n]] = 0.0
    unheld = ~np.isin(model.contact.blocks, clamped_blocks)
    return np.asarray(residual[clamped_blocks].sum(axis=0) + contact_force[unheld].sum(axis=0) + master.sum(axis=0))
