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

Per-node γ
----------
The paper takes one γ ≈ λ_max(A) (we scale it by ``gamma_scale`` = 0.01, docs/table2). On a graded or distorted
mesh λ_max(A) comes from elements far from the contact (or from one sliver), far above the stiffness of the small
elements at the contact: the stick rows γ I of the Newton matrix then dwarf the rows of A that GAMG (built on A)
approximates, and GMRES stagnates (the Hertz block of benchmarks/hertz.py, 19 542 unknowns: γ = 53.6
against λ_max(Aᵢᵢ) = 14–28 at the contact: 2000 GMRES iterations per step; with γ ≤ 0.5·λ_max(Aᵢᵢ): 20 Newton /
112 Krylov). So every contact node i gets its own

    γᵢ = min(γ, κ·λ_max(Aᵢᵢ)),   κ = ``gamma_node_scale`` (0.5),  Aᵢᵢ the node's 3×3 diagonal block of A,

(:func:`node_gamma`) and γ stays on the other DOFs. On the Section 7 cuboid γ/λ_max(Aᵢᵢ) <= 0.123 at every contact
node (lev 1-7, d1-d3), so γᵢ = γ there and the paper's formulas run bit for bit.

Why this is still the paper's method. Let Γ = diag(γ_j) over all DOFs (γᵢ on the three of contact node i, γ on
the rest) and D = Γ^{1/2}. In u' = D u the GE 0 ∈ A u − l + Q(u) reads 0 ∈ A' u' − l' + Q'(u') with
A' = D⁻¹AD⁻¹ (SPD), l' = D⁻¹l and Q'(u') = D⁻¹Q(D⁻¹u'). On contact node i, Q'ᵢ(v') = γᵢ^{−1/2} Rᵢ Q̃(Rᵢᵀv'/γᵢ^{1/2})
= Rᵢ Q̃(Rᵢᵀv'), because Q̃ is invariant under positive scalings of its argument and of its values
(N_{R+}(c w₃) = N_{R+}(w₃), ∂‖c w₁₂‖ = ∂‖w₁₂‖, and c·Q̃(w) = Q̃(w): ϑ ranges over a cone and the tangential
part is linear in ϑ) — Q' is a contact map of the same kind, and everything the paper proves holds for the
scaled problem with the scalar γ' = 1. Its approximation step maps back to d̂ = D⁻¹(I + Q')⁻¹(u' − r') =
(Γ + Q)⁻¹(Γ u − r) (v' = (I + Q')⁻¹(w') ⇔ D w' ∈ Γ D⁻¹v' + Q(D⁻¹v')), i.e. the closed-form resolvent with γᵢ on
node i and e = r/γ elsewhere; ŷ = (Γ e, e). Its Newton step (5.4) is the step of :mod:`fenics_coulomb.scd.steps`
with every node's blocks and rows taken with its own γᵢ and ŷ₁ = Γ e (checked against the paper's step on the
scaled problem in tests/scd/test_node_gamma.py). Under exact solves the direction depends on γᵢ only through the
approximation step and ŷ₁ (in (5.4) a sliding row's γ·b/a = t/s and a sticking row's γ cancel); the rows' γᵢ
set the scale of the contact rows against A's, which is what the preconditioner built on A sees. ‖ŷ‖ is
‖(Γe, e)‖ = (Σ_j (1 + γ_j²) e_j²)^{1/2}, the paper's √(1 + γ²)‖e‖ when all γᵢ = γ; the local convergence does
not depend on the norm, the line search and the stopping rule use this one.

Size: about 650 lines, a fifth of them the derivations (per-node γ, the approximation step); the rest is the one
driver (KSP life cycle, escalation, Newton loop), whose paper kernels are modules of their own.
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.frames import conjugate, to_global, to_local
from fenics_coulomb.scd.contact_rows import ContactRows
from fenics_coulomb.scd.forcing import forcing_term, terminal_forcing
from fenics_coulomb.scd.galerkin import GalerkinCoarsening
from fenics_coulomb.scd.newton_operator import MATRIX_FREE_PCS, NewtonOperator
from fenics_coulomb.scd.power_method import power_iteration
from fenics_coulomb.scd.preconditioner import (
    AUTO_STALL_ITS,
    DETERMINISTIC_PTAP,
    DETERMINISTIC_PTAP_MIN_RANKS,
    auto_ladder,
    check_option_value,
    create_ksp,
    default_options,
    resolve_pc,
)
from fenics_coulomb.scd.records import IterationRecord, SolveResult, global_state_counts
from fenics_coulomb.scd.resolvent import classify, contact_states, resolvent
from fenics_coulomb.scd.steps import STEPS
from fenics_coulomb.scd.stopping import StoppingRule
from fenics_coulomb.settings import COMMAND_PREFIX, SolverSettings

__all__ = ["KSP_LIMIT_STEPS", "HIERARCHY_REFRESH", "node_gamma", "line_search_steps", "Iterate", "Direction",
           "SCDNewtonSolver"]

logger = logging.getLogger(__name__)

#: A solve stops (SolverError "ksp_limit", exit 3) when the linear solves of this many consecutive Newton steps
#: reach ksp_max_it without their tolerance: one inexact direction is used (with a warning), but directions
#: that stay that inexact do not converge, they only cost ksp_max_it iterations per step (GAMG with
#: --gamma-scale 1, d3/L2 lev 8: 2000 GMRES iterations in every step, 780 s for 9 steps and still running).
KSP_LIMIT_STEPS = 3
#: Finite sliding keeps GAMG's hierarchy across geometry updates (it was built on the Ã of an earlier geometry,
#: which differs from the new one in the contact coupling only) until a linear solve needs more than this many
#: times the Krylov iterations per decade of the first solve on it; then the next update sets it up on the new Ã
#: (:meth:`SCDNewtonSolver.rebind`). slide_off, 1 rank: a set-up at every update 205 Krylov iterations in 2.0 s
#: CPU, never again 488 in 1.14 s, factor 1.5: 226 in 1.16 s, 2: 264 in 1.01 s, 3: 285 in 1.16 s (loaded machine).
HIERARCHY_REFRESH = 2.0

Array = npt.NDArray[np.float64]


def node_gamma(gamma: float, blocks: Array, scale: float | None) -> Array:
    """γᵢ = min(γ, scale·λ_max(Aᵢᵢ)) of each contact node from A's 3×3 diagonal blocks Aᵢᵢ (shape (m, 3, 3));
    γ everywhere when ``scale`` is None (see "Per-node γ" in the module docstring)."""
    m = blocks.shape[0]
    if scale is None or m == 0:
        return np.full(m, gamma)
    local = np.linalg.eigvalsh(0.5 * (blocks + np.swapaxes(blocks, 1, 2)))[:, -1]
    return np.minimum(gamma, scale * local)


def line_search_steps(count: int) -> Iterator[float]:
    """The step lengths of Section 7: 1, 1/2, 1/4, 1/8, 1/32, 1/128, 0.1/128, 0.01/128, ..."""
    head = (1.0, 0.5, 0.25, 0.125, 1.0 / 32.0, 1.0 / 128.0)
    for i in range(count):
        yield head[i] if i < len(head) else (1.0 / 128.0) * 0.1 ** (i - len(head) + 1)


@dataclass
class Iterate:
    """An iterate u with its residual r = A u − l and its approximation step (e = u − d̂, v = d̂ and z on the
    contact nodes, ‖ŷ‖)."""

    u: Array
    r: Array
    e: Array
    v: Array
    z: Array
    residual: float


@dataclass
class Direction:
    """A Newton direction Δu with the Krylov iterations, forcing term and linear residual of its solve."""

    du: Array
    krylov_iterations: int
    forcing: float
    linear_residual: float


class SCDNewtonSolver:
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

        t0 = time.perf_counter()
        self.gamma = (
            float(settings.gamma) if settings.gamma is not None
            else settings.gamma_scale * power_iteration(self.A, settings.power_iterations)
        )
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
        for key, value in self._user_options.items():
            if not isinstance(key, str) or not key or key.startswith("-"):
                raise InputError(f"petsc_options: key {key!r} must be an option name without '-' and prefix, "
                                 "e.g. 'ksp_monitor'")
            check_option_value(f"{prefix}{key}", value)
        self._galerkin: GalerkinCoarsening | None = None
        #: Krylov iterations per decade of the linear solves since GAMG's hierarchy was set up (the first: fresh).
        self._hierarchy_rates: list[float] = []
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
        the shell operator and the work vectors stay. GAMG on A keeps its hierarchy (:meth:`_refresh_hierarchy`
        decides when to build it again on the current Ã); every other preconditioner reads the Newton matrix and is
        set up again at the next linear solve anyway.
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
        if self._galerkin is not None or self.pc != "gamg":
            # the Galerkin coarse products and the preconditioners of M start from a KSP of their own
            self.ksp.destroy()
            if self._nullspace is not None:
                self._nullspace.destroy()
            self._create_ksp()
            self.ksp.setTolerances(rtol=self.tol, max_it=self._max_it)
        elif self._refresh_hierarchy():
            self._hierarchy_rates = []
            if self._nullspace is not None:
                self._nullspace.destroy()
            self._nullspace = self.model.near_nullspace()
            self.A.setNearNullSpace(self._nullspace)
            self.ksp.getPC().setReusePreconditioner(False)
            self.ksp.setOperators(self.M, self.A)  # GAMG is set up on the new Ã at the next linear solve
            if self.comm.rank == 0:
                logger.debug("finite sliding: GAMG's hierarchy set up again on the new stiffness")
        else:  # the hierarchy of an earlier Ã (kept alive by the KSP, or the same Mat with new values)
            self.ksp.getPC().setReusePreconditioner(True)
        self.timings["setup"] = self.timings.get("setup", 0.0) + time.perf_counter() - t0

    def _refresh_hierarchy(self) -> bool:
        """Whether GAMG's hierarchy is to be built again on the current Ã at a geometry update: when no linear
        solve has used the one built last (its set-up costs nothing yet), or when a linear solve since needed more
        than HIERARCHY_REFRESH times the Krylov iterations per decade of reduction of the first solve after the
        set-up (the hierarchy of an earlier geometry no longer preconditions the new one well)."""
        rates = self._hierarchy_rates
        return not rates or max(rates) > HIERARCHY_REFRESH * max(rates[0], 1.0)

    def _record_rate(self, its: int, rtol: float) -> None:
        """Keep the Krylov iterations per decade of reduction of a linear solve (:meth:`_refresh_hierarchy`)."""
        decades = max(1.0, -math.log10(rtol)) if rtol > 0.0 else 16.0
        self._hierarchy_rates.append(its / decades)

    def set_node_gamma(self, values: Array) -> None:
        """Set the contact nodes' γᵢ (owned, shape (m,), each > 0; collective). With every γᵢ = γ the solver runs
        the paper's scalar formulas bit for bit; otherwise ‖ŷ‖ weighs the contact DOFs with 1 + γᵢ²."""
        values = np.array(values, dtype=np.float64).reshape(-1)
        if values.shape != (self.cdofs.shape[0],) or not np.all(np.isfinite(values) & (values > 0.0)):
            raise ValueError(f"node_gamma: {values.shape[0]} values, need {self.cdofs.shape[0]} finite ones > 0")
        #: γᵢ of each owned contact node (see "Per-node γ" in the module docstring), shape (m,).
        self.node_gamma = values
        self._weights: Array | None = None
        if not self.comm.allreduce(bool(np.all(values == self.gamma)), op=MPI.LAND):
            self._weights = np.full(self.A.getLocalSize()[0], 1.0 + self.gamma**2)
            self._weights[self.cdofs] = (1.0 + values**2)[:, None]

    @property
    def frames(self) -> Array:
        """Frames R = (t₁, t₂, n) of the contact nodes (columns), shape (m, 3, 3), as currently placed."""
        return self.model.contact.frames

    def _create_ksp(self) -> None:
        """Create the KSP of the Newton matrix for ``self.pc`` under the solver's prefix and options."""
        settings = self.settings
        self._hierarchy_rates = []
        self._default_options = {k: v for k, v in default_options(self.pc, self.model.V.mesh.topology.cell_type.name,
                                                                  settings.poisson_ratio).items()
                                 if k not in self._user_options}
        self.ksp, self._nullspace = create_ksp(self.comm, self.M, self.A, self.model.V, self.pc, self.prefix,
                                               settings.tol, settings.gmres_restart, settings.ksp_max_it,
                                               self.model.near_nullspace)
        with self.petsc_options():
            self.ksp.setFromOptions()
        if self._galerkin is not None:
            self._galerkin.destroy()
            self._galerkin = None
        if settings.galerkin_coarse and settings.variant == "4a" and self.pc == "gamg" \
                and self.ksp.getPC().getType() == "gamg":
            self._galerkin = GalerkinCoarsening(self.A, self.rows)

    def _escalate(self) -> bool:
        """After a stagnated linear solve under pc = "auto", hand the rest of the solve to the next preconditioner of
        the ladder (:func:`~fenics_coulomb.scd.preconditioner.auto_ladder`); True if it did (collective).

        The new KSP gets the same Newton matrix (an explicit copy of A with the current contact rows when the new
        preconditioner reads its entries and the old operator was matrix-free). The switch is logged, kept in
        :attr:`pc_history` and reported in the result; the user's ksp_max_it applies to the last stage.
        """
        reason = int(self.ksp.getConvergedReason())
        if not self._ladder or reason > 0:
            return False
        previous, self.pc = self.pc, self._ladder.pop(0)
        names = {v: k for k, v in vars(PETSc.KSP.ConvergedReason).items() if isinstance(v, int)}
        spent = int(self.ksp.getIterationNumber())
        self.pc_history.append({"newton_step": self._steps + 1, "from": previous, "to": self.pc,
                                "krylov_iterations": spent, "reason": names.get(reason, str(reason))})
        if self.comm.rank == 0:
            logger.warning("pc auto: %s-GMRES stagnated in Newton step %d (%d iterations without tol=%g, %s); %s takes "
                           "over for the rest of the solve", previous, self._steps + 1, spent,
                           self.ksp.getTolerances()[0], names.get(reason, reason), self.pc)
        self.ksp.destroy()
        if self._nullspace is not None:
            self._nullspace.destroy()
        if self.operator.matrix_free and self.pc not in MATRIX_FREE_PCS:
            self.operator.destroy()
            self.operator = NewtonOperator(self.A, self.rows, self.cdofs, False, self.prefix)
            self.M = self.operator.M
            if self._blocks is None:
                self.operator.set_stiffness()
            else:
                self.operator.update(*self._blocks)
        self._create_ksp()
        self.ksp.setTolerances(rtol=self.tol, max_it=self._max_it)
        return True

    @contextlib.contextmanager
    def petsc_options(self) -> Iterator[None]:
        """Put the solver's options into PETSc's database under its prefix for the duration (options the
        database already holds win over the solver's defaults), then restore the database. With GAMG on
        three or more ranks also the unprefixed :data:`~fenics_coulomb.scd.preconditioner.DETERMINISTIC_PTAP`
        (PETSc creates the Galerkin products without a prefix), unless the user gave it."""
        opts = PETSc.Options()
        added: dict[str, object] = {}
        for key, value in (*self._default_options.items(), *self._user_options.items()):
            name = f"{self.prefix}{key}"
            if key in self._user_options or not opts.hasName(name):
                added[name] = opts.getString(name) if opts.hasName(name) else None
                opts[name] = value
        key, value = DETERMINISTIC_PTAP  # unprefixed by necessity, scoped to the solver's own calls
        if self.pc in ("gamg", "gamg-newton") and self.comm.size >= DETERMINISTIC_PTAP_MIN_RANKS \
                and not opts.hasName(key):
            added[key] = None
            opts[key] = value
        try:
            yield
        finally:
            for name, previous in added.items():  # restore what the database held before
                if previous is None:
                    opts.delValue(name)
                else:
                    opts[name] = previous

    # -- the approximation step -------------------------------------------------------------------
    def approximation_step(self, u: Array, r: Array) -> Iterate:
        """The approximation step (6.17) at u with residual r: d̂ = (γI + Q)⁻¹(γ u − r) and ‖ŷ‖.

        On contact node i the resolvent acts in the node's frame: (vⁱ, zⁱ) = J̃(Rᵢᵀ(γ uⁱ − rⁱ)) and
        eⁱ = uⁱ − Rᵢ vⁱ (Cartesian), see :mod:`fenics_coulomb.model.obstacles`.
        """
        gamma = self.node_gamma
        e = r / self.gamma
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
    def forcing(self, history: list[float], eta: float, rule: StoppingRule) -> float:
        """The tolerance of the next linear solve: the fixed tol, or the Eisenstat–Walker term."""
        if not self.settings.adaptive_tol:
            return terminal_forcing(self.tol, history[-1], rule.threshold)
        return forcing_term(self.tol, history, eta, rule.threshold)

    def newton_direction(self, it: Iterate, eta: float) -> Direction:
        """Solve the Newton system of the variant at the approximation step of ``it`` to tolerance ``eta``."""
        t0 = time.perf_counter()
        sets = classify(it.v, it.z, self.model.friction)
        left, right = self.step.rows(it.v, it.z, sets, self.model.friction, self.node_gamma)
        held = self._held
        if held is not None:  # held local components: the rows of a DOF without contact, (B, C) = (1, 0)
            node, k = np.nonzero(held[0])
            left[node, k, :] = 0.0
            left[node, :, k] = 0.0
            left[node, k, k] = 1.0
            right[node, k, :] = 0.0
            right[node, :, k] = 0.0
        if self._galerkin is not None:  # rows scaled to A's diagonal for the Galerkin coarse operators
            left, right = self._galerkin.scale(left, right)
        # the blocks of the Cartesian contact map Qᵢ = Rᵢ Q̃(Rᵢᵀ · + sⁱ): Rᵢ Bⁱ Rᵢᵀ, Rᵢ Cⁱ Rᵢᵀ (see
        # fenics_coulomb.model.obstacles); the identity frame leaves them unchanged. The Newton operator (shell or
        # explicit rows) receives these rotated blocks.
        left, right = conjugate(self.frames, left), conjugate(self.frames, right)
        self.operator.update(left, right)
        self._blocks = (left, right)
        self.step.right_hand_side(self, it.e, left, right)
        self.timings["newton_matrix"] = self.timings.get("newton_matrix", 0.0) + time.perf_counter() - t0
        if self._galerkin is not None:
            self._coarsen(left, right)

        t0 = time.perf_counter()
        its = self._solve_newton_system(eta)
        while self._escalate():
            its += self._solve_newton_system(eta)
        self._record_rate(int(self.ksp.getIterationNumber()), eta)
        self.timings["ksp"] = self.timings.get("ksp", 0.0) + time.perf_counter() - t0
        b_norm = self.b.norm()
        # GMRES with right preconditioning monitors the true (unpreconditioned) residual norm
        linear_residual = float(self.ksp.getResidualNorm()) / b_norm if b_norm > 0.0 else 0.0
        du = self.step.direction(self.x.getArray(readonly=True).copy(), it.e, left, self.cdofs)
        du[self.model.dirichlet_rows] = 0.0  # exact: the iterate already holds g there (see :meth:`start`)
        self._check_linear_solve(its, du)
        self._steps += 1
        return Direction(du, its, eta, linear_residual)

    def _coarsen(self, left: Array, right: Array) -> None:
        """Set GAMG up on A (the first time) and make its coarse operators the Galerkin products of the Newton
        matrix with the Cartesian contact-row blocks (left, right) (:mod:`fenics_coulomb.scd.galerkin`)."""
        t0 = time.perf_counter()
        with self.petsc_options():
            self.ksp.setUp()
            self._galerkin.update(self.ksp.getPC(), left, right)
        self.timings["galerkin"] = self.timings.get("galerkin", 0.0) + time.perf_counter() - t0

    def _set_tolerance(self, rtol: float) -> None:
        """Set the KSP's relative tolerance; under pc = "auto" with a preconditioner left to escalate to also its
        iteration cap, AUTO_STALL_ITS per decade of reduction (at most the user's ksp_max_it)."""
        if self._ladder:
            decades = max(1.0, -math.log10(rtol)) if rtol > 0.0 else 16.0
            self.ksp.setTolerances(rtol=rtol, max_it=min(self._max_it, math.ceil(AUTO_STALL_ITS * decades)))
        else:
            self.ksp.setTolerances(rtol=rtol, max_it=self._max_it)

    def _solve_newton_system(self, eta: float) -> int:
        """One GMRES solve of the Newton system (right-hand side b, solution x) to tolerance eta; its iterations."""
        self._set_tolerance(eta)
        self.x.set(0.0)
        self._petsc_call(self.step.linear_solve, self.ksp, self.b, self.x)
        return int(self.ksp.getIterationNumber())

    def _petsc_call(self, call: Callable[..., object], *args: object) -> None:
        """Run a KSP call with the solver's options. An exception raised by a Python callback inside it — the
        matrix-free operator's mult, where a SIGINT or SIGTERM (:class:`~fenics_coulomb.errors.Interrupted`) arriving
        during a linear solve is raised — reaches PETSc only as an error code, and petsc4py keeps it as the cause
        of the PETSc.Error: it is raised again as itself (the interrupt must end the run, not count as a failed
        solve that the other ranks would wait on). Any other PETSc error is a failed linear solve (e.g. a
        -coulomb_ksp_type that cannot do what is asked of it)."""
        try:
            with self.petsc_options():
                call(*args)
        except PETSc.Error as err:
            if err.__cause__ is not None:
                raise err.__cause__ from None
            detail = str(err).strip().splitlines()
            raise SolverError(f"the linear solver failed: {detail[-1] if detail else err}", "ksp_breakdown") from None

    def _check_linear_solve(self, its: int, du: Array) -> None:
        """Raise SolverError for a failed or non-finite linear solve, or for the KSP_LIMIT_STEPS-th consecutive one
        that hit its iteration limit; warn for a single one (its inexact direction is used)."""
        reason = int(self.ksp.getConvergedReason())
        finite = self.comm.allreduce(bool(np.all(np.isfinite(du))), op=MPI.LAND)
        if (reason < 0 and reason != PETSc.KSP.ConvergedReason.DIVERGED_MAX_IT) or not finite:
            names = {v: k for k, v in vars(PETSc.KSP.ConvergedReason).items() if isinstance(v, int)}
            hint = ""
            if reason == PETSc.KSP.ConvergedReason.DIVERGED_BREAKDOWN and self.pc == "ilu":
                hint = ("; ILU-preconditioned GMRES stagnated, as it does for nearly incompressible materials "
                        "(nu -> 0.5): use --pc gamg or --pc lu")
            raise SolverError(
                f"the linear solver failed in Newton step {self._steps + 1}: {names.get(reason, reason)} after "
                f"{its} iterations{'' if finite else ', non-finite direction'}{hint}",
                "ksp_breakdown" if finite else "non_finite",
            )
        if reason != PETSc.KSP.ConvergedReason.DIVERGED_MAX_IT:
            self._limited = 0
            return
        self._limited += 1
        rtol = self.ksp.getTolerances()[0]
        if self._limited >= KSP_LIMIT_STEPS:
            lo, hi = self._node_gamma_range()
            raise SolverError(
                f"the linear solver (pc {self.pc}) reached its iteration limit ({its} iterations without tol={rtol:g}) "
                f"in {self._limited} consecutive Newton steps (up to step {self._steps + 1}): directions that inexact "
                f"do not converge; try {self._remedies()}, or a smaller --gamma-node-scale (now "
                f"{self.settings.gamma_node_scale}: gamma {self.gamma:.3g}, at the contact {lo:.3g}-{hi:.3g})",
                "ksp_limit",
            )
        if self.comm.rank == 0:
            logger.warning("KSP reached %d iterations without tol=%g; using the inexact direction", its, rtol)

    def _remedies(self) -> str:
        """The preconditioners to suggest after ``self.pc`` failed (the stages of pc = auto's ladder it skipped)."""
        if self.settings.pc != "auto":
            return "--pc auto (it hands a stagnating solve to GAMG, BoomerAMG and LU in turn)"
        return "--pc hypre or --pc lu (pc auto has no stage left)"

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
        return StoppingRule.create(rtol, self.settings.max_it, first.residual, zero.residual,
                                   self.norm(shift), self.norm(first.u - shift), load, self.gamma)

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
        it = self.start(initial_displacement)
        rule = self.stopping_rule(it, reduction)
        it = self.zero_if_converged(it, rule)
        history = [it.residual]
        records: list[IterationRecord] = []
        eta = self.tol
        lo, hi = self._node_gamma_range()  # collective
        if self.comm.rank == 0:
            gammas = f"{self.gamma:.4g}" if lo == hi == self.gamma else f"{self.gamma:.4g} (contact {lo:.3g}-{hi:.3g})"
            logger.info("SCD semismooth* Newton (%s, tol=%g, pc=%s, gamma=%s): |y0| = %.3e, stops at |y| <= %.3e "
                        "(rtol %g x |y(u = 0)|: |y|/|y0| <= %.3e)", self.step.name, self.tol, self.pc, gammas,
                        it.residual, rule.threshold, rule.rtol,
                        rule.threshold / it.residual if it.residual > 0 else 0.0)
        try:
            while not rule.satisfied(it.residual):
                rule.check(len(records), it.residual)
                eta = self.forcing(history, eta, rule)
                direction = self.newton_direction(it, eta)
                alpha, it = self.line_search(it, direction, len(records))
                history.append(it.residual)
                records.append(self.record(len(records) + 1, it, alpha, direction, rule))
        except SolverError as err:
            err.result = self.result(it, history, records, False, err.reason, t_start, rule=rule)
            raise
        return self.result(it, history, records, True, "converged", t_start, rule=rule)

    def record(self, k: int, it: Iterate, alpha: float, direction: Direction, rule: StoppingRule) -> IterationRecord:
        """The record of iteration k (logged on rank 0)."""
        counts = global_state_counts(self.comm, contact_states(classify(it.v, it.z, self.model.friction),
                                                               self.model.friction))
        if self.comm.rank == 0:
            logger.info("it %3d  |y|/|y0| = %.3e  step %.4g  krylov %4d  open/stick/slip %d/%d/%d",
                        k, it.residual / rule.initial, alpha, direction.krylov_iterations,
                        counts["open"], counts["stick"], counts["slip"])
        return IterationRecord(k, it.residual, alpha, direction.krylov_iterations, counts["open"],
                               counts["stick"], counts["slip"], direction.forcing, direction.linear_residual)

    def result(self, it: Iterate, history: list[float], records: list[IterationRecord], converged: bool,
               reason: str, t_start: float, linear: bool = False, rule: StoppingRule | None = None) -> SolveResult:
        """The result at iterate ``it`` (collective: global counts); ``rule`` the stopping rule of the solve."""
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
        if self._galerkin is not None:
            m = len(self.cdofs)
            self._coarsen(np.broadcast_to(np.eye(3), (m, 3, 3)).copy(), np.zeros((m, 3, 3)))
        its = self._solve_linear_system()
        while self._escalate():
            its += self._solve_linear_system()
        self._record_rate(int(self.ksp.getIterationNumber()), self.settings.reduction)
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

    def _solve_linear_system(self) -> int:
        """Solve A x = l̃ (the Newton matrix is A) to the reduction; its iterations."""
        self._set_tolerance(self.settings.reduction)
        self.x.set(0.0)
        self._petsc_call(self.ksp.solve, self.model.load, self.x)
        self.ksp.setTolerances(rtol=self.tol)
        return int(self.ksp.getIterationNumber())

    def is_separated(self, result: SolveResult) -> bool:
        """True on all ranks if no contact node of ``result`` touches or penetrates the obstacle."""
        gap = to_local(self.frames, result.displacement[self.cdofs])[:, 2] + self.model.contact.gap
        return bool(self.comm.allreduce(bool(np.all(gap > 0.0)), op=MPI.LAND))

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        self.operator.destroy()
        if self._galerkin is not None:
            self._galerkin.destroy()
        for obj in (self.ksp, self.u, self.r, self.b, self.x, self.Adu, self.w):
            obj.destroy()
        if self._nullspace is not None:
            self._nullspace.destroy()
