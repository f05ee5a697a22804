"""Physics checks of a computed contact state, independent of the solver's internals.

Everything is recomputed from the physical displacement ũ, the stiffness A and the load l̃: the contact
force on the body at a contact node is fⁱ = (A ũ − l̃)ⁱ (normal part λ = f₃, tangential part t = f₁₂),
the gap is ũ₃ + α — all in each node's frame R = (t₁, t₂, n): λ = n·f, t = T f, gap = g + n·ũ and the
slip s = T(ũ − δ) (T = (t₁; t₂), δ the node's obstacle displacement). The residuals are relative, so that
thresholds do not depend on units:

* ``equilibrium``: max |A ũ − l̃| over free DOFs (not contact, not clamped) / max |l̃| (or / max λ when l̃ = 0);
* ``penetration``: max(−gap, 0) / δ  (gap ≥ 0), δ = max(max α, max |ũ|) the displacement scale;
* ``negative_pressure``: max(−λ, 0) / max λ  (λ ≥ 0);
* ``complementarity``: max |gap·λ| / (δ · max λ)  (gap·λ = 0);
* ``cone``: max(‖t‖ − F λ, 0) / max λ  (‖t‖ ≤ F λ);
* ``slip_direction``: on nodes sliding by more than 1e-6 of the largest slip (and 1e-9 δ), max ‖t + F λ s/‖s‖‖ / max λ
  (the friction force opposes the slip s = ũ₁₂);
* ``reaction_balance``: ‖Σ contact forces + Σ Dirichlet reactions + applied resultant‖ / max(‖applied resultant‖,
  ‖Σ contact forces‖),
  with the reactions from the residual assembled with UFL without boundary conditions.
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.frames import to_local

__all__ = ["FORCE_FLOOR", "residual", "unconstrained_residual", "physics_residuals", "PHYSICS_TOL",
           "PHYSICS_PER_RTOL", "PHYSICS_LOOSEST", "DECISIVE_CHECKS", "physics_failure", "boundary_reactions", "total_contact_force"]


#: Forces below this fraction of (largest diagonal of A) × (displacement scale) count as round-off in the relative
#: residuals of :func:`physics_residuals`.
FORCE_FLOOR = 1e-10


def _gmax(comm: MPI.Comm, values: npt.NDArray[np.float64], initial: float = 0.0) -> float:
    local = float(np.max(values, initial=initial)) if values.size else initial
    return float(comm.allreduce(local, op=MPI.MAX))


def residual(model: ContactModel, displacement: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """A ũ − l̃ on the owned DOFs."""
    x, y = model.A.createVecs()
    x.array[:] = displacement
    model.A.mult(x, y)
    y.axpy(-1.0, model.load)
    out = y.getArray(readonly=True).copy()
    x.destroy()
    y.destroy()
    return out


def unconstrained_residual(model: ContactModel, displacement: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """K ũ − l̃⁰ per owned node (shape (owned nodes, 3)), assembled with UFL WITHOUT boundary conditions: the
    force the supports and the obstacles exert on the body, node by node (collective)."""
    uh = dolfinx.fem.Function(model.V)
    uh.x.petsc_vec.array[:] = displacement
    uh.x.scatter_forward()
    # K ũ and l̃⁰ assembled apart: a and L may integrate over measures with different subdomain data (e.g.
    # dx(body) with cell tags in a and the default L's plain dx), which one form cannot combine
    b = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(ufl.action(model.a_ufl, uh)))
    load = dolfinx.fem.petsc.assemble_vector(model.L)
    b.axpy(-1.0, load)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    full = b.getArray(readonly=True).reshape(-1, 3).copy()
    b.destroy()
    load.destroy()
    return full


def physics_residuals(model: ContactModel, displacement: npt.NDArray[np.float64],
                      balance: bool = True) -> dict[str, float]:
    """Relative residuals of equilibrium, Signorini, Coulomb and global balance (see module docstring);
    ``balance=False`` leaves out the global balance, which needs an assembly without boundary conditions (new
    DOLFINx objects: the solver's own check after every solve does without them)."""
    comm = model.V.mesh.comm
    cmap = model.contact
    F = model.friction
    r = residual(model, displacement)
    f = r[cmap.local_dofs]
    f_local = to_local(cmap.frames, f)
    lam = f_local[:, 2]
    t = f_local[:, :2]
    v = to_local(cmap.frames, displacement[cmap.local_dofs]) + model.local_shift
    gap = v[:, 2]
    slip = v[:, :2]

    free = np.ones(r.size, dtype=bool)
    free[cmap.local_dofs.ravel()] = False
    free[model.dirichlet_rows] = False
    load_scale = _gmax(comm, np.abs(model.load.getArray(readonly=True)))
    # displacement scale: the largest initial gap or displacement (a zero gap profile has no gap scale)
    gap_scale = max(_gmax(comm, np.abs(cmap.gap)), _gmax(comm, np.abs(displacement)))
    # forces below FORCE_FLOOR × (largest diagonal of A) × (displacement scale) are round-off: a body moved
    # rigidly by its prescribed values carries no force at all, and its residuals are round-off of round-off
    diagonal = model.A.getDiagonal()
    tiny = np.finfo(float).tiny
    force_tiny = max(FORCE_FLOOR * _gmax(comm, np.abs(diagonal.getArray(readonly=True))) * gap_scale, tiny)
    diagonal.destroy()
    # force scale: the largest contact force, or the largest nodal load when nothing touches
    lam_scale = max(_gmax(comm, lam), load_scale)
    out: dict[str, float] = {}
    # relative to the load, or to the contact forces when only an obstacle's displacement loads the body
    out["equilibrium"] = _gmax(comm, np.abs(r[free])) / max(load_scale if load_scale > force_tiny else lam_scale,
                                                             force_tiny)
    out["penetration"] = _gmax(comm, -gap) / max(gap_scale, tiny)
    out["negative_pressure"] = _gmax(comm, -lam) / max(lam_scale, force_tiny)
    out["complementarity"] = _gmax(comm, np.abs(gap * lam)) / max(gap_scale * max(lam_scale, force_tiny), tiny)
    tnorm = np.hypot(t[:, 0], t[:, 1])
    out["cone"] = _gmax(comm, tnorm - F * lam) / max(lam_scale, force_tiny)
    snorm = np.hypot(slip[:, 0], slip[:, 1])
    smax = _gmax(comm, snorm)
    # sliding: more than 1e-6 of the largest slip and more than round-off of the displacement scale (when every
    # node sticks, the slips are round-off and have no direction)
    sliding = snorm > max(1e-6 * smax, 1e-9 * gap_scale) if smax > 0 else np.zeros_like(snorm, dtype=bool)
    Fn = np.broadcast_to(np.asarray(F, dtype=np.float64), lam.shape)
    mismatch = t[sliding] + (Fn * lam)[sliding, None] * slip[sliding] / snorm[sliding, None]
    out["slip_direction"] = _gmax(comm, np.hypot(mismatch[:, 0], mismatch[:, 1])) / max(lam_scale, force_tiny)

    if not balance:
        return out
    # Global balance with the clamped reactions from an assembly without boundary conditions.
    clamped_blocks = np.unique(model.dirichlet_rows // 3)
    if not model.coupling.paired:
        full = unconstrained_residual(model, displacement)
        local = full[clamped_blocks].sum(axis=0) + f.sum(axis=0)
    else:  # contact pairs, u = M z: the contact forces are internal (Σ_j φ_sj = 1), so the residual summed over
        # every node (supports, slave and master nodes; zero elsewhere) balances the applied load
        full = unconstrained_residual(model, model.physical(displacement))
        local = full[: model.V.dofmap.index_map.size_local].sum(axis=0)
    total = np.asarray(comm.allreduce(local, op=MPI.SUM))
    applied = model.total_load()
    contact_total = np.asarray(comm.allreduce(f.sum(axis=0), op=MPI.SUM))
    # the support forces' own size: a body loaded only through prescribed displacements, with no contact force,
    # has supports that balance each other (their sum is round-off of their size, not of 0)
    owned = clamped_blocks[clamped_blocks < model.V.dofmap.index_map.size_local]
    support = comm.allreduce(float(np.linalg.norm(full[owned], axis=1).sum()), op=MPI.SUM)
    # relative to the applied resultant, or to the contact resultant or the support forces when the body is
    # loaded only through prescribed displacements
    balance_scale = max(float(np.linalg.norm(applied)), float(np.linalg.norm(contact_total)), support, force_tiny)
    out["reaction_balance"] = float(np.linalg.norm(total + applied) / balance_scale)
    out["contact_resultant"] = [float(c) for c in contact_total]  # type: ignore[assignment]
    return out


#: A converged solve fails the physics checks when a relative residual exceeds max(PHYSICS_TOL, PHYSICS_PER_RTOL ×
#: the solve's rtol) or is not finite. The stopping rule bounds the 2-norm of the force and displacement
#: misfit by rtol·‖ŷ(ũ = 0)‖ (:mod:`fenics_coulomb.scd.stopping`); the checks take maxima over nodes, which can be up
#: to √(contact nodes) times that (measured: up to 5.4e-6 at rtol 1e-7 on a strongly graded block). The bound is
#: there to catch what no stopping rule sees — a degenerate cell (equilibrium 0.875 off), a load that overflows —
#: never to second-guess a solve that met its target.
PHYSICS_TOL = 1e-3
PHYSICS_PER_RTOL = 1e4
#: The loosest bound, whatever rtol: a solve asked for a loose accuracy (``--accuracy 0.9`` left a penetration of
#: 3.4 % of the displacement scale) is not converged with a residual above 1 % (exit 3), never "checks passed".
PHYSICS_LOOSEST = 1e-2
#: The checks that decide (the others are reported values): slip_direction measures the direction of slips down to
#: 1e-6 of the largest one, which a solve to rtol resolves only to about rtol/slip, and reaction_balance divides
#: by the supports' own forces, which are the solver's noise when a prescribed motion is rigid.
DECISIVE_CHECKS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone")


def physics_failure(checks: dict[str, float], rtol: float) -> str:
    """"" when every decisive check of :func:`physics_residuals` passes, else the first failure in words."""
    bound = min(max(PHYSICS_TOL, PHYSICS_PER_RTOL * rtol), PHYSICS_LOOSEST)
    for key in DECISIVE_CHECKS:
        value = checks.get(key, 0.0)
        if not np.isfinite(value) or value > bound:
            cause = ("rtol or accuracy too loose for any check to pass: tighten it" if bound < PHYSICS_PER_RTOL * rtol
                     else "a degenerate mesh cell or a load too large for floating point?")
            return f"the physics checks fail: {key} residual {value:.3g} > {bound:.3g} ({cause})"
    return ""


def boundary_reactions(model: ContactModel, displacement: npt.NDArray[np.float64],
                       groups: dict[str, npt.NDArray[np.int32]],
                       master_force: npt.NDArray[np.float64] | None = None) -> dict[str, list[float]]:
    """The reaction force the support exerts on the body per Dirichlet boundary (collective, same on all ranks).

    At a node, K ũ − l̃⁰ (the stiffness and load assembled WITHOUT boundary conditions) is the sum of the
    external forces not in l̃⁰: the support's reaction and the contact force the node receives. Contact nodes
    never carry a Dirichlet component, but with two bodies a prescribed MASTER node receives the contact force
    f_j = −Σ_s φ_sj f_s of the slave nodes paired with it; the support carries it: its reaction is
    K ũ − l̃⁰ − f_j (a driven master body moved rigidly has K ũ − l̃⁰ = 0 and its support the whole contact
    force). ``groups`` maps a boundary name to its local DOF blocks (owned and ghost; only owned ones are
    summed); ``master_force`` is the result's master reaction (owned DOFs; None for one body).
    """
    comm = model.V.mesh.comm
    full = unconstrained_residual(model, displacement)
    if master_force is not None:
        full -= np.asarray(master_force, dtype=np.float64).reshape(-1, 3)[: full.shape[0]]
    size_local = model.V.dofmap.index_map.size_local
    out: dict[str, list[float]] = {}
    for name, blocks in groups.items():
        owned = blocks[blocks < size_local]
        total = comm.allreduce(full[owned].sum(axis=0), op=MPI.SUM)
        out[name] = [float(c) for c in total]
    return out


def total_contact_force(model: ContactModel, contact_force: npt.NDArray[np.float64]) -> list[float]:
    """Σ of the Cartesian contact forces on the body over all contact nodes (collective)."""
    local = np.asarray(contact_force, dtype=np.float64).reshape(-1, 3).sum(axis=0)
    return [float(c) for c in model.V.mesh.comm.allreduce(local, op=MPI.SUM)]
