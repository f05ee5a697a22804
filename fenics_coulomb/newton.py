r"""The SCD semismooth* Newton method for the contact GE 0 ∈ A u − l + Q(u) (Sections 4, 5, 7).

One iteration k, from the iterate u = u⁽ᵏ⁾ with residual r = A u − l:

1. Approximation step (6.17): d̂ = (γI + Q)⁻¹(γ u − r), node-wise by the closed-form resolvent on the
   contact blocks and d̂ = u − r/γ on the other DOFs. With e := u − d̂ the residual of Section 7 is
   ŷ = (γ e, e), ‖ŷ‖ = √(1 + γ²)·‖e‖, and zⁱ = γ eⁱ − rⁱ ∈ Q̃(d̂ⁱ).
2. Newton step, either
   (4a) with rge(Y*, X*) ∈ S*Q(d̂, z) (blocks W*ⁱ, U*ⁱ on contact nodes, I and 0 elsewhere), system (5.4)
            (Y*ᵀ A + X*ᵀ) Δu = −(Y*ᵀ ŷ₁ + X*ᵀ ŷ₂),
   (4b) with rge(X, Y) ∈ SQ(d̂, z) (blocks Xⁱ, Yⁱ; I and 0 elsewhere)
            (A X + Y) p = A ŷ₂ − ŷ₁,   Δu = X p − ŷ₂,
        solved as the transposed system of Xᵀ A + Yᵀ, which has the row structure of (5.4), for the
        correction q = p − ŷ₂ (so that the inexact solve errs relative to Δu, not to p).
   Both matrices equal A outside the contact rows, so the Newton matrix is a copy of A whose contact
   rows are overwritten in place every iteration (same sparsity, no new allocation).
3. Non-monotone line search (Section 7): α is the first of 1, 1/2, 1/4, 1/8, 1/32, 1/128, 0.1/128,
   0.01/128, … with ‖ŷ(u + αΔu)‖ ≤ (1 − 0.1α + 0.1/(k + 1))‖ŷ(u)‖.

Stop when ‖ŷ‖ ≤ rtol·min(‖ŷ⁽⁰⁾‖, 100·‖ŷ(ũ = 0)‖) (the second term only binds for loads so small that the
start's gap misfit dominates ‖ŷ⁽⁰⁾‖), or when ‖ŷ‖ reaches the round-off level of the displacements (a start
that already solves the problem, e.g. zero load from ũ = 0, stops at once).
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

from fenics_coulomb.derivatives import s_blocks, sstar_blocks
from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.model import ContactModel, rigid_body_modes
from fenics_coulomb.resolvent import (
    OPEN,
    SLIP,
    STICK,
    classify,
    contact_states,
    resolvent,
)

logger = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: The reduction is measured relative to min(‖ŷ⁽⁰⁾‖, LOAD_GUARD·‖ŷ(ũ = 0)‖).
LOAD_GUARD = 100.0

PRECONDITIONERS = ("auto", "ilu", "gamg", "gamg-newton", "hypre", "lu", "jacobi", "none")
#: pc = "auto" (:func:`choose_preconditioner`) takes ILU (the paper's) only on hexahedral meshes below this many
#: unknowns on at most AUTO_ILU_MAX_RANKS ranks, GAMG everywhere else (docs/pc-auto; docs/ratio, docs/table2:
#: on the cuboid ILU is the faster up to lev 6 (27 744 unknowns), GAMG from lev 7 (79 488) on).
AUTO_GAMG_UNKNOWNS = 50_000
#: Block-Jacobi ILU's Krylov counts grow with the number of blocks (docs/pc-auto: d3/L2 lev 6, ν = 0.45:
#: 137 on 1 rank, 210 on 2; issue 17: lev 5 d2/L1 145 on 1 rank, 245 on 16) while GAMG's do not.
AUTO_ILU_MAX_RANKS = 2
#: GAMG's level smoother (Chebyshev) sweeps unless -<prefix>mg_levels_ksp_max_it says otherwise: one sweep
#: costs more Krylov iterations than PETSc's two but less time (lev 8: 8.4 s against 10.3 s; lev 10: 78 s
#: against 105 s).
GAMG_SMOOTHER_SWEEPS = 1
#: PETSc's default parallel triple product P^T A P (GAMG's Galerkin coarse matrices) adds the off-process
#: contributions in the order the messages arrive, so the coarse matrices, and every later bit, can differ
#: from run to run on 3 and more ranks (docs/partition). The "allatonce" algorithm sums them in a fixed order.
#: PETSc creates these product matrices without an options prefix, so the option can only be given
#: unprefixed: the solver sets it for the duration of its own KSP solves (where GAMG sets up) and removes
#: it afterwards; a value the user gave is left alone.
DETERMINISTIC_PTAP = ("matptap_via", "allatonce")
VARIANTS = ("4a", "4b")


def choose_preconditioner(n_global: int, n_ranks: int, cell_type: str) -> str:
    """The preconditioner that ``pc = "auto"`` stands for, chosen from the measurements in docs/pc-auto.

    GAMG (on A, with the rigid-body near-nullspace) kept every linear solve of every measured case within one
    GMRES restart cycle (at most 18 iterations per Newton step; hexahedral cuboid lev 2-7, tetrahedral hemisphere
    and roller 2 058-63 900 unknowns, ν 0.3 and 0.45, 1, 2 and 4 ranks). ILU's counts grow with the mesh size, the
    rank count and ν, and on tetrahedra they are several times larger from the smallest meshes on (roller, 7 617
    unknowns, ν = 0.45: up to 81 per step on 1 rank against GAMG's 17, and GAMG the faster) and exceed a restart
    cycle in 9 of the 58 measured groups, all tetrahedral (up to 466 per step); with ν = 0.3 and 25 000
    unknowns a tetrahedral hemisphere ran into the 2000-iteration limit with ILU (issue 11). So ILU is
    kept only where it is measured robust and at least as fast: hexahedra below AUTO_GAMG_UNKNOWNS unknowns on
    at most AUTO_ILU_MAX_RANKS ranks.

    Args:
        n_global: Global number of unknowns (>= 1).
        n_ranks: Number of MPI ranks (>= 1).
        cell_type: The mesh's cell type name (``"hexahedron"``, ``"tetrahedron"``, ...).

    Returns:
        ``"ilu"`` or ``"gamg"``.
    """
    if n_global < 1 or n_ranks < 1:
        raise ValueError(f"choose_preconditioner: n_global = {n_global}, n_ranks = {n_ranks} must be >= 1")
    if cell_type == "hexahedron" and n_global < AUTO_GAMG_UNKNOWNS and n_ranks <= AUTO_ILU_MAX_RANKS:
        return "ilu"
    return "gamg"


@dataclass
class SolverSettings:
    """Settings of the SCD semismooth* Newton solver.

    Attributes:
        variant: Newton step "4a" (S*Q, system (5.4)) or "4b" (SQ).
        tol: Relative unpreconditioned GMRES residual that ends each linear solve (paper: 0.1).
        rtol: Stop when ‖ŷ‖ <= rtol·min(‖ŷ⁽⁰⁾‖, 100·‖ŷ(ũ = 0)‖) (paper: rtol·‖ŷ⁽⁰⁾‖ with rtol = 1e-12). The
            default 1e-8 is chosen from docs/tradeoff: relative displacement errors ≤ 4e-7 with tol 0.1
            (≤ 8e-7 for every measured tol and pc), every contact state right, 13–41 % faster than 1e-12,
            and far below the discretization error (3.5e-3 at lev 6).
        max_iterations: Newton iterations before giving up.
        pc: Preconditioner: auto (:func:`choose_preconditioner`: ilu on hexahedra below AUTO_GAMG_UNKNOWNS
            unknowns on at most AUTO_ILU_MAX_RANKS ranks, gamg otherwise), ilu
            (block-Jacobi/ILU(0) in parallel, the paper's), gamg (smoothed aggregation on the stiffness matrix A
            with the rigid-body near-nullspace, set up once per solver and reused by every Newton step),
            gamg-newton (smoothed aggregation on the Newton matrix, set up every step), hypre, lu, jacobi,
            none.
        power_iterations: Power-method iterations on A for γ (paper: 5).
        gamma: Fixed γ instead of the power-method estimate.
        gamma_scale: Factor on the power-method estimate of λ_max(A). The paper uses γ ≈ λ_max(A)
            (factor 1); the default 0.01 is measured to need far fewer Newton iterations and to keep them
            nearly level-independent (docs/table2: 14–18 iterations for lev 4–7 against 20–82), while 0.001
            is too small (some cases stall).
        gmres_restart: GMRES restart length.
        ksp_max_it: Maximal Krylov iterations per Newton step.
        line_search_steps: Number of step lengths tried before the line search fails.
        adaptive_tol: Safeguarded Eisenstat–Walker forcing terms η_k <= tol (:func:`forcing_term`) instead
            of the fixed tol.
        prefix: PETSc options prefix of the Newton matrix and its KSP.
    """

    variant: str = "4a"
    tol: float = 0.1
    rtol: float = 1e-8
    max_iterations: int = 100
    pc: str = "auto"
    power_iterations: int = 5
    gamma: float | None = None
    gamma_scale: float = 0.01
    gmres_restart: int = 100
    ksp_max_it: int = 2000
    line_search_steps: int = 20
    adaptive_tol: bool = False
    prefix: str = "coulomb_"

    def validate(self) -> None:
        """Raise InputError naming the first bad value."""
        if self.variant not in VARIANTS:
            raise InputError(f"variant {self.variant!r}: choose one of {list(VARIANTS)}")
        if not (math.isfinite(self.tol) and 0.0 < self.tol < 1.0):
            raise InputError(f"tol = {self.tol!r}: the linear-solve tolerance must lie in (0, 1)")
        if not (math.isfinite(self.rtol) and 0.0 < self.rtol < 1.0):
            raise InputError(f"rtol = {self.rtol!r}: the residual reduction must lie in (0, 1)")
        if int(self.max_iterations) != self.max_iterations or self.max_iterations < 1:
            raise InputError(f"max_iterations = {self.max_iterations!r}: must be an integer >= 1")
        if self.pc not in PRECONDITIONERS:
            raise InputError(f"preconditioner {self.pc!r}: choose one of {list(PRECONDITIONERS)}")
        if self.variant == "4b" and self.pc == "hypre":
            raise InputError("preconditioner 'hypre' cannot apply its transpose, which variant 4b needs")
        if int(self.power_iterations) != self.power_iterations or self.power_iterations < 1:
            raise InputError(f"power_iterations = {self.power_iterations!r}: must be an integer >= 1")
        if self.gamma is not None and not (math.isfinite(self.gamma) and self.gamma > 0.0):
            raise InputError(f"gamma = {self.gamma!r}: must be finite and > 0")
        if not (math.isfinite(self.gamma_scale) and self.gamma_scale > 0.0):
            raise InputError(f"gamma_scale = {self.gamma_scale!r}: must be finite and > 0")
        for name in ("gmres_restart", "ksp_max_it", "line_search_steps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise InputError(f"{name} = {value!r}: must be an integer >= 1")


@dataclass
class IterationRecord:
    """One Newton iteration: residual after it, step length, Krylov iterations, contact states, the
    forcing term η of its linear solve and the relative unpreconditioned residual the solve reached."""

    iteration: int
    residual: float
    step_length: float
    krylov_iterations: int
    open: int
    stick: int
    slip: int
    forcing: float
    linear_residual: float


@dataclass
class SolveResult:
    """Outcome of :meth:`SCDNewtonSolver.solve` (arrays are this rank's owned entries).

    Attributes:
        u: Shifted displacement u = ũ + d (owned DOFs).
        displacement: Physical displacement ũ (owned DOFs).
        converged: Whether ‖ŷ‖ <= rtol·‖ŷ⁽⁰⁾‖ was reached.
        reason: "converged" or the cause of failure.
        iterations: Newton iterations taken.
        krylov_iterations: Total Krylov iterations.
        residual_history: ‖ŷ⁽ᵏ⁾‖, k = 0, 1, ...
        records: Per-iteration records (k >= 1).
        sets: Set of (6.9) per owned contact node at the final iterate.
        states: OPEN/STICK/SLIP per owned contact node.
        normal_force: Normal contact force λ = −ϑ >= 0 per owned contact node.
        tangential_force: Tangential contact force on the body, −g ∈ R² (opposite to slip).
        gap: Final gap u3 per owned contact node (from the approximation step, d̂3 >= 0).
        gamma: γ used in the approximation step.
        timings: Wall time per phase in seconds (this rank).
        pc: The preconditioner used (``auto`` resolved).
    """

    u: Array
    displacement: Array
    converged: bool
    reason: str
    iterations: int
    krylov_iterations: int
    residual_history: list[float]
    records: list[IterationRecord]
    sets: npt.NDArray[np.int8]
    states: npt.NDArray[np.int8]
    normal_force: Array
    tangential_force: Array
    gap: Array
    gamma: float
    timings: dict[str, float] = field(default_factory=dict)
    pc: str = ""

    def state_counts(self, comm: MPI.Comm) -> dict[str, int]:
        """Global number of open / stick / slip contact nodes."""
        local = np.array([np.sum(self.states == s) for s in (OPEN, STICK, SLIP)], dtype=np.int64)
        total = comm.allreduce(local, op=MPI.SUM)
        return {"open": int(total[0]), "stick": int(total[1]), "slip": int(total[2])}


def line_search_steps(count: int) -> Iterator[float]:
    """The step lengths of Section 7: 1, 1/2, 1/4, 1/8, 1/32, 1/128, 0.1/128, 0.01/128, ..."""
    head = (1.0, 0.5, 0.25, 0.125, 1.0 / 32.0, 1.0 / 128.0)
    for i in range(count):
        yield head[i] if i < len(head) else (1.0 / 128.0) * 0.1 ** (i - len(head) + 1)


def forcing_term(tol: float, history: list[float], eta_prev: float, target: float) -> float:
    r"""Safeguarded Eisenstat–Walker forcing term (choice 2, as in Kelley 1995, (6.18)–(6.20)).

    With the residual norms ‖ŷ⁽ᵏ⁾‖ in ``history`` (last = current) and the previous forcing term η₋:

        ηᴬ = 0.9·(‖ŷ⁽ᵏ⁾‖/‖ŷ⁽ᵏ⁻¹⁾‖)²,
        ηᴮ = min(tol, ηᴬ)                      if 0.9·η₋² <= 0.1,
             min(tol, max(ηᴬ, 0.9·η₋²))        otherwise (no sudden drop after one lucky step),
        η  = min(tol, max(ηᴮ, 0.5·target/‖ŷ⁽ᵏ⁾‖))   (no over-solving in the last step).

    The first step (one residual) takes ``tol``. ``tol`` is thus the largest forcing term: while the
    method localizes the contact states (residual ratios near 1) the solves are those of the fixed rule;
    once the residual falls fast they tighten, and the Newton method turns superlinear instead of
    converging linearly at the rate ``tol``.

    Args:
        tol: Largest forcing term (the fixed rule's tolerance).
        history: Residual norms so far.
        eta_prev: Forcing term of the previous step.
        target: The residual norm that ends the iteration.
    """
    if len(history) < 2 or history[-2] <= 0.0:
        return tol
    gamma = 0.9
    eta_a = gamma * (history[-1] / history[-2]) ** 2
    safeguard = gamma * eta_prev**2
    eta_b = min(tol, eta_a) if safeguard <= 0.1 else min(tol, max(eta_a, safeguard))
    guard = 0.5 * target / history[-1] if history[-1] > 0.0 else tol
    return float(min(tol, max(eta_b, guard)))


def power_iteration(A: PETSc.Mat, iterations: int) -> float:
    """Estimate the largest eigenvalue of the SPD matrix A by the power method.

    The start vector depends only on the global index (x_j = 1.5 + sin(j)), so the estimate is the
    same for any number of ranks.
    """
    x, y = A.createVecs()
    lo, hi = x.getOwnershipRange()
    x.array[:] = 1.5 + np.sin(np.arange(lo, hi, dtype=np.float64))
    x.scale(1.0 / x.norm())
    estimate = 0.0
    for _ in range(iterations):
        A.mult(x, y)
        estimate = y.norm()
        y.scale(1.0 / estimate)
        x, y = y, x
    x.destroy()
    y.destroy()
    return float(estimate)


class ContactRows:
    """Contact rows of A as per-node 3-row blocks, for in-place updates of the Newton matrix.

    The three rows of a node share one column pattern (DOLFINx assembles blocked, bs = 3), so the new
    rows Bⁱ Aⁱ + Cⁱ (Bⁱ, Cⁱ ∈ R^{3×3}, Aⁱ the node's 3 rows, Cⁱ acting on the node's own columns) are a
    batched 3×3 product over the stored entries, computed with NumPy without a loop over nodes.
    """

    def __init__(self, A: PETSc.Mat, global_dofs: npt.NDArray[np.int64]) -> None:
        comm = A.getComm()
        rows = np.ascontiguousarray(global_dofs.ravel(), dtype=PETSc.IntType)
        self.rows = rows
        c0, c1 = A.getOwnershipRangeColumn()
        isrow = PETSc.IS().createGeneral(rows, comm=comm)
        iscol = PETSc.IS().createStride(c1 - c0, first=c0, step=1, comm=comm)
        sub = A.createSubMatrix(isrow, iscol)
        indptr, indices, data = sub.getValuesCSR()
        sub.destroy()
        isrow.destroy()
        iscol.destroy()
        self.indptr = np.asarray(indptr, dtype=PETSc.IntType)
        self.indices = np.asarray(indices, dtype=PETSc.IntType)
        m = global_dofs.shape[0]
        self.num_nodes = m
        lengths = np.diff(self.indptr).reshape(m, 3) if m else np.zeros((0, 3), dtype=PETSc.IntType)
        if not np.all(lengths == lengths[:, :1]):
            raise RuntimeError("contact rows of a node do not share their sparsity pattern")
        nnz = lengths[:, 0].astype(np.int64)
        self.node_of_entry = np.repeat(np.arange(m), nnz)
        first = np.cumsum(nnz) - nnz
        position = np.arange(int(nnz.sum())) - np.repeat(first, nnz)
        starts = self.indptr[:-1].reshape(m, 3) if m else np.zeros((0, 3), dtype=PETSc.IntType)
        # positions of row b of each node's block in the CSR arrays: shape (3, entries)
        self.positions = np.stack([np.repeat(starts[:, b], nnz) + position for b in range(3)])
        cols = self.indices[self.positions]
        if not np.all(cols == cols[:1]):
            raise RuntimeError("contact rows of a node do not share their column order")
        self.values = np.ascontiguousarray(np.asarray(data)[self.positions])  # (3, entries)
        # where each node's own three columns sit among its entries
        own = cols[0] // 3 == global_dofs[self.node_of_entry, 0] // 3
        entry = np.flatnonzero(own)
        comp = cols[0][entry] % 3
        diag = np.full((m, 3), -1, dtype=np.int64)
        diag[self.node_of_entry[entry], comp] = entry
        if np.any(diag < 0):
            raise RuntimeError("a contact row misses its diagonal block")
        self.diagonal_entries = diag.ravel()
        self._out = np.empty(len(self.indices), dtype=PETSc.ScalarType)

    def combine(self, left: Array, right: Array) -> Array:
        """CSR values of the rows Bⁱ Aⁱ + Cⁱ for left = (Bⁱ), right = (Cⁱ), shapes (m, 3, 3)."""
        new = np.einsum("eab,be->ae", left[self.node_of_entry], self.values)
        # right[i, a, c] goes to row a, column (node i, component c)
        new[:, self.diagonal_entries] += np.moveaxis(right, 2, 1).reshape(-1, 3).T
        out = self._out
        for b in range(3):
            out[self.positions[b]] = new[b]
        return out

    def update(self, M: PETSc.Mat, left: Array, right: Array) -> None:
        """Overwrite the contact rows of M by Bⁱ Aⁱ + Cⁱ and assemble M (collective)."""
        values = self.combine(left, right)
        M.setValuesIJV(self.indptr, self.indices, values, rowmap=self.rows,
                       addv=PETSc.InsertMode.INSERT_VALUES)
        M.assemble()


class SCDNewtonSolver:
    """SCD semismooth* Newton solver for a :class:`ContactModel`; owns the Newton matrix and its KSP.

    The Newton matrix (options prefix ``coulomb_``) starts as a copy of A; its KSP (GMRES, right
    preconditioned, stopped on the unpreconditioned relative residual ``tol``) can be tuned from the
    command line with ``-coulomb_ksp_*`` and ``-coulomb_pc_*`` options. Call :meth:`destroy` when done.
    """

    def __init__(self, model: ContactModel, settings: SolverSettings | None = None) -> None:
        settings = settings or SolverSettings()
        settings.validate()
        self.model = model
        self.settings = settings
        self.comm = model.body.mesh.comm
        A = model.A
        self.timings: dict[str, float] = {}

        t0 = time.perf_counter()
        self.gamma = (
            float(settings.gamma) if settings.gamma is not None
            else settings.gamma_scale * power_iteration(A, settings.power_iterations)
        )
        self.timings["gamma"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        self.M = A.duplicate(copy=True)
        self.M.setOptionsPrefix(settings.prefix)
        self.rows = ContactRows(A, model.contact.global_dofs)
        self.cdofs = model.contact.local_dofs
        self._nullspace: PETSc.NullSpace | None = None
        self._options_set: list[str] = []
        self._steps = 0
        n_global = A.getSize()[0]
        #: The preconditioner in use ("auto" resolved by :func:`choose_preconditioner`).
        self.pc = settings.pc if settings.pc != "auto" else choose_preconditioner(
            n_global, self.comm.size, model.body.mesh.topology.cell_type.name)
        self.ksp = self._create_ksp()
        # work vectors
        self._u, self._r = A.createVecs()
        self._b, self._du = A.createVecs()
        self._Adu, self._w = A.createVecs()
        self.timings["setup"] = time.perf_counter() - t0

    def _create_ksp(self) -> PETSc.KSP:
        s = self.settings
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(s.prefix)
        # gamg preconditions with the stiffness matrix A, which never changes: PETSc sets the AMG hierarchy up
        # at the first solve and reuses it for every Newton matrix (only contact rows differ from A).
        ksp.setOperators(self.M, self.model.A if self.pc == "gamg" else self.M)
        ksp.setType(PETSc.KSP.Type.GMRES)
        ksp.setGMRESRestart(s.gmres_restart)
        ksp.setPCSide(PETSc.PC.Side.RIGHT)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.setTolerances(rtol=s.tol, atol=0.0, max_it=s.ksp_max_it)
        pc = ksp.getPC()
        parallel = self.comm.size > 1
        if self.pc == "ilu":
            pc.setType("bjacobi" if parallel else "ilu")
        elif self.pc == "lu":
            pc.setType("lu")
            if parallel:
                pc.setFactorSolverType("mumps")
        elif self.pc in ("gamg", "gamg-newton"):
            # Smoothed aggregation with the rigid-body near-nullspace, on A (gamg) or on the Newton matrix
            # itself (gamg-newton, a new hierarchy every step).
            pc.setType("gamg")
            self._nullspace = rigid_body_modes(self.model.V)
            (self.model.A if self.pc == "gamg" else self.M).setNearNullSpace(self._nullspace)
            opts = PETSc.Options()
            key = f"{s.prefix}mg_levels_ksp_max_it"
            if not opts.hasName(key):
                opts.setValue(key, GAMG_SMOOTHER_SWEEPS)
                self._options_set.append(key)
        elif self.pc == "hypre":
            pc.setType("hypre")
            pc.setHYPREType("boomeramg")
        else:
            pc.setType(self.pc)
        ksp.setFromOptions()
        return ksp

    @contextlib.contextmanager
    def _deterministic_setup(self) -> Iterator[None]:
        """Within: GAMG's set-up (at a KSP solve) forms its Galerkin products in a fixed summation order
        (:data:`DETERMINISTIC_PTAP`), so that the same run on the same ranks gives the same bits."""
        key, value = DETERMINISTIC_PTAP
        opts = PETSc.Options()
        scoped = self.pc in ("gamg", "gamg-newton") and self.comm.size > 1 and not opts.hasName(key)
        if scoped:
            opts.setValue(key, value)
        try:
            yield
        finally:
            if scoped:
                opts.delValue(key)

    # -- the approximation step -------------------------------------------------------------------
    def _approximate(self, u: Array, r: Array) -> tuple[Array, Array, Array]:
        """Return (e, v, z): e = u − d̂ on all owned DOFs, (v, z) = (d̂ⁱ, zⁱ) on contact nodes."""
        gamma = self.gamma
        e = r / gamma
        uc = u[self.cdofs]
        v, z = resolvent(gamma * uc - r[self.cdofs], gamma, self.model.friction)
        e[self.cdofs] = uc - v
        return e, v, z

    def _norm(self, e: Array) -> float:
        """‖ŷ‖ = √(1 + γ²)·‖e‖ over all ranks."""
        local = float(np.dot(e, e))
        return math.sqrt((1.0 + self.gamma**2) * self.comm.allreduce(local, op=MPI.SUM))

    def _counts(self, states: npt.NDArray[np.int8]) -> tuple[int, int, int]:
        local = np.array([np.sum(states == s) for s in (OPEN, STICK, SLIP)], dtype=np.int64)
        total = self.comm.allreduce(local, op=MPI.SUM)
        return int(total[0]), int(total[1]), int(total[2])

    # -- the Newton step ---------------------------------------------------------------------------
    def _newton_direction(
        self, e: Array, v: Array, z: Array, sets: npt.NDArray[np.int8]
    ) -> tuple[Array, int, float]:
        """Solve for Δu by variant 4a or 4b; return (Δu on owned DOFs, Krylov iterations, relative residual)."""
        F = self.model.friction
        gamma = self.gamma
        cd = self.cdofs
        t0 = time.perf_counter()
        # Units: Q̃ maps displacements to forces. The blocks are taken for Q̃/γ (forces measured in units
        # of γ·length, so the sliding bases' s + t/γ and the rows' A·Δu + γ·U*ᵀΔu are consistent), and the
        # rows are multiplied by γ. This selects the same Newton iterate as the paper's bases (exact solves)
        # but makes the inexact GMRES solves independent of the units of E and the loads.
        if self.settings.variant == "4a":
            W, U = sstar_blocks(v, z / gamma, sets, F)
            left, right = np.swapaxes(W, 1, 2), gamma * np.swapaxes(U, 1, 2)
            self.rows.update(self.M, left, right)
            b = -gamma * e
            b[cd] = -gamma * (np.einsum("iab,ib->ia", left, e[cd]) + np.einsum("iab,ib->ia", right, e[cd]) / gamma)
            self._b.array[:] = b
        else:
            X, Y = s_blocks(v, z / gamma, sets, F)
            left, right = np.swapaxes(X, 1, 2), gamma * np.swapaxes(Y, 1, 2)
            self.rows.update(self.M, left, right)
            # (A X + Y) p = A ŷ₂ − ŷ₁ with ŷ₂ = e, ŷ₁ = γ e. Near the solution Δu = X p − e is much
            # smaller than p ≈ e, so an inexact p would swamp Δu: solve for q = p − e instead, with
            # (A X + Y) q = A e − γ e − (A X + Y) e, whose size is that of Δu (and tol then means the
            # same as in 4a).
            self._w.array[:] = e
            self.model.A.mult(self._w, self._b)
            self._b.axpy(-gamma, self._w)
            self.M.multTranspose(self._w, self._Adu)
            self._b.axpy(-1.0, self._Adu)
        self.timings["newton_matrix"] = self.timings.get("newton_matrix", 0.0) + time.perf_counter() - t0

        t0 = time.perf_counter()
        self._du.set(0.0)
        try:
            with self._deterministic_setup():
                if self.settings.variant == "4a":
                    self.ksp.solve(self._b, self._du)
                else:
                    self.ksp.solveTranspose(self._b, self._du)
        except PETSc.Error as err:  # e.g. a -coulomb_ksp_type that cannot do what is asked of it
            detail = str(err).strip().splitlines()
            raise SolverError(f"the linear solver failed: {detail[-1] if detail else err}", "ksp_breakdown") from None
        self.timings["ksp"] = self.timings.get("ksp", 0.0) + time.perf_counter() - t0
        its = int(self.ksp.getIterationNumber())
        reason = int(self.ksp.getConvergedReason())
        b_norm = self._b.norm()
        # GMRES with right preconditioning monitors the true (unpreconditioned) residual norm
        linear_residual = float(self.ksp.getResidualNorm()) / b_norm if b_norm > 0.0 else 0.0
        du = self._du.getArray(readonly=True).copy()
        if self.settings.variant == "4b":
            p = du + e
            du = p - e
            du[cd] = np.einsum("iba,ib->ia", left, p[cd]) - e[cd]  # Xⁱ p = (leftⁱ)ᵀ p
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
        if reason == PETSc.KSP.ConvergedReason.DIVERGED_MAX_IT and self.comm.rank == 0:
            logger.warning("KSP reached %d iterations without tol=%g; using the inexact direction",
                           its, self.settings.tol)
        self._steps += 1
        return du, its, linear_residual

    # -- the driver --------------------------------------------------------------------------------
    def solve(self, initial_displacement: Array | None = None) -> SolveResult:
        """Solve the contact problem from ũ⁽⁰⁾ (owned DOFs of the physical displacement; default 0).

        Raises:
            SolverError: when the method does not converge; ``error.result`` holds the last iterate.
        """
        s = self.settings
        model = self.model
        A = model.A
        t_start = time.perf_counter()
        self._steps = 0
        self.ksp.setTolerances(rtol=s.tol)
        shift = model.shift.getArray(readonly=True)
        u = np.array(shift, dtype=np.float64)
        if initial_displacement is not None:
            u += np.asarray(initial_displacement, dtype=np.float64)
        self._u.array[:] = u
        A.mult(self._u, self._r)
        self._r.axpy(-1.0, model.rhs)
        r = self._r.getArray(readonly=True).copy()

        e, v, z = self._approximate(u, r)
        res = self._norm(e)
        res0 = res
        # Round-off floor of ‖ŷ‖ = √(1+γ²)‖u − d̂‖: u − d̂ cannot be resolved below the rounding error of
        # the displacements involved (start, shift d, and the load's displacement scale ‖l̃‖/γ).
        scale = self._norm(u) + self._norm(model.load.getArray(readonly=True)) / self.gamma
        floor = 100.0 * np.finfo(np.float64).eps * scale
        # The load's own residual scale ‖ŷ(ũ = 0)‖ = √(1+γ²)/γ·‖l̃‖ (no contact at ũ = 0): ‖ŷ⁽⁰⁾‖ of the paper's
        # start is dominated by γ·d when the load is small, and a reduction relative to it alone would
        # accept a field that does not resolve the load. The reduction is therefore taken relative to
        # min(‖ŷ⁽⁰⁾‖, 100·‖ŷ(ũ = 0)‖): the paper's rule for ordinary loads (‖ŷ⁽⁰⁾‖ is then below the bound),
        # a load-relative rule when the start's misfit dwarfs the load.
        load_scale = self._norm(model.load.getArray(readonly=True)) / self.gamma
        target = s.rtol * min(res0, LOAD_GUARD * load_scale)
        history = [res]
        records: list[IterationRecord] = []
        krylov_total = 0
        eta = s.tol
        reason = "max_iterations"
        converged = False
        k = 0
        if self.comm.rank == 0:
            logger.info("SCD semismooth* Newton (%s, tol=%g, pc=%s, gamma=%.4g): |y0| = %.3e",
                        s.variant, s.tol, self.pc, self.gamma, res0)

        def result(conv: bool, why: str) -> SolveResult:
            sets = classify(v, z, model.friction)
            self.timings["total"] = time.perf_counter() - t_start
            return SolveResult(
                u=u.copy(),
                displacement=u - shift,
                converged=conv,
                reason=why,
                iterations=k,
                krylov_iterations=krylov_total,
                residual_history=list(history),
                records=list(records),
                sets=sets,
                states=contact_states(sets, model.friction),
                normal_force=-z[:, 2].copy(),
                tangential_force=-z[:, :2].copy(),
                gap=v[:, 2].copy(),
                gamma=self.gamma,
                pc=self.pc,
                timings=dict(self.timings),
            )

        try:
            if not math.isfinite(res0):
                raise SolverError(f"the initial residual is not finite ({res0})", "non_finite")
            while True:
                if res <= max(target, floor):
                    converged, reason = True, "converged"
                    break
                if k >= s.max_iterations:
                    raise SolverError(
                        f"no convergence after {k} Newton iterations: |y|/|y0| = {res / res0:.3e} "
                        f"> rtol = {s.rtol:g}", "max_iterations")
                sets = classify(v, z, model.friction)
                if s.adaptive_tol:
                    eta = forcing_term(s.tol, history, eta, max(target, floor))
                    self.ksp.setTolerances(rtol=eta)
                du, its, linear_residual = self._newton_direction(e, v, z, sets)
                krylov_total += its

                t0 = time.perf_counter()
                self._du.array[:] = du
                A.mult(self._du, self._Adu)
                Adu = self._Adu.getArray(readonly=True)
                bound = 1.0 + 0.1 / (k + 1)
                accepted = None
                for alpha in line_search_steps(s.line_search_steps):
                    ut = u + alpha * du
                    rt = r + alpha * Adu
                    et, vt, zt = self._approximate(ut, rt)
                    rest = self._norm(et)
                    if rest <= (bound - 0.1 * alpha) * res:
                        accepted = (alpha, ut, rt, et, vt, zt, rest)
                        break
                self.timings["line_search"] = self.timings.get("line_search", 0.0) + time.perf_counter() - t0
                if accepted is None:
                    raise SolverError(
                        f"the line search found no acceptable step in iteration {k + 1} "
                        f"(|y|/|y0| = {res / res0:.3e})", "line_search")
                alpha, u, r, e, v, z, res = accepted
                if not math.isfinite(res):
                    raise SolverError(f"non-finite residual in iteration {k + 1}", "non_finite")
                k += 1
                history.append(res)
                n_open, n_stick, n_slip = self._counts(contact_states(classify(v, z, model.friction),
                                                                      model.friction))
                records.append(IterationRecord(k, res, alpha, its, n_open, n_stick, n_slip,
                                               eta, linear_residual))
                if self.comm.rank == 0:
                    logger.info("it %3d  |y|/|y0| = %.3e  step %.4g  krylov %4d  open/stick/slip %d/%d/%d",
                                k, res / res0, alpha, its, n_open, n_stick, n_slip)
        except SolverError as err:
            err.result = result(False, err.reason)
            if self.comm.rank == 0:
                logger.error("%s", err)
            raise
        return result(converged, reason)

    def solve_linear(self) -> SolveResult:
        """Solve A ũ = l̃ once (no contact possible): the Newton matrix is A and the KSP runs to ``rtol``."""
        model = self.model
        t0 = time.perf_counter()
        model.A.copy(self.M, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        tol = self.ksp.getTolerances()
        self.ksp.setTolerances(rtol=self.settings.rtol)
        self._du.set(0.0)
        with self._deterministic_setup():
            self.ksp.solve(model.load, self._du)
        self.ksp.setTolerances(rtol=tol[0])
        its = int(self.ksp.getIterationNumber())
        reason = int(self.ksp.getConvergedReason())
        b_norm = model.load.norm()
        linear_residual = float(self.ksp.getResidualNorm()) / b_norm if b_norm > 0.0 else 0.0
        self.timings["ksp"] = self.timings.get("ksp", 0.0) + time.perf_counter() - t0
        displacement = self._du.getArray(readonly=True).copy()
        u = displacement + model.shift.getArray(readonly=True)
        self._u.array[:] = u
        model.A.mult(self._u, self._r)
        self._r.axpy(-1.0, model.rhs)
        e, v, z = self._approximate(u, self._r.getArray(readonly=True).copy())
        res = self._norm(e)
        res0 = math.sqrt(1.0 + self.gamma**2) * model.load.norm() / self.gamma
        sets = classify(v, z, model.friction)
        self.timings["total"] = time.perf_counter() - t0
        converged = reason > 0
        return SolveResult(
            u=u, displacement=displacement, converged=converged,
            reason="converged" if converged else f"ksp_reason_{reason}", iterations=1, krylov_iterations=its,
            residual_history=[res0, res],
            records=[IterationRecord(1, res, 1.0, its, 0, 0, 0, self.settings.rtol, linear_residual)], sets=sets,
            states=contact_states(sets, model.friction), normal_force=-z[:, 2].copy(),
            tangential_force=-z[:, :2].copy(), gap=v[:, 2].copy(), gamma=self.gamma, timings=dict(self.timings),
            pc=self.pc,
        )

    def is_separated(self, result: SolveResult) -> bool:
        """True on all ranks if no contact node of ``result`` touches or penetrates the obstacle."""
        gap = result.displacement[self.cdofs[:, 2]] + self.model.contact.gap
        return bool(self.comm.allreduce(bool(np.all(gap > 0.0)), op=MPI.LAND))

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        for obj in (self.ksp, self.M, self._u, self._r, self._b, self._du, self._Adu, self._w):
            obj.destroy()
        if self._nullspace is not None:
            self._nullspace.destroy()
        opts = PETSc.Options()
        for key in self._options_set:
            opts.delValue(key)
        self._options_set = []
