"""Contact forces and areas computed from a solution: the nodal contact areas and the forces on each body of
a contact pair (post-processing in the model's terms; the output fields are :mod:`fenics_coulomb.io.fields`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.model.contact_model import ContactModel

if TYPE_CHECKING:  # a result of the method above this package: only its displacement and contact_force are read
    from fenics_coulomb.scd.records import SolveResult

__all__ = ["block_to_scalar_dofs", "contact_areas", "pair_forces"]


def block_to_scalar_dofs(V: dolfinx.fem.FunctionSpace, S: dolfinx.fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Map DOF blocks of the vector space V to DOFs of the scalar space S on the same P1 element."""
    blocks = V.dofmap.list.ravel()
    scalars = S.dofmap.list.ravel()
    num = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    mapping = np.full(num, -1, dtype=np.int32)
    mapping[blocks] = scalars
    return mapping


def contact_areas(model: ContactModel) -> npt.NDArray[np.float64]:
    """Each owned contact node's share of the contact surface: ∫ φᵢ ds over the contact boundary (lumped facet
    areas), and D_j = ∫ ψ_j N_j ds on a dual mortar pair's slave nodes (= ∫ N_j ds over its slave facets: the
    pressure there is f_j·n_j / D_j; collective)."""
    if not model.markers:
        return np.zeros(model.contact.size)
    areas = _lumped_areas(model)
    pairing = getattr(model, "pairing", None)
    if pairing is not None and pairing.size:
        paired = np.flatnonzero(model.paired)  # the pairing's nodes, in the same ascending block order
        mortar = np.isfinite(pairing.area)
        areas[paired[mortar]] = pairing.area[mortar]
    return areas


def _lumped_areas(model: ContactModel) -> npt.NDArray[np.float64]:
    """∫ φᵢ ds over the contact boundary at each owned contact node (collective)."""
    msh = model.V.mesh
    S = dolfinx.fem.functionspace(msh, ("Lagrange", 1))
    v = ufl.TestFunction(S)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=model.facet_tags)
    form = dolfinx.fem.form(sum((v * ds(tag) for tag in model.markers[1:]), v * ds(model.markers[0])))
    b = dolfinx.fem.petsc.assemble_vector(form)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    values = b.getArray(readonly=True).copy()
    b.destroy()
    return values[block_to_scalar_dofs(model.V, S)[model.contact.blocks]]


def pair_forces(model: ContactModel, result: SolveResult,
                pairs: Sequence[Any] | None = None) -> list[dict[str, Any]]:
    """Per contact pair, the total force on each body from that body's own residual (collective; the same list
    on all ranks; empty for one body).

    The residual K u − l̃⁰ of the physical displacement u, assembled WITHOUT boundary conditions
    (:func:`fenics_coulomb.model.checks.unconstrained_residual`), is the force the other body and the supports exert
    on each node. Summed over the pair's slave contact nodes it is the force on the slave body; summed over
    the master nodes of the facets the pair's contact nodes use (the stencils φ_sj) it is the force on the
    master body. Equilibrium (Σ_j φ_sj = 1) makes them equal and opposite; on a supported (Dirichlet) master
    node the residual also holds the support's reaction, so the contact force f_j = −Σ_s φ_sj f_s it receives is
    taken there instead (counted in ``prescribed_nodes``); a master node shared by several pairs' stencils
    counts for each of them.

    Args:
        model: The model of a solve with contact pairs.
        result: Its result (``displacement`` = the physical u).
        pairs: The :class:`~fenics_coulomb.model.pairing.ContactPair` s in the order given to the problem, for
            their names and tags (optional).

    Returns:
        One dict per pair: ``pair`` (index), ``name``, ``slave``/``master`` tags and ``method`` (when ``pairs``
        is given),
        ``contact_nodes``, ``master_nodes``, ``prescribed_nodes``, ``force_on_slave_body`` and
        ``force_on_master_body`` (3-vectors from the residuals), ``contact_force`` (Σ of the solver's force
        on the slave contact nodes) and ``balance`` = ‖slave + master‖ / ‖slave‖.
    """
    from fenics_coulomb.model.checks import unconstrained_residual

    pairing = model.pairing
    if pairing is None:
        return []
    comm = model.comm
    imap = model.V.dofmap.index_map
    n, r0 = imap.size_local, int(imap.local_range[0])
    pairs = list(pairs if pairs is not None else getattr(model, "pairs", None) or [])
    count = max(len(pairs), comm.allreduce(int(pairing.pair_index.max(initial=-1)) + 1, op=MPI.MAX))
    full = unconstrained_residual(model, result.displacement)
    prescribed = np.zeros(n, dtype=bool)
    prescribed[model.dirichlet_rows // 3] = True
    force = np.asarray(result.contact_force, dtype=np.float64).reshape(-1, 3)
    # what each master node receives from the contact: the residual on a free node; on a prescribed one the
    # residual also holds the support's reaction, so there the contact force f_j = −Σ_s φ_sj f_s itself
    received = full.copy()
    if getattr(result, "master_force", None) is not None:
        master_force = np.asarray(result.master_force, dtype=np.float64).reshape(-1, 3)[:n]
        received[prescribed] = master_force[prescribed]
    out: list[dict[str, Any]] = []
    for k in range(count):
        mine = pairing.pair_index == k
        slave = pairing.blocks[mine]
        stencil = pairing.master_blocks[mine]
        used = np.unique(stencil[stencil >= 0])
        used = np.unique(np.concatenate(comm.allgather(used))).astype(np.int64)
        master = (used[(used >= r0) & (used < r0 + n)] - r0).astype(np.int32)
        local = np.concatenate([full[slave].sum(axis=0), received[master].sum(axis=0), force[mine].sum(axis=0),
                                [slave.size, master.size, prescribed[slave].sum() + prescribed[master].sum()]])
        total = np.asarray(comm.allreduce(local, op=MPI.SUM))
        on_slave, on_master = total[0:3], total[3:6]
        scale = float(np.linalg.norm(on_slave))
        entry: dict[str, Any] = {"pair": k}
        if k < len(pairs):
            q = pairs[k]
            entry["name"] = getattr(q, "name", None)
            entry["slave"] = [int(t) for t in np.atleast_1d(q.slave)]
            entry["master"] = [int(t) for t in np.atleast_1d(q.master)]
            entry["method"] = getattr(q, "method", None)
        entry.update({
            "contact_nodes": int(total[9]),
            "master_nodes": int(total[10]),
            "prescribed_nodes": int(total[11]),
            "force_on_slave_body": [float(c) for c in on_slave],
            "force_on_master_body": [float(c) for c in on_master],
            "contact_force": [float(c) for c in total[6:9]],
            "balance": float(np.linalg.norm(on_slave + on_master) / scale) if scale > 0 else 0.0,
        })
        out.append(entry)
    return out

