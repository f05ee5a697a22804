r"""The SCD semismooth* Newton driver for the contact GE 0 ∈ A u − l + Q(u) (Sections 4, 5, 7).

One iteration k, from the iterate u = u⁽ᵏ⁾ with residual r = A u − l:

1. Approximation step (6.17): d̂ = (γI + Q)⁻¹(γ u − r), node-wise by the closed-form resolvent on the
   contact blocks and d̂ = u − r/γ on the other DOFs. With e := u − d̂ the residual of Section 7 is
   ŷ = (γ e, e), ‖ŷ‖ = √(1 + γ²)·‖e‖, and zⁱ = γ eⁱ − rⁱ ∈ Q̃(d̂ⁱ).
2. Newton direction: variant 4a or 4b (:mod:`fenics_coulomb.scd.steps`); the Newton matrix is A with its
   contact rows replaced every iteration, applied matrix-free when the preconditioner is built on A, else
   a copy of A updated in place (:mod:`fenics_coulomb.scd.newton_operator`).
3. Non-monotone line search (Section 7): α is the first of 1, 1/2, 1/4, 1/8, 1/32, 1/128, 0.1/128,
   0.01/128, … with ‖ŷ(u + αΔu)‖ ≤ (1 − 0.1α + 0.1/(k + 1))‖ŷ(u)‖.
4. Stopping rule (:mod:`fenics_coulomb.scd.stopping`).

The linear solves' tolerance is fixed or an Eisenstat–Walker forcing term (:mod:`fenics_coulomb.scd.forcing`).

Per-node γ: every contact node i gets its own γᵢ = min(γ, κ·λ_max(Aᵢᵢ)) (:mod:`fenics_coulomb.scd.node_gamma`,
where the derivation is); γ stays on the other DOFs. The linear solves (the KSP's life cycle, the options'
scope, pc = "auto"'s escalation, GAMG's hierarchy across geometry updates) are the base class
:class:`~fenics_coulomb.scd.linear_solves.NewtonLinearSolves`.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterator

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.frames import conjugate, to_global, to_local
from fenics_coulomb.scd.contact_rows import ContactRows
from fenics_coulomb.scd.derivatives import pressed_branch
from fenics_coulomb.scd.forcing import forcing_term, terminal_forcing
from fenics_coulomb.scd.linear_solves import NewtonLinearSolves
from fenics_coulomb.scd.newton_operator import MATRIX_FREE_PCS, NewtonOperator
from fenics_coulomb.scd.physical_preconditioner import PhysicalGAMG
from fenics_coulomb.scd.node_gamma import node_gamma
from fenics_coulomb.scd.power_method import power_iteration
from fenics_coulomb.scd.preconditioner import auto_ladder, check_option_value, resolve_pc
from fenics_coulomb.scd.records import Direction, Iterate, IterationRecord, SolveResult, global_state_counts
from fenics_coulomb.scd.resolvent import classify, contact_states, resolvent
from fenics_coulomb.scd.steps import STEPS
from fenics_coulomb.scd.stopping import ACCURACY_FORCING, StoppingRule
from fenics_coulomb.settings import COMMAND_PREFIX, SolverSettings, check_fixed_gamma

__all__ = ["line_search_steps", "Iterate", "Direction", "SCDNewtonSolver"]

#: With a body held by contact alone, v3 ≤ this × the mesh's size (its coordinates' round-off) touches, and biactive
#: nodes take the pressed branch (:func:`~fenics_coulomb.scd.derivatives.pressed_branch`; docs/robustness: a block
#: meshed onto its floor, held sideways only, had a singular Newton matrix and ran off).
TOUCHING = 1e-12

logger = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


def line_search_steps(count: int) -> Iterator[float]:
    """The step lengths of Section 7: 1, 1/2, 1/4, 1/8, 1/32, 1/128, 0.1/128, 0.01/128, ..."""
    head = (1.0, 0.5, 0.25, 0.125, 1.0 / 32.0, 1.0 / 128.0)
    for i in range(count):
        yield head[i] if i < len(head) else (1.0 / 128.0) * 0.1 ** (i - len(head) + 1)


class SCDNewtonSolver(NewtonLinearSolves):
    """SCD semismooth* Newton solver for a :class:`ContactModel`; owns the Newton matrix and its KSP.

    The Newton matrix and its KSP (GMRES, right preconditioned, stopped on the unpreconditioned relative
    residual) carry the options prefix ``prefix``; ``petsc_options`` are put into PETSc's options database
    under it only while the solver reads them (creation and every solve) and removed again, so that no
    option outlives the call. ``-<prefix>ksp_*`` / ``-<prefix>pc_*`` options of the database apply as well.
    A geometry update of finite sliding hands the solver the model's new Ã (:meth:`rebind`): the KSP, the operator
    and the work vectors stay. Call :meth:`destroy` when done.

    Args:
        model: The algebraic contact problem.
        settings: Solver settings (validated here).
        prefix: PETSc options prefix of the Newton matrix and its KSP.
        petsc_options: PETSc options (without prefix) for the KSP and its preconditioner.
    """

    def __init__(self, model: ContactModel, settings: SolverSettings | None = None, prefix: str = COMMAND_PREFIX,
                 petsc_options: dict[str, object] | None = None) -> None:
        settings = settings or SolverSettings()  # validated where it was constructed
        self.model = model
        self.settings = settings
        self.prefix = prefix
        self.comm = model.comm
        self.step = STEPS[settings.variant]()
        self.A = model.A
        self.timings: dict[str, float] = {}
        self._pressed_branch = model.coupling.holds_by_contact()  #: :data:`TOUCHING`

        t0 = time.perf_counter()
        self.gamma = (
            float(settings.gamma) if settings.gamma is not None
            else settings.gamma_scale * power_iteration(self.A, settings.power_iterations)
        )
        if settings.gamma is not None:
            check_fixed_gamma(self.gamma, power_iteration(self.A, settings.power_iterations))
        self.timings["gamma"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        self.rows = ContactRows(self.A, model.contact.global_dofs)
        self.cdofs = model.contact.local_dofs
        self.set_node_gamma(node_gamma(self.gamma, self.rows.diagonal_blocks(),
                                       settings.gamma_node_scale if settings.gamma is None else None))
        #: The preconditioner in use ("auto" resolved by the global number of unknowns).
        self.pc = resolve_pc(settings.pc, self.A.getSize()[0], self.comm.size,
                             model.V.mesh.topology.cell_type.name, settings.poisson_ratio)
        #: The Newton matrix: a shell (no copy of A) when the preconditioner does not read it.
        self.operator = NewtonOperator(self.A, self.rows, self.cdofs,
                                       settings.matrix_free and self.pc in MATRIX_FREE_PCS, prefix)
        self.M = self.operator.M
        self._user_options = dict(petsc_options or {})
        self._options_read, self._options_reported, self._linear_solved, self.report_unread = set(), False, False, True
        for key, value in self._user_options.items():
            if not isinstance(key, str) or not key or key.startswith("-"):
                raise InputError(f"petsc_options: key {key!r} must be an option name without '-' and prefix, "
                                 "e.g. 'ksp_monitor'")
            check_option_value(f"{prefix}{key}", value)
        #: Pairs with GAMG: the preconditioner in the physical displacement (:mod:`.physical_preconditioner`).
        self._physical: PhysicalGAMG | None = None
        self._create_ksp()
        #: The fixed forcing term: settings.tol, or the options' ksp_rtol.
        self.tol = float(self.ksp.getTolerances()[0])
        #: pc = "auto": the preconditioners that take over, in turn, when a linear solve stagnates (:meth:`_escalate`).
        self._ladder = auto_ladder(self.pc, self.A.getSize()[0]) if settings.pc == "auto" else []
        #: Every change of preconditioner in this solver's life: Newton step, from, to, Krylov iterations spent.
        self.pc_history: list[dict[str, object]] = []
        self._blocks: tuple[Array, Array] | None = None  # the contact-row blocks of the current Newton matrix
        self._max_it = int(self.ksp.getTolerances()[3])
        self._steps = 0
        self._limited = 0  # consecutive Newton steps whose linear solve reached ksp_max_it
        self.u, self.r = self.A.createVecs()
        self.b, self.x = self.A.createVecs()
        self.Adu, self.w = self.A.createVecs()
        for name in ("u", "r", "b", "x", "Adu", "w"):
            getattr(self, name).setOptionsPrefix(f"{prefix}{name}_")
        self.timings["setup"] = time.perf_counter() - t0

    def rebind(self) -> None:
        """Take over the model's new Ã and contact nodes after a geometry update of finite sliding (collective).

        γ (from the new Ã), the contact rows, the per-node γᵢ and the Newton operator follow the model; the KSP,
        the shell operator and the work vectors stay. GAMG keeps its hierarchy, which does not depend on the geometry
        (on A for one body, on the physical stiffness B for pairs); every other preconditioner reads the Newton
        matrix and is set up again at the next linear solve anyway.
        """
        model, settings = self.model, self.settings
        t0 = time.perf_counter()
        self.A = model.A
        if settings.gamma is None:
            self.gamma = settings.gamma_scale * power_iteration(self.A, settings.power_iterations)
        self.timings["gamma"] = self.timings.get("gamma", 0.0) + time.perf_counter() - t0
        t0 = time.perf_counter()
        self.rows = ContactRows(self.A, model.contact.global_dofs)
        self.cdofs = model.contact.local_dofs
        self.set_node_gamma(node_gamma(self.gamma, self.rows.diagonal_blocks(),
                                       settings.gamma_node_scale if settings.gamma is None else None))
        self.operator.rebind(self.A, self.rows, self.cdofs)
        self.M = self.operator.M
        self._blocks = None
        self._rebind_ksp()
        self.timings["setup"] = self.timings.get("setup", 0.0) + time.perf_counter() - t0

    def set_node_gamma(self, values: Array) -> None:
        """Set the contact nodes' γᵢ (owned, shape (m,), each > 0; collective). With every γᵢ = γ the solver runs
        the paper's scalar formulas bit for bit; otherwise ‖ŷ‖ weighs the contact DOFs with 1 + γᵢ²."""
        values = np.array(values, dtype=np.float64).reshape(-1)
        if values.shape != (self.cdofs.shape[0],) or not np.all(np.isfinite(values) & (values > 0.0)):
            raise ValueError(f"node_gamma: {values.shape[0]} values, need {self.cdofs.shape[0]} finite ones > 0")
        #: γᵢ of each owned contact node (:mod:`fenics_coulomb.scd.node_gamma`), shape (m,).
        self.node_gamma: Array = values
        self._weights: Array | None = None
        if not self.comm.allreduce(bool(np.all(values == self.gamma)), op=MPI.LAND):
            self._weights = np.full(self.A.getLocalSize()[0], 1.0 + self.gamma**2)
            self._weights[self.cdofs] = (1.0 + values**2)[:, None]

    @property
    def frames(self) -> Array:
        """Frames R = (t₁, t₂, n) of the contact nodes (columns), shape (m, 3, 3), as currently placed."""
        return self.model.contact.frames

    # -- the approximation step -------------------------------------------------------------------
    def approximation_step(self, u: Array, r: Array) -> Iterate:
        """The approximation step (6.17) at u with residual r: d̂ = (γI + Q)⁻¹(γ u − r) and ‖ŷ‖.

        On contact node i the resolvent acts in the node's frame: (vⁱ, zⁱ) = J̃(Rᵢᵀ(γ uⁱ − rⁱ)) and
        eⁱ = uⁱ − Rᵢ vⁱ (Cartesian), see :mod:`fenics_coulomb.model.obstacles`.
        """
        gamma = self.node_gamma
        e = np.asarray(r / self.gamma, dtype=np.float64)
        uc = u[self.cdofs]
        w = to_local(self.frames, gamma[:, None] * uc - r[self.cdofs])
        held = self._held
        if held is not None:  # the law of the free components (model/frames.py, "held components")
            w[held[0]] = 0.0
        v, z = resolvent(w, gamma, self.model.friction)
        e[self.cdofs] = uc - to_global(self.frames, v)
        if held is not None:  # e = r/γᵢ on a held DOF, as on a DOF without contact
            nodes = np.flatnonzero(held[1].any(axis=1))
            rows = self.cdofs[nodes][held[1][nodes]]
            e[rows] = r[rows] / np.broadcast_to(gamma[nodes, None], (nodes.size, 3))[held[1][nodes]]
        return Iterate(u, r, e, v, z, self.norm(e))

    @property
    def _held(self) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]] | None:
        """(local, Cartesian) held components of the contact nodes, shape (m, 3) each, or None when no owned contact
        node has one (see "Contact nodes with held components" in :mod:`fenics_coulomb.model.frames`)."""
        cmap = self.model.contact
        if cmap.held is None or not np.any(cmap.held):
            return None
        return cmap.held_local, cmap.held

    def norm(self, e: Array) -> float:
        """‖ŷ‖ = ‖(Γ e, e)‖ over all ranks: √(1 + γ²)·‖e‖ for one γ, with γᵢ on the contact nodes' DOFs."""
        if self._weights is None:
            local = float(np.dot(e, e))
            return math.sqrt((1.0 + self.gamma**2) * self.comm.allreduce(local, op=MPI.SUM))
        local = float(np.dot(self._weights * e, e))
        return math.sqrt(self.comm.allreduce(local, op=MPI.SUM))

    def contact_norm(self, e: Array) -> float:
        """The contact nodes' part of ‖ŷ‖ = ‖(Γ e, e)‖: the same sum over their rows only (collective)."""
        ec = e[self.cdofs]
        weights = 1.0 + self.gamma**2 if self._weights is None else self._weights[self.cdofs]
        return math.sqrt(self.comm.allreduce(float(np.sum(weights * ec * ec)), op=MPI.SUM))

    def undeformed(self) -> Iterate:
        """The approximation step at ũ = 0 (u = d, residual A d − l = −l̃; no product with A): ŷ(ũ = 0), the
        residual of the undeformed body under the solve's loads and obstacles (collective)."""
        return self.approximation_step(np.array(self.model.shift.getArray(readonly=True), dtype=np.float64),
                                       -self.model.load.getArray(readonly=True))

    # -- the Newton direction ---------------------------------------------------------------------
    def forcing(self, history: list[float], eta: float, rule: StoppingRule, settled: bool) -> float:
        """The tolerance of the next linear solve: the fixed tol, or the Eisenstat–Walker term; at most
        ACCURACY_FORCING once the residual rule holds and the correction checks an accuracy (it is the estimate).
        The fixed rule's terminal tightening only when ``settled`` (every node's contact state that of the iterate
        before): a step cuts ‖ŷ‖ by its η only in the final states."""
        if rule.accuracy is not None and rule.satisfied(history[-1]):
            return min(self.tol, ACCURACY_FORCING)
        if not self.settings.adaptive_tol:
            return terminal_forcing(self.tol, history[-1], rule.threshold) if settled else self.tol
        return forcing_term(self.tol, history, eta, rule.threshold)

    def newton_direction(self, it: Iterate, eta: float) -> Direction:
        """Solve the Newton system of the variant at the approximation step of ``it`` to tolerance ``eta``."""
        t0 = time.perf_counter()
        sets = classify(it.v, it.z, self.model.friction)
        if self._pressed_branch:  # round-off above the obstacle touches it (a body meshed onto its floor: 1e-16)
            v = it.v.copy()
            v[v[:, 2] <= TOUCHING * self.model.mesh_size, 2] = 0.0
            sets = pressed_branch(classify(v, it.z, self.model.friction))
        left, right = self.step.rows(it.v, it.z, sets, self.model.friction, self.node_gamma)
        held = self._held
        if held is not None:  # held local components: the rows of a DOF without contact, (B, C) = (1, 0)
            node, k = np.nonzero(held[0])
            left[node, k, :] = 0.0
            left[node, :, k] = 0.0
            left[node, k, k] = 1.0
            right[node, k, :] = 0.0
            right[node, :, k] = 0.0
        # the blocks of the Cartesian contact map Qᵢ = Rᵢ Q̃(Rᵢᵀ · + sⁱ): Rᵢ Bⁱ Rᵢᵀ, Rᵢ Cⁱ Rᵢᵀ (see
        # fenics_coulomb.model.obstacles); the identity frame leaves them unchanged. The Newton operator (shell or
        # explicit rows) receives these rotated blocks.
        left, right = conjugate(self.frames, left), conjugate(self.frames, right)
        self.operator.update(left, right)
        self._blocks = (left, right)
        self.step.right_hand_side(self, it.e, left, right)
        self.timings["newton_matrix"] = self.timings.get("newton_matrix", 0.0) + time.perf_counter() - t0

        t0 = time.perf_counter()
        its = self._solve_newton_system(eta)
        while self._escalate():
            its += self._solve_newton_system(eta)
        self.timings["ksp"] = self.timings.get("ksp", 0.0) + time.perf_counter() - t0
        b_norm = self.b.norm()
        # GMRES with right preconditioning monitors the true (unpreconditioned) residual norm
        linear_residual = float(self.ksp.getResidualNorm()) / b_norm if b_norm > 0.0 else 0.0
        du = self.step.direction(self.x.getArray(readonly=True).copy(), it.e, left, self.cdofs)
        du[self.model.dirichlet_rows] = 0.0  # exact: the iterate already holds g there (see :meth:`start`)
        self._check_linear_solve(its, du)
        self._steps += 1
        return Direction(du, its, eta, linear_residual)

    # -- the line search --------------------------------------------------------------------------
    def line_search(self, it: Iterate, direction: Direction, k: int) -> tuple[float, Iterate]:
        """The non-monotone line search of Section 7 from ``it`` along Δu in iteration k + 1."""
        t0 = time.perf_counter()
        du = direction.du
        self.x.array[:] = du
        self.A.mult(self.x, self.Adu)
        Adu = self.Adu.getArray(readonly=True)
        bound = 1.0 + 0.1 / (k + 1)
        accepted = None
        for alpha in line_search_steps(self.settings.line_search_steps):
            trial = self.approximation_step(it.u + alpha * du, it.r + alpha * Adu)
            if trial.residual <= (bound - 0.1 * alpha) * it.residual:
                accepted = (alpha, trial)
                break
        self.timings["line_search"] = self.timings.get("line_search", 0.0) + time.perf_counter() - t0
        if accepted is None:
            raise SolverError(f"the line search found no acceptable step in iteration {k + 1}", "line_search")
        return accepted

    # -- the driver -------------------------------------------------------------------------------
    def start(self, initial_displacement: Array | None) -> Iterate:
        """The first iterate: u⁽⁰⁾ = ũ⁽⁰⁾ + d (ũ⁽⁰⁾ = 0 when None) and its approximation step.

        Its Dirichlet rows take the prescribed values g exactly; the rows are decoupled (identity rows and
        columns), so every Newton direction is zero there (:meth:`newton_direction`) and the boundary
        conditions hold bit for bit, not to the linear solver's round-off (GAMG leaves ~1e-15 in those rows).
        """
        u = np.array(self.model.shift.getArray(readonly=True), dtype=np.float64)
        if initial_displacement is not None:
            u += np.asarray(initial_displacement, dtype=np.float64)
        u[self.model.dirichlet_rows] = self.model.dirichlet_values
        self.u.array[:] = u
        self.A.mult(self.u, self.r)
        self.r.axpy(-1.0, self.model.rhs)
        return self.approximation_step(u, self.r.getArray(readonly=True).copy())

    def stopping_rule(self, first: Iterate, reduction: float | None = None) -> StoppingRule:
        """The stopping rule for a solve starting at ``first`` (:mod:`fenics_coulomb.scd.stopping`): relative to the
        residual of ũ = 0, whatever the start; ``reduction`` (default the settings' rtol) the reduction asked."""
        shift = self.model.shift.getArray(readonly=True)
        load = self.norm(self.model.load.getArray(readonly=True))
        zero = self.undeformed()
        rtol = self.settings.reduction if reduction is None else float(reduction)
        final = reduction is None or rtol <= self.settings.reduction  # not a loose intermediate solve
        return StoppingRule.create(rtol, self.settings.max_it, first.residual, zero.residual, self.norm(shift),
                                   self.norm(first.u - shift), load, self.gamma,
                                   self.settings.accuracy if final else None)

    def zero_if_converged(self, it: Iterate, rule: StoppingRule) -> Iterate:
        """ũ = 0 (u = d, residual −l̃) instead of ``it`` when the rule holds there: for a zero or tiny load ũ = 0
        is the solution, which the iteration from ũ⁽⁰⁾ would only approach at the linear solves' rate."""
        shift = np.array(self.model.shift.getArray(readonly=True), dtype=np.float64)
        if rule.satisfied(it.residual) or not math.isfinite(it.residual) or not self.comm.allreduce(
                bool(np.any(it.u != shift)), op=MPI.LOR):
            return it
        zero = self.approximation_step(shift, -self.model.load.getArray(readonly=True))
        if not rule.satisfied(zero.residual):
            return it
        if self.comm.rank == 0:
            logger.info("ũ = 0 meets the stopping rule (|y| = %.3e): the load is below round-off", it.residual)
        return zero

    def solve(self, initial_displacement: Array | None = None, reduction: float | None = None) -> SolveResult:
        """Solve the contact problem from ũ⁽⁰⁾ (owned DOFs of the physical displacement; default 0) to the residual
        reduction ``reduction`` (default the settings' rtol; finite sliding solves intermediate geometries looser).

        Raises:
            SolverError: when the method does not converge; ``error.result`` holds the last iterate.
        """
        t_start = time.perf_counter()
        self._steps = 0
        self._limited = 0
        first = self.start(initial_displacement)
        rule = self.stopping_rule(first, reduction)
        it = self.zero_if_converged(first, rule)
        history = [it.residual]
        records: list[IterationRecord] = []
        eta = self.tol
        friction, settled = self.model.friction, True  # the first step as the fixed rule has it
        states = contact_states(classify(it.v, it.z, friction), friction)
        lo, hi = self._node_gamma_range()  # collective
        if self.comm.rank == 0:
            gammas = f"{self.gamma:.4g}" if lo == hi == self.gamma else f"{self.gamma:.4g} (contact {lo:.3g}-{hi:.3g})"
            logger.info("SCD semismooth* Newton (%s, tol=%g, pc=%s, gamma=%s): |y0| = %.3e, stops at |y| <= %.3e "
                        "(rtol %g x |y(u = 0)|: |y|/|y0| <= %.3e)", self.step.name, self.tol, self.pc, gammas,
                        it.residual, rule.threshold, rule.rtol,
                        rule.threshold / it.residual if it.residual > 0 else 0.0)
        try:
            correction = 0.0 if it is not first else None  # ũ = 0 for a load below round-off: exact
            while not rule.converged(it.residual, correction):
                rule.check(len(records), it.residual, correction)
                eta = self.forcing(history, eta, rule, settled)
                direction = self.newton_direction(it, eta)
                alpha, it = self.line_search(it, direction, len(records))
                if rule.accuracy is not None:
                    correction = self.correction(it, direction.du) if alpha == 1.0 else math.inf
                history.append(it.residual)
                previous, states = states, contact_states(classify(it.v, it.z, friction), friction)
                settled = bool(self.comm.allreduce(np.array_equal(previous, states), op=MPI.LAND))
                records.append(self.record(len(records) + 1, it, alpha, direction, rule, states))
        except SolverError as err:
            err.result = self.result(it, history, records, False, err.reason, t_start, rule=rule)
            raise
        return self.result(it, history, records, True, "converged", t_start, rule=rule)

    def correction(self, it: Iterate, du: Array) -> float:
        """‖M Δz‖ / ‖M z‖ of the Newton correction ``du`` that led to ``it``: its relative size in the physical
        displacement (collective)."""
        step = self.model.physical(du)
        u = self.model.physical(it.u - self.model.shift.getArray(readonly=True))
        size = self.comm.allreduce(np.array([float(np.dot(step, step)), float(np.dot(u, u))]), op=MPI.SUM)
        return math.sqrt(size[0] / size[1]) if size[1] > 0.0 else (0.0 if size[0] == 0.0 else math.inf)

    def record(self, k: int, it: Iterate, alpha: float, direction: Direction, rule: StoppingRule,
               states: npt.NDArray[np.int8]) -> IterationRecord:
        """The record of iteration k (logged on rank 0); ``states`` the contact states at ``it``."""
        counts = global_state_counts(self.comm, states)
        if self.comm.rank == 0:
            logger.info("it %3d  |y|/|y0| = %.3e  step %.4g  krylov %4d  open/stick/slip %d/%d/%d",
                        k, it.residual / rule.initial, alpha, direction.krylov_iterations,
                        counts["open"], counts["stick"], counts["slip"])
        return IterationRecord(k, it.residual, alpha, direction.krylov_iterations, counts["open"],
                               counts["stick"], counts["slip"], direction.forcing, direction.linear_residual)

    def result(self, it: Iterate, history: list[float], records: list[IterationRecord], converged: bool,
               reason: str, t_start: float, linear: bool = False, rule: StoppingRule | None = None) -> SolveResult:
        """The result at iterate ``it`` (collective: global counts); ``rule`` the stopping rule of the solve."""
        self.report_unread_options()
        friction = self.model.friction
        sets = classify(it.v, it.z, friction)
        states = contact_states(sets, friction)
        self.timings["total"] = time.perf_counter() - t_start
        return SolveResult(
            u=it.u.copy(),
            displacement=it.u - self.model.shift.getArray(readonly=True),
            converged=converged,
            reason=reason,
            iterations=len(records),
            krylov_iterations=sum(rec.krylov_iterations for rec in records),
            residual_history=list(history),
            records=list(records),
            sets=sets,
            states=states,
            normal_force=-it.z[:, 2].copy(),
            tangential_force=-it.z[:, :2].copy(),
            contact_force=-to_global(self.frames, it.z),
            gap=it.v[:, 2].copy(),
            gamma=self.gamma,
            node_gamma=self._node_gamma_range(),
            rtol=rule.rtol if rule is not None else self.settings.reduction,
            target=rule.threshold if rule is not None else 0.0,
            timings=dict(self.timings),
            pc=self.pc,
            pc_history=[dict(h) for h in self.pc_history],
            n=self.model.n,
            p=self.model.p,
            counts=global_state_counts(self.comm, states),
            linear=linear,
        )

    def _node_gamma_range(self) -> tuple[float, float]:
        """(min, max) of the contact nodes' γᵢ over all ranks ((γ, γ) without contact nodes)."""
        lo = self.comm.allreduce(float(np.min(self.node_gamma, initial=self.gamma)), op=MPI.MIN)
        hi = self.comm.allreduce(float(np.max(self.node_gamma, initial=0.0)), op=MPI.MAX)
        return lo, max(hi, lo)

    def solve_linear(self) -> SolveResult:
        """Solve A ũ = l̃ once (no contact possible): the Newton matrix is A and the KSP runs to the reduction."""
        model = self.model
        t0 = time.perf_counter()
        self.operator.set_stiffness()
        self._blocks = None
        its = self._solve_linear_system()
        while self._escalate():
            its += self._solve_linear_system()
        reason = int(self.ksp.getConvergedReason())
        b_norm = model.load.norm()
        linear_residual = float(self.ksp.getResidualNorm()) / b_norm if b_norm > 0.0 else 0.0
        self.timings["ksp"] = self.timings.get("ksp", 0.0) + time.perf_counter() - t0
        u = self.x.getArray(readonly=True).copy() + model.shift.getArray(readonly=True)
        u[model.dirichlet_rows] = model.dirichlet_values  # exactly, not to the KSP's round-off
        self.u.array[:] = u
        self.A.mult(self.u, self.r)
        self.r.axpy(-1.0, model.rhs)
        it = self.approximation_step(u, self.r.getArray(readonly=True).copy())
        res0 = math.sqrt(1.0 + self.gamma**2) * b_norm / self.gamma
        converged = reason > 0
        record = IterationRecord(1, it.residual, 1.0, its, 0, 0, 0, self.settings.reduction, linear_residual)
        return self.result(it, [res0, it.residual], [record], converged,
                           "converged" if converged else f"ksp_reason_{reason}", t0, linear=True)

    def is_separated(self, result: SolveResult) -> bool:
        """True on all ranks if no contact node of ``result`` touches or penetrates the obstacle."""
        gap = to_local(self.frames, result.displacement[self.cdofs])[:, 2] + self.model.contact.gap
        return bool(self.comm.allreduce(bool(np.all(gap > 0.0)), op=MPI.LAND))

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        self.operator.destroy()
        for obj in (self.ksp, self.u, self.r, self.b, self.x, self.Adu, self.w):
            obj.destroy()
        if self._nullspace is not None:
            self._nullspace.destroy()
        if self._physical is not None:
            self._physical.destroy()
