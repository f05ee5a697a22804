"""The linear solves of the SCD Newton driver: the KSP of the Newton matrix over the solver's life.

:class:`NewtonLinearSolves` is the part of :class:`~fenics_coulomb.scd.newton.SCDNewtonSolver` that owns the KSP
(GMRES, right preconditioned, stopped on the unpreconditioned relative residual) and its preconditioner:

* creation for the resolved preconditioner under the solver's options prefix (:mod:`fenics_coulomb.scd.preconditioner`),
  with GAMG's near-nullspace;
* the scope of the options: the solver's defaults and the user's ``petsc_options`` put into PETSc's database only
  for the solver's own calls (:meth:`NewtonLinearSolves.petsc_options`);
* one linear solve of the Newton system or of A x = l̃ to a relative tolerance, pc = "auto"'s cap per decade of
  reduction and its escalation ladder after a stagnated solve;
* the checks of a finished solve: a failed or non-finite one, and ``KSP_LIMIT_STEPS`` consecutive ones that
  reach ksp_max_it;
* finite sliding's geometry updates: the KSP made anew for the preconditioners that read the Newton matrix, GAMG's
  hierarchy kept (it is set up on A, or for pairs on the geometry-independent physical stiffness,
  :mod:`fenics_coulomb.scd.physical_preconditioner`).

The driver (start, Newton loop, line search, result) is :mod:`fenics_coulomb.scd.newton`.
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import SolverError
from fenics_coulomb.scd.newton_operator import MATRIX_FREE_PCS, NewtonOperator
from fenics_coulomb.scd.options import option_read, unread_hint
from fenics_coulomb.scd.physical_preconditioner import PhysicalGAMG
from fenics_coulomb.scd.preconditioner import (
    AUTO_STALL_ITS,
    DETERMINISTIC_PTAP,
    DETERMINISTIC_PTAP_MIN_RANKS,
    create_ksp,
    default_options,
)

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel
    from fenics_coulomb.scd.contact_rows import ContactRows
    from fenics_coulomb.scd.steps import NewtonStep
    from fenics_coulomb.settings import SolverSettings

__all__ = ["KSP_LIMIT_STEPS", "LINEAR_SOLVES", "NewtonLinearSolves"]

logger = logging.getLogger(__name__)

#: A solve stops (SolverError "ksp_limit", exit 3) when the linear solves of this many consecutive Newton steps
#: reach ksp_max_it without their tolerance: one inexact direction is used (with a warning), but directions
#: that stay that inexact do not converge, they only cost ksp_max_it iterations per step (GAMG with
#: --gamma-scale 1, d3/L2 lev 8: 2000 GMRES iterations in every step, 780 s for 9 steps and still running).
KSP_LIMIT_STEPS = 3

#: The linear solves of every solver in this process so far (one counter: the command warns of its PETSc
#: options no object read only after some solve has run, :func:`fenics_coulomb.cli.main`).
LINEAR_SOLVES = [0]

Array = npt.NDArray[np.float64]


class NewtonLinearSolves:
    """The KSP of the Newton matrix and every linear solve of :class:`~fenics_coulomb.scd.newton.SCDNewtonSolver`
    (its base class; the attributes below are the solver's, set in its constructor)."""

    comm: MPI.Comm
    model: ContactModel
    settings: SolverSettings
    prefix: str
    step: NewtonStep
    A: PETSc.Mat
    M: PETSc.Mat
    operator: NewtonOperator
    rows: ContactRows
    cdofs: npt.NDArray[np.int32]
    gamma: float
    ksp: PETSc.KSP
    timings: dict[str, float]
    x: PETSc.Vec
    b: PETSc.Vec
    #: The preconditioner in use ("auto" resolved by the global number of unknowns).
    pc: str
    #: The fixed forcing term: settings.tol, or the options' ksp_rtol.
    tol: float
    #: Every change of preconditioner in this solver's life: Newton step, from, to, Krylov iterations spent.
    pc_history: list[dict[str, object]]
    _user_options: dict[str, object]
    #: The user's options that some object of the solver has read, and whether the others were reported.
    _options_read: set[str]
    _options_reported: bool
    _linear_solved: bool
    #: Whether this solver warns of the user's options no object read (nested iteration's coarse levels, whose options
    #: are the command's, leave it to the command).
    report_unread: bool
    _default_options: dict[str, object]
    _nullspace: PETSc.NullSpace | None
    #: Pairs with GAMG: the preconditioner set up in the physical displacement (None otherwise).
    _physical: PhysicalGAMG | None
    _ladder: list[str]
    _blocks: tuple[Array, Array] | None
    _max_it: int
    _steps: int
    _limited: int

    def _node_gamma_range(self) -> tuple[float, float]:
        raise NotImplementedError

    def _rebind_ksp(self) -> None:
        """The KSP after a geometry update (:meth:`~fenics_coulomb.scd.newton.SCDNewtonSolver.rebind`): made anew
        for the preconditioners of M; GAMG's hierarchy kept, as it does not
        depend on the geometry (one body: it is A's; pairs: B's, :mod:`fenics_coulomb.scd.physical_preconditioner`,
        which reads the new change of variables at each application)."""
        if self.pc != "gamg":
            # the preconditioners of M start from a KSP of their own
            self.ksp.destroy()
            if self._nullspace is not None:
                self._nullspace.destroy()
            self._create_ksp()
            self.ksp.setTolerances(rtol=self.tol, max_it=self._max_it)
        else:
            self.ksp.setOperators(self.M, self.model.gamg_stiffness())
            self.ksp.getPC().setReusePreconditioner(True)

    def _create_ksp(self) -> None:
        """Create the KSP of the Newton matrix for ``self.pc`` under the solver's prefix and options."""
        settings = self.settings
        self._default_options = {k: v for k, v in default_options(self.pc, self.model.V.mesh.topology.cell_type.name,
                                                                  settings.poisson_ratio).items()
                                 if k not in self._user_options}
        if self.pc == "gamg" and self._physical is None:
            B = self.model.physical_stiffness()
            if B is not None:
                self._physical = PhysicalGAMG(B, self.model.variables, self.model.V, self.prefix)
        physical = self._physical if self.pc == "gamg" else None
        # GAMG on the stiffness: A, or A made non-singular for a body held by contact alone
        stiffness = self.model.gamg_stiffness() if self.pc == "gamg" and physical is None else self.A
        self.ksp, self._nullspace = create_ksp(self.comm, self.M, stiffness, self.model.V, self.pc, self.prefix,
                                               settings.tol, settings.gmres_restart, settings.ksp_max_it,
                                               self.model.near_nullspace, physical)
        with self.petsc_options():
            self.ksp.setFromOptions()
            if physical is not None:
                physical.set_from_options()

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
        if self._physical is not None:  # GAMG on B is left behind for good: its hierarchy goes now
            self._physical.destroy()
            self._physical = None
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
        if self.pc == "gamg" and self.comm.size >= DETERMINISTIC_PTAP_MIN_RANKS \
                and not opts.hasName(key):
            added[key] = None
            opts[key] = value
        try:
            yield
        finally:
            # which of the user's options some object read (the flag goes with the value restored below)
            self._options_read.update(key for key in self._user_options if option_read(f"{self.prefix}{key}"))
            for name, previous in added.items():  # restore what the database held before
                if previous is None:
                    opts.delValue(name)
                else:
                    opts[name] = previous

    @property
    def options_read(self) -> frozenset[str]:
        """The user's ``petsc_options`` (names without the prefix) that some object of the solver has read."""
        return frozenset(self._options_read)

    def report_unread_options(self) -> None:
        """Warn once (rank 0) of the user's ``petsc_options`` that no object of the solver has read after a linear
        solve (the preconditioner reads some at its first set-up): a misspelt name, or an option of another
        preconditioner than the one in use, is otherwise ignored silently."""
        if not self.report_unread or self._options_reported or not self._linear_solved:
            return
        unread = [key for key in self._user_options if key not in self._options_read]
        if unread and self.comm.rank == 0:
            logger.warning("petsc_options not read by the solver's KSP or preconditioner (pc %s): %s — misspelt, or "
                           "options of another preconditioner%s", self.pc, ", ".join(sorted(unread)),
                           unread_hint(unread, self.comm.size > 1))
        self._options_reported = bool(unread)

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
        self._linear_solved = True
        LINEAR_SOLVES[0] += 1
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
                f"do not converge; try {self._remedies()}, or a smaller gamma_node_scale ([solver] or the API; now "
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

    def _solve_linear_system(self) -> int:
        """Solve A x = l̃ (the Newton matrix is A) to the reduction; its iterations."""
        self._set_tolerance(self.settings.reduction)
        self.x.set(0.0)
        self._petsc_call(self.ksp.solve, self.model.load, self.x)
        self._linear_solved = True
        LINEAR_SOLVES[0] += 1
        self.ksp.setTolerances(rtol=self.tol)
        return int(self.ksp.getIterationNumber())
