"""Physics checks of a computed contact state, independent of the solver's internals.

Everything is recomputed from the physical displacement ũ, the stiffness A and the load l̃: the contact
force on the body at a contact node is fⁱ = (A ũ − l̃)ⁱ (normal part λ = f₃, tangential part t = f₁₂),
the gap is ũ₃ + α — all in each node's frame R = (t₁, t₂, n): λ = n·f, t = T f, gap = g + n·ũ and the
slip s = T(ũ − δ) (T = (t₁; t₂), δ the node's obstacle displacement). The residuals are relative, so that
thresholds do not depend on units:

* ``equilibrium``: max |A ũ − l̃| over free DOFs (not contact, not clamped) / max |l̃| (or / max λ when l̃ = 0);
* ``penetration``: max(−gap, 0) / δ  (gap ≥ 0), δ = max(max α, max |ũ|) the displacement scale;
* ``free_penetration``: the same for the slave nodes over a master surface that are not contact nodes (beyond the
  search distance, or mortar nodes not fully covered) when no paired contact node carries a force: a pair that
  lost its contact must not pass;
* ``shared_penetration``: the same for the nodes on both a pair's slave surface and the obstacles' contact boundary,
  against the constraint they were not given (a node meets one, the one with the smaller gap: it must not end
  inside the other — the obstacle, or the pair's master surface);
* ``obstacle_penetration``: the same for the obstacles' contact nodes against every obstacle (a node meets its
  own obstacle's constraint and must not end inside another: a corner between two obstacles);
* ``uncovered_penetration``: the same for the slave nodes of the pairs that no part of their master surface lies
  beneath (beyond the master surface's border: no constraint keeps them out) inside the master body in X + u, their
  depth the signed distance to the body's boundary but its symmetry planes
  (:mod:`fenics_coulomb.model.pairs.uncovered`), and
  ``uncovered_penetration_at``, the deepest one's position in X + u; under small sliding (which pairs in X: the
  deformed master's edge may pass such a node) reported, not decisive, as ``uncovered_small_sliding`` (``_at``);
* ``master_penetration`` (reported, not decisive): the same for the master nodes of the pairs inside their slave body
  in X + u, less the depth the facetting of curved surfaces allows (:mod:`fenics_coulomb.model.pairs.master_nodes`;
  a pair does not constrain its master's nodes: a master smaller than the slave, or its border under a slave that
  hangs over it), ``master_penetration_at``, the deepest one's position, and ``master_penetration_facet``, the largest
  such depth over the slave facet's size there (not relative to δ: a slide far along the contact dilutes δ);
* ``support_penetration`` (reported, not decisive): the same for the nodes of the obstacles' contact boundary that
  a support holds and that are therefore no contact nodes (a support moving a node along or into the contact);
* ``free_balance``: along the rigid motions the supports leave free (a body held by contact alone), how far the
  contact forces are from balancing the loads, ‖f + c‖ / max(‖f‖, ‖c‖) (:mod:`fenics_coulomb.model.rigid_approach`);
* ``negative_pressure``: max(−λ, 0) / max λ  (λ ≥ 0);
* ``complementarity``: max |gap·λ| / (δ · max λ)  (gap·λ = 0);
* ``cone``: max(‖t‖ − F λ, 0) / max λ  (‖t‖ ≤ F λ);
* ``slip_direction``: on nodes sliding by more than 1e-6 of the largest slip, 1e-9 δ and
  :data:`SLIP_RESOLUTION` × the solve's displacement accuracy e·δ, max ‖t + F λ s/‖s‖‖ / max λ (the friction force
  opposes the slip s = ũ₁₂). A slip known to ±e·δ has a direction known to ±e·δ/‖s‖ rad: a sticking node whose
  slip is the solve's own error (2e-8 against e·δ = 1.6e-8 on the two-body demo at rtol 1e-7) has no direction,
  and its mismatch (0.5 there) measures the tolerance, not the friction law;
* ``reaction_balance``: ‖Σ contact forces + Σ Dirichlet reactions + applied resultant‖ / max(‖applied resultant‖,
  ‖Σ contact forces‖),
  with the reactions from the residual assembled with UFL without boundary conditions; springs in the form
  (``k·inner(u, v)·ds``) count as supports (their resultant Σ K u, round-off for an elastic form).
"""

from __future__ import annotations

import weakref
from collections.abc import Mapping
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import check_all
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.dof_values import set_owned_values
from fenics_coulomb.model.frames import to_local
from fenics_coulomb.model.obstacle_checks import obstacle_depths

__all__ = ["FORCE_FLOOR", "residual", "unconstrained_residual", "physics_residuals", "SLIP_RESOLUTION", "PHYSICS_TOL",
           "PHYSICS_PER_RTOL", "PHYSICS_LOOSEST", "DECISIVE_CHECKS", "physics_failure", "boundary_reactions",
           "constrained_mask", "support_dofs", "total_contact_force", "ONE_CONSTRAINT", "physics_bound", "force_floor",
           "displacement_scale", "MASTER_WARNING", "reported_warnings", "SPRING_FLOOR"]


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


#: Per model: the displacement Function and the compiled form K w of :func:`unconstrained_residual` (weak keys:
#: an entry goes with its model; no PETSc object is kept).
_ACTIONS: weakref.WeakKeyDictionary[ContactModel, tuple[dolfinx.fem.Function, dolfinx.fem.Form]] = \
    weakref.WeakKeyDictionary()


def unconstrained_residual(model: ContactModel, displacement: npt.NDArray[np.float64],
                           load: npt.NDArray[np.float64] | None = None) -> npt.NDArray[np.float64]:
    """K ũ − l̃⁰ per owned node (shape (owned nodes, 3)), assembled with UFL WITHOUT boundary conditions: the
    force the supports and the obstacles exert on the body, node by node (collective).

    Both vectors are completed on their owners (each its own reverse ghost scatter) before they are subtracted:
    the owned part of a ghosted vector does not hold the other ranks' contributions to a node on a partition
    boundary. ``load``: l̃⁰ so completed (:meth:`ContactModel.owned_load`) when the caller has it already."""
    if model not in _ACTIONS:  # compiled once per model (a load path asks at every step)
        w = dolfinx.fem.Function(model.V)
        _ACTIONS[model] = (w, dolfinx.fem.form(ufl.action(model.a_ufl, w)))
    uh, action = _ACTIONS[model]
    set_owned_values(uh, displacement)
    # K ũ and l̃⁰ assembled apart: a and L may integrate over measures with different subdomain data (e.g.
    # dx(body) with cell tags in a and the default L's plain dx), which one form cannot combine
    b = dolfinx.fem.petsc.assemble_vector(action)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    owned = model.owned_load() if load is None else load
    full = b.getArray(readonly=True).reshape(-1, 3) - owned  # (x − y is x + (−1)·y: VecAXPY's bits)
    b.destroy()
    return full


def force_floor(model: ContactModel, scale: float) -> float:
    """Forces below FORCE_FLOOR × (largest diagonal of A) × ``scale`` (the displacement scale) are round-off: a body
    moved rigidly by its prescribed values carries no force at all (collective)."""
    diagonal = model.A.getDiagonal()
    floor = FORCE_FLOOR * _gmax(model.comm, np.abs(diagonal.getArray(readonly=True))) * scale
    diagonal.destroy()
    return max(floor, np.finfo(float).tiny)


def displacement_scale(model: ContactModel, displacement: npt.NDArray[np.float64]) -> float:
    """The largest initial gap or displacement (a zero gap profile has no gap scale; collective)."""
    return max(_gmax(model.comm, np.abs(model.contact.gap)), _gmax(model.comm, np.abs(displacement)))


def physics_residuals(model: ContactModel, displacement: npt.NDArray[np.float64],
                      balance: bool = True, accuracy: float = 0.0) -> dict[str, float]:
    """Relative residuals of equilibrium, Signorini, Coulomb and global balance (see module docstring).

    Args:
        model: The algebraic model.
        displacement: The unknown (z for contact pairs) on the owned DOFs.
        balance: With the global balance, which needs an assembly without boundary conditions (new DOLFINx
            objects: the solver's own check after every solve does without them).
        accuracy: The solve's relative displacement accuracy e (ERROR_PER_RTOL·rtol; 0: unknown): slips below
            SLIP_RESOLUTION·e·δ have no direction the slip_direction check could test.
    """
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
    slip = np.where(cmap.held_local[:, :2], 0.0, v[:, :2])  # a held component is the support's, not a slip

    free = np.ones(r.size, dtype=bool)
    free[cmap.local_dofs.ravel()] = False
    free[model.dirichlet_rows] = False
    load_scale = _gmax(comm, np.abs(model.load.getArray(readonly=True)))
    # displacement scale: the largest initial gap or displacement (a zero gap profile has no gap scale)
    gap_scale = displacement_scale(model, displacement)
    tiny = np.finfo(float).tiny
    force_tiny = force_floor(model, gap_scale)
    # force scale: the largest contact force, or the largest nodal load when nothing touches
    lam_scale = max(_gmax(comm, lam), load_scale)
    out: dict[str, float] = {}
    # relative to the load, or to the contact forces when only an obstacle's displacement loads the body
    out["equilibrium"] = _gmax(comm, np.abs(r[free])) / max(load_scale if load_scale > force_tiny else lam_scale,
                                                             force_tiny)
    out["penetration"] = _gmax(comm, -gap) / max(gap_scale, tiny)
    # a pair that carries no force while its free slave nodes (over the master, but no contact nodes: beyond the
    # search distance, or mortar nodes not fully covered) penetrate the master has lost its contact: no exit 0 for
    # bodies passing through each other. (Border nodes that the mortar full-coverage rule drops beside nodes that
    # carry the contact penetrate by the rule's border error and only warn, docs/sliding.)
    carried = _gmax(comm, lam[model.coupling.paired_mask(cmap.size)])
    out["free_penetration"] = model.coupling.free_slave_depth(model, model.physical(displacement)) / \
        max(gap_scale, tiny) if carried <= force_tiny else 0.0
    # a node meets one constraint: a node on a pair's slave surface and the obstacles' contact boundary must not
    # end inside the one it was not given (a rigid obstacle reaching into its partner body needs both)
    physical = model.physical(displacement)
    out["shared_penetration"] = model.coupling.shared_depth(model, physical) / max(gap_scale, tiny)
    # every obstacle contact node against every obstacle, and the contact boundary's supported nodes
    blocks, x = model.placement.boundary(model.V, model.facet_tags, model.markers)
    rigid = cmap.blocks[~model.coupling.paired_mask(cmap.size)]
    contact = np.isin(blocks, rigid)
    checked = contact | ~np.isin(blocks, cmap.blocks)  # not the pairs' slave nodes (shared_penetration's)
    contact_depth, support_depth = obstacle_depths(model.obstacles, x[checked],
                                                   physical.reshape(-1, 3)[blocks[checked]], contact[checked],
                                                   model.sliding == "finite", 1e-12 * model.placement.size)
    out["obstacle_penetration"] = _gmax(comm, contact_depth) / max(gap_scale, tiny)
    out["support_penetration"] = _gmax(comm, support_depth) / max(gap_scale, tiny)
    # nothing keeps a slave node with no master surface beneath it out of the master body
    # (small sliding pairs in X: a node beyond the master's border there may meet the deformed master's edge, which
    # that model does not see: reported and warned)
    uncovered, uncovered_at = model.coupling.uncovered_depth(model, physical)
    key = "uncovered_penetration" if model.sliding == "finite" else "uncovered_small_sliding"
    out[key] = uncovered / max(gap_scale, tiny)
    if uncovered_at is not None:
        out[f"{key}_at"] = [float(c) for c in uncovered_at]  # type: ignore[assignment]
    # a pair keeps its slave nodes out of the master body, not the master's nodes out of the slave body
    master_depth, master_at, master_facet = model.coupling.master_depth(model, physical)
    out["master_penetration"] = master_depth / max(gap_scale, tiny)
    out["master_penetration_facet"] = master_facet
    if master_at is not None:
        out["master_penetration_at"] = [float(c) for c in master_at]  # type: ignore[assignment]
    out["free_balance"] = model.coupling.free_balance(model, f)
    out["negative_pressure"] = _gmax(comm, -lam) / max(lam_scale, force_tiny)
    out["complementarity"] = _gmax(comm, np.abs(gap * lam)) / max(gap_scale * max(lam_scale, force_tiny), tiny)
    tnorm = np.hypot(t[:, 0], t[:, 1])
    out["cone"] = _gmax(comm, tnorm - F * lam) / max(lam_scale, force_tiny)
    snorm = np.hypot(slip[:, 0], slip[:, 1])
    smax = _gmax(comm, snorm)
    # sliding: more than 1e-6 of the largest slip, more than round-off of the displacement scale (when every node
    # sticks, the slips are round-off and have no direction) and more than the solve's accuracy resolves
    cut = max(1e-6 * smax, 1e-9 * gap_scale, SLIP_RESOLUTION * accuracy * gap_scale)
    sliding = snorm > cut if smax > 0 else np.zeros_like(snorm, dtype=bool)
    Fn = np.broadcast_to(np.asarray(F, dtype=np.float64), lam.shape)
    mismatch = t[sliding] + (Fn * lam)[sliding, None] * slip[sliding] / snorm[sliding, None]
    out["slip_direction"] = _gmax(comm, np.hypot(mismatch[:, 0], mismatch[:, 1])) / max(lam_scale, force_tiny)

    if not balance:
        return out
    # Global balance with the clamped reactions from an assembly without boundary conditions.
    clamped_blocks = np.unique(model.dirichlet_rows // 3)
    # what the supports and the contact forces take from the load (for contact pairs the contact forces are
    # internal: the residual of u = M z summed over every node)
    full = unconstrained_residual(model, model.physical(displacement))
    local = model.coupling.balance_sum(model, full, f, clamped_blocks)
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
    # springs in the form (k·inner(u, v)·ds) are supports too: the force the stiffness itself takes to the ground,
    # Σ K u over every node = Σ (K u − l̃⁰) + the applied resultant (round-off for an elastic form, whose rigid
    # translations cost nothing: then left out, the value unchanged)
    springs = np.asarray(comm.allreduce(full.sum(axis=0), op=MPI.SUM)) + applied
    if np.linalg.norm(springs) > SPRING_FLOOR * balance_scale:
        total = total - springs
    out["reaction_balance"] = float(np.linalg.norm(total + applied) / balance_scale)
    out["contact_resultant"] = [float(c) for c in contact_total]  # type: ignore[assignment]
    return out


#: A resultant of the stiffness below this × the balance's scale is round-off (no springs in the form).
SPRING_FLOOR = 1e-8

#: The slip_direction check tests the nodes whose slip exceeds this × the solve's displacement error (their slip
#: direction known to 1/SLIP_RESOLUTION rad).
SLIP_RESOLUTION = 1e3

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
#: The checks that decide (the others are reported values): slip_direction tests directions known to 1e-3 rad, a
#: mismatch of up to F·1e-3 of the largest force from the solve's own error, and reaction_balance divides
#: by the supports' own forces, which are the solver's noise when a prescribed motion is rigid.
DECISIVE_CHECKS = ("equilibrium", "penetration", "free_penetration", "shared_penetration", "obstacle_penetration",
                   "uncovered_penetration", "free_balance", "negative_pressure", "complementarity", "cone")


#: ``master_penetration`` is warned above this: dual mortar meets the gaps weakly, and a master node at the border of
#: a coarse pair lies inside the slave body by its pointwise error (1.2e-3 on verification case 5's coarse incline,
#: exact in push/weight there), while a master smaller than the slave leaves 0.33 (node-to-surface) and 0.78 (mortar)
#: (tests/model/test_master_nodes.py). Not decisive: mortar's slave hanging over the master's border (the slide-off
#: demo: 3.5e-3 inside, 0.4 % of its 0.8 slide) is the method's documented edge limit.
MASTER_WARNING = 1e-2

#: Why a node on a pair's slave surface and on the obstacles' contact boundary can fail (the messages' words).
ONE_CONSTRAINT = ("a contact node meets one constraint, the pair's or the obstacle's (the smaller gap), and these "
                  "nodes must meet both — an obstacle reaching into the pair's partner body, or a slave face sharing "
                  "an edge with a face that rests on the obstacle (two blocks side by side on a floor): this model "
                  "cannot; keep the slave surface's nodes off the obstacles' contact boundary (e.g. a slave face that "
                  "stops short of the floor, or the floor contact on the master body only)")


def physics_bound(rtol: float) -> float:
    """The bound a relative residual of :func:`physics_residuals` must not exceed in a solve to ``rtol``."""
    return min(max(PHYSICS_TOL, PHYSICS_PER_RTOL * rtol), PHYSICS_LOOSEST)


def physics_failure(checks: Mapping[str, Any], rtol: float) -> str:
    """"" when every decisive check of :func:`physics_residuals` passes, else the first failure in words."""
    bound = physics_bound(rtol)
    for key in DECISIVE_CHECKS:
        value = checks.get(key, 0.0)
        if not np.isfinite(value) or value > bound:
            cause = ("rtol or accuracy too loose for any check to pass: tighten it" if bound < PHYSICS_PER_RTOL * rtol
                     else "no contact node of the pairs carries a force while slave nodes beyond the search distance "
                     "or not fully covered by the master (mortar) penetrate it: make the smaller surface the slave, "
                     "enlarge search_distance, or, for a slave that rests on the master's border (mortar drops the "
                     "nodes whose facets reach past it), use method = 'node-to-surface'" if key == "free_penetration"
                     else f"nodes on a pair's slave surface and an obstacle's contact boundary end inside the "
                     f"constraint they were not given: {ONE_CONSTRAINT}" if key == "shared_penetration"
                     else "contact nodes end inside an obstacle other than their own: a node meets one obstacle's "
                     "constraint (the smallest gap), and a node between two obstacles (a corner, an edge resting on "
                     "two) needs both: this model cannot; keep the contact boundary of each obstacle apart (e.g. the "
                     "faces meeting the wall and the floor without their common edge)" if key == "obstacle_penetration"
                     else "slave nodes of a pair that no part of its master surface lies beneath end inside the "
                     "master body (deepest at (" + ", ".join(f"{c:.6g}" for c in checks.get(
                         "uncovered_penetration_at", [])) + ") in X + u): nothing keeps them out; tag the master "
                     "surface over all of the partner's face the slave may touch" if key == "uncovered_penetration"
                     else "the loads push the body along a motion its supports leave free and its contacts do not hold "
                     "(e.g. sideways on a frictionless floor): the solve ran off along it; support that motion"
                     if key == "free_balance"
                     else "a degenerate mesh cell or a load too large for floating point?")
            return f"the physics checks fail: {key} residual {value:.3g} > {bound:.3g} ({cause})"
    return ""


def reported_warnings(checks: dict[str, Any], rtol: float) -> list[str]:
    """The warnings of the reported (not decisive) checks of a solve to ``rtol`` that passed the decisive ones."""
    out = []
    depth = checks.get("support_penetration", 0.0)
    if depth > physics_bound(rtol):
        out.append(f"nodes of the contact boundary that a support holds (no contact nodes: a support moving them along "
                   f"or into the contact) end inside an obstacle, by up to {depth:.3g} of the displacement scale: "
                   "leave them out of the support or out of the contact boundary")
    depth = checks.get("uncovered_small_sliding", 0.0)
    if depth > physics_bound(rtol):
        at = "(" + ", ".join(f"{c:.6g}" for c in checks.get("uncovered_small_sliding_at", [])) + ")"
        out.append(f"slave nodes of a pair that no part of its master surface lies beneath in the reference "
                   f"configuration end inside the master body, by up to {depth:.3g} of the displacement scale (at "
                   f"{at} in X + u): small sliding pairs once, in X; use sliding = 'finite', or tag the master surface "
                   "over all of the partner's face the slave may touch")
    depth, facet = checks.get("master_penetration", 0.0), checks.get("master_penetration_facet", 0.0)
    if depth > MASTER_WARNING or facet > MASTER_WARNING:
        at = "(" + ", ".join(f"{c:.6g}" for c in checks.get("master_penetration_at", [])) + ")"
        out.append(f"a master node of a contact pair ends inside the slave body, by up to {depth:.3g} of the "
                   f"displacement scale and {facet:.3g} of the slave facet above it (at {at}): a pair keeps its slave "
                   "nodes out of the master body, not the master's nodes out of the slave's — make the smaller "
                   "surface the slave, meshed at least as finely as the master, or use mortar (and under mortar a "
                   "slave that hangs over the master's border drops the nodes whose facets straddle it: "
                   "node-to-surface keeps them)")
    return out


def constrained_mask(model: ContactModel) -> npt.NDArray[np.bool_]:
    """Which owned DOFs (unrolled, shape (owned nodes, 3)) a boundary condition of the problem holds."""
    size_local = model.V.dofmap.index_map.size_local
    mask = np.zeros(3 * size_local, dtype=bool)
    mask[model.dirichlet_rows] = True
    return mask.reshape(-1, 3)


def support_dofs(model: ContactModel, support: Any, name: str = "") -> npt.NDArray[np.int32]:
    """The owned DOFs (unrolled local indices, ascending) whose reactions make up one support's reaction.

    Args:
        model: The solved model.
        support: A ``dolfinx.fem.DirichletBC`` of the problem (on V or on a sub-space ``V.sub(i)``: the
            components it holds), a list of them (the union), or an integer array of local DOF blocks (nodes: the
            components of those nodes that the problem's boundary conditions hold).
        name: The support's name (for the error message).

    Raises:
        InputError: (on every rank) a boundary condition that holds a DOF the problem does not hold (a condition
            of another problem or mesh), or a node block out of range.
    """
    size_local = model.V.dofmap.index_map.size_local
    num_blocks = size_local + model.V.dofmap.index_map.num_ghosts
    held = constrained_mask(model)
    if isinstance(support, list | tuple) and support and all(isinstance(s, dolfinx.fem.DirichletBC) for s in support):
        return np.unique(np.concatenate([support_dofs(model, s, name) for s in support])).astype(np.int32)
    if isinstance(support, dolfinx.fem.DirichletBC):
        dofs = np.asarray(support.dof_indices()[0], dtype=np.int64)  # unrolled: V's DOFs for V.sub(i) too
        owned = dofs[dofs < 3 * size_local]
        ok = bool(np.all((dofs >= 0) & (dofs < 3 * num_blocks))) and bool(np.all(held.ravel()[owned]))
        check_all(model.comm, ok, f"reactions[{name!r}]: a DirichletBC that is not one of the problem's boundary "
                  "conditions (it holds DOFs the problem does not hold)")
        return np.unique(owned).astype(np.int32)
    try:
        blocks = np.asarray(support)
    except (TypeError, ValueError):  # a ragged sequence
        blocks = np.asarray(None, dtype=object)
    ok = blocks.ndim == 1 and (blocks.size == 0 or (np.issubdtype(blocks.dtype, np.integer)
                                                     and int(blocks.min()) >= 0 and int(blocks.max()) < num_blocks))
    what = f"an array of shape {blocks.shape} and dtype {blocks.dtype}" if blocks.dtype != object else \
        f"a {type(support).__name__}"
    check_all(model.comm, ok, f"reactions[{name!r}]: {what} is neither a DirichletBC of the problem nor an array "
              f"of local node blocks in [0, {num_blocks})")
    blocks = np.unique(blocks.astype(np.int64))
    blocks = blocks[blocks < size_local]
    dofs = (3 * blocks[:, None] + np.arange(3)).ravel()
    return dofs[held.ravel()[dofs]].astype(np.int32)


def boundary_reactions(model: ContactModel, displacement: npt.NDArray[np.float64], groups: Mapping[str, Any],
                       master_force: npt.NDArray[np.float64] | None = None,
                       contact_force: npt.NDArray[np.float64] | None = None,
                       load: npt.NDArray[np.float64] | None = None) -> dict[str, list[float]]:
    """The reaction force each support exerts on the body (collective, same on all ranks).

    At a DOF, r = K ũ − l̃⁰ (the stiffness and load assembled WITHOUT boundary conditions) is the sum of the
    external forces not in l̃⁰: a support's reaction where a boundary condition holds the DOF, the contact force
    of an obstacle or of a pair's other body where the node is a contact node, and, with two bodies, the force
    f_l = −Σ_j Φ_jl f_j a master node receives from the slave nodes paired with it. The reaction of a support
    is therefore r − f_contact − f_master summed over the DOFs the support HOLDS, component by component: a
    condition on ``V.sub(0)`` (or a roller) has no reaction in the components it leaves free, and a node held in
    x by one support and in y by another gives each its own component. A driven master body moved rigidly has
    r = 0 on its nodes and its support carries the whole contact force (−f_master).

    A DOF named by several groups counts once, in the first group (in ``groups`` order) that names it, so that
    Σ reactions + Σ contact forces of the obstacles + applied load = 0 holds for any set of groups that covers
    the supports.

    Args:
        model: The solved model.
        displacement: The physical displacement ũ (owned DOFs).
        groups: name → support (:func:`support_dofs`: a DirichletBC or local node blocks).
        master_force: Two bodies: the result's master reaction (owned DOFs; None for one body).
        contact_force: The result's contact force per owned contact node, shape (m, 3) (None: taken as 0, right
            while no contact node has a constrained component).
        load: l̃⁰ completed on its owners (:meth:`ContactModel.owned_load`), when the caller has it already.
    """
    comm = model.V.mesh.comm
    full = unconstrained_residual(model, displacement, load)
    if master_force is not None:
        full -= np.asarray(master_force, dtype=np.float64).reshape(-1, 3)[: full.shape[0]]
    if contact_force is not None and model.contact.size:
        np.subtract.at(full, model.contact.blocks, np.asarray(contact_force, dtype=np.float64).reshape(-1, 3))
    flat = full.ravel()
    taken = np.zeros(flat.size, dtype=bool)
    out: dict[str, list[float]] = {}
    for name, support in groups.items():
        dofs = support_dofs(model, support, str(name))
        dofs = dofs[~taken[dofs]]
        taken[dofs] = True
        local = np.zeros(3)
        np.add.at(local, dofs % 3, flat[dofs])
        out[str(name)] = [float(c) for c in comm.allreduce(local, op=MPI.SUM)]
    return out


def total_contact_force(model: ContactModel, contact_force: npt.NDArray[np.float64]) -> list[float]:
    """Σ of the Cartesian contact forces on the body over all contact nodes (collective)."""
    local = np.asarray(contact_force, dtype=np.float64).reshape(-1, 3).sum(axis=0)
    return [float(c) for c in model.V.mesh.comm.allreduce(local, op=MPI.SUM)]
