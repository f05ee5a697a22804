r"""The rigid approach: a body held by contact alone brought onto its obstacles along its free rigid motions.

A body whose supports leave rigid motions free (a block on a floor held sideways by rollers, pressed by a
traction) is held along them by contact alone. Started with its contact nodes open — any positive gap — the
Newton matrix of the first SCD step is the stiffness with those motions in its null space, and GMRES returns a
direction of arbitrary size and sign along them: measured on such a block (lev 2) at gaps 1e-3, 1e-5, 1e-8, 1e-10
the solve ran off (exit 3), at 1e-4 and 1e-6 it converged, by chance. No start of the paper's places the body
on its obstacles: ũ = −d (the paper's u⁽⁰⁾ = 0) moves the contact nodes alone, whose elastic force then opens them
again.

The approach is the rigid motion m = Σₖ cₖ rₖ in the span of the free modes rₖ (:mod:`fenics_coulomb.model.nullspace`)
that the loads would do the most work along without any contact node passing its obstacle, to first order — the
linear program

    maximize  f·c,   fₖ = Σ l̃ · rₖ  (over the DOFs the supports do not hold)
    subject to  nᵢ·m(xᵢ) ≥ −gᵢ  at every contact node i (gᵢ its gap at the placement, nᵢ its obstacle's normal),

solved on every rank alike (the constraints gathered; at most six unknowns). Its optimum touches the obstacles
where the body comes to rest on them (a flat bottom: every node; an off-centre load with a free tilt: the edge
beneath it), so the first SCD step starts from touching nodes (round-off: ``scd/newton.TOUCHING``) on the pressed
branch of the derivative. Unbounded — the loads lift the body off, or push it along a free motion no obstacle
blocks — there is no approach (None): the solve then fails naming the free motion. The approach is a start only:
the solution does not depend on it (the same problem is solved from another first iterate).
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.nullspace import FreeMotions, rigid_modes_at

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel

__all__ = ["rigid_approach", "free_work", "loads_the_free_motions", "free_motion_balance"]

Array = npt.NDArray[np.float64]


#: Per model: its free rigid motions at the owned DOF blocks (weak keys: an entry goes with its model).
_MODES: weakref.WeakKeyDictionary[ContactModel, Array] = weakref.WeakKeyDictionary()


def _free_modes(model: ContactModel, motions: FreeMotions) -> Array:
    """The free rigid motions of the model's one body at its owned DOF blocks, shape (blocks, 3, k) (computed once per
    model: the start, the lost-support check and the free motions' balance of every solve read them)."""
    if model not in _MODES:
        _MODES[model] = _modes_of(model, motions)
    return _MODES[model]


def _modes_of(model: ContactModel, motions: FreeMotions) -> Array:
    V = model.V
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    basis = motions.eigenvectors[0][:, motions.free[0]]  # (6, k): the free motions' mode coefficients
    return np.einsum("nia,ak->nik", rigid_modes_at((x - motions.centroid[0]) / motions.extent[0]), basis)


def free_work(model: ContactModel, motions: FreeMotions, modes: Array | None = None) -> tuple[Array, float]:
    """(fₖ = Σ l̃·rₖ over the DOFs the supports do not hold: the loads' work along each free motion, the largest
    nodal load) on every rank alike (collective). A body whose loads do no work along its free motions needs nothing
    to hold them: at rest, or loaded only along what its supports hold."""
    modes = _free_modes(model, motions) if modes is None else modes
    n = modes.shape[0]
    load = model.load.getArray(readonly=True).copy()
    load[model.dirichlet_rows[model.dirichlet_rows < 3 * n]] = 0.0
    work = np.asarray(model.comm.allreduce(np.einsum("ni,nik->k", load.reshape(-1, 3), modes)))
    return work, model.comm.allreduce(float(np.abs(load).max(initial=0.0)), op=MPI.MAX)


def loads_the_free_motions(model: ContactModel, motions: FreeMotions) -> bool:
    """Whether the loads do work along a free motion (:func:`free_work` above round-off; collective)."""
    if not motions.free[0].any():
        return False
    work, scale = free_work(model, motions)
    return float(np.linalg.norm(work)) > 1e-12 * max(scale, np.finfo(float).tiny)


def free_motion_balance(model: ContactModel, motions: FreeMotions, contact_force: Array) -> float:
    """‖f + c‖ / max(‖f‖, ‖c‖) over the free motions: f the loads' work along each (:func:`free_work`), c the contact
    forces' (``contact_force``: A ũ − l̃ at the owned contact nodes, shape (m, 3)). Along a motion the supports leave
    free only the contact can balance the loads: a solve that ran off along one (a frictionless sideways push) ends
    with the round-off of K·ũ at |ũ| = 4e10 standing in for the missing force, every residual small (collective; 0
    without free motions)."""
    if not motions.free[0].any():
        return 0.0
    modes = _free_modes(model, motions)
    work, scale = free_work(model, motions, modes)
    cmap = model.contact
    contact = np.asarray(model.comm.allreduce(np.einsum("mi,mik->k", np.asarray(contact_force).reshape(-1, 3),
                                                        modes[cmap.blocks])))
    # relative to the larger of the two, and never to less than 1e-3 of the whole load (a load along the supported
    # motions only: the contact forces' round-off along the free ones is no imbalance)
    total = model.comm.allreduce(float(np.abs(model.load.getArray(readonly=True)).sum()), op=MPI.SUM)
    size = max(float(np.linalg.norm(work)), float(np.linalg.norm(contact)), 1e-3 * total)
    if size <= 1e-12 * max(scale, np.finfo(float).tiny):
        return 0.0
    return float(np.linalg.norm(work + contact)) / size


def rigid_approach(model: ContactModel, motions: FreeMotions, start: Array | None = None) -> Array | None:
    """The owned DOF values of the rigid approach of the model's one body (module docstring) from ``start`` (owned
    DOF values of ũ; default 0: the gaps at the placement), or None when there is none: no free motion, no load along
    one, or an unbounded program (collective).

    Only the motions that move some contact node along its normal count (the row space of the constraints, to
    1e-10 of their largest singular value): a free motion along the contact (a sideways push that friction holds, or
    nothing) is no approach, and is left to the solve. Among the optimal motions the one with the smallest
    coefficients is taken (a second program), with the constraints in the order of the nodes' global DOFs: the start
    does not depend on the partition (a block in a symmetric groove has a tie of mirror-image corners)."""
    if not motions.free[0].any():
        return None
    comm = model.comm
    modes = _free_modes(model, motions)
    work, scale = free_work(model, motions, modes)
    cmap = model.contact
    normals = cmap.frames[:, :, 2]
    rows = np.einsum("mi,mik->mk", normals, modes[cmap.blocks])  # nᵢ·rₖ(xᵢ)
    gaps = model.local_shift[:, 2] if cmap.size else np.zeros(0)  # the normal gap at the placement: v3 = n·ũ + s3
    if start is not None and cmap.size:
        gaps = gaps + np.einsum("mi,mi->m", normals, np.asarray(start)[cmap.local_dofs])
    order = np.concatenate(comm.allgather(np.asarray(cmap.global_dofs[:, 0], dtype=np.int64)))
    rows = np.concatenate(comm.allgather(rows.reshape(-1, work.size)))[np.argsort(order, kind="stable")]
    gaps = np.concatenate(comm.allgather(np.asarray(gaps, dtype=np.float64)))[np.argsort(order, kind="stable")]
    if rows.shape[0] == 0 or float(np.linalg.norm(work)) <= 1e-12 * max(scale, np.finfo(float).tiny):
        return None
    _, sigma, vt = np.linalg.svd(rows, full_matrices=False)
    basis = vt[sigma > 1e-10 * sigma[0]].T if sigma.size and sigma[0] > 0 else np.zeros((work.size, 0))
    if basis.shape[1] == 0:
        return None
    from scipy.optimize import linprog  # scipy only where used (fenics_coulomb/__init__.py)

    # in the body's units: the motion y = length·ŷ (the rows are dimensionless: modes of the normalized coordinates),
    # the work per unit motion over its largest component; HiGHS's tolerances are absolute (1e-7): a body of extent
    # 1e-3 in metres otherwise met them with every gap and got no approach
    length = float(motions.extent[0])
    reduced, limits, room = rows @ basis, -(basis.T @ work), gaps / length
    if not np.abs(limits).max() > 0.0:  # the loads do no work along the motions that approach an obstacle
        return None
    limits = limits / float(np.abs(limits).max())
    free = [(None, None)] * basis.shape[1]
    program = linprog(limits, A_ub=-reduced, b_ub=room, bounds=free, method="highs")
    if program.status != 0:
        return None
    # the smallest |y|₁ among the optima (y = p − q, p, q ≥ 0, the work at least the optimum's); the first program's
    # vertex where the second finds none
    k = basis.shape[1]
    smallest = linprog(np.ones(2 * k), A_ub=np.vstack([np.hstack([-reduced, reduced]), np.hstack([limits, -limits])]),
                       b_ub=np.concatenate([room, [float(program.fun)]]), bounds=[(0, None)] * (2 * k), method="highs")
    y = length * (smallest.x[:k] - smallest.x[k:] if smallest.status == 0 else program.x)
    return np.ascontiguousarray(np.einsum("nik,k->ni", modes, basis @ y).ravel())
