"""The solve of one load step of a :class:`~fenics_coulomb.problem.ContactProblem` under either sliding model, beyond
the single SCD solve: finite sliding's geometry iteration (:class:`~fenics_coulomb.model.sliding.GeometryIteration`
driven on the problem's model and solver: configure X + u, place, solve, check, update) with the pairing each
configuration already has, and small sliding's measure of how far it has slid.

:class:`SlidingSolve` is the part of ``ContactProblem`` that does it (its base class; the attributes and methods
declared below are the problem's).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import SolverError
from fenics_coulomb.model.checks import ONE_CONSTRAINT, physics_failure, physics_residuals
from fenics_coulomb.model.sliding import GeometryIteration
from fenics_coulomb.model.small_sliding import SMALL_SLIDE_WARNING, largest_slide
from fenics_coulomb.scd.resolvent import OPEN
from fenics_coulomb.settings import ERROR_PER_RTOL, SolverSettings

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel
    from fenics_coulomb.model.pairs import Pairing
    from fenics_coulomb.scd.newton import SCDNewtonSolver
    from fenics_coulomb.scd.records import SolveResult

__all__ = ["SlidingSolve"]

logger = logging.getLogger(__name__)


def _join_histories(result: SolveResult, solves: list[SolveResult]) -> None:
    """The residual histories and iteration records of every solve of a geometry iteration (``solves``, in order)
    into ``result``, one after the other, with the solve of each history entry (``history_geometry``):
    summary.json's newton_iterations counts them all, and so do its histories and convergence.csv."""
    if len(solves) < 2:
        return
    records = [record for solve in solves for record in solve.records]  # result is solves[-1]: read, then set
    history = [float(r) for solve in solves for r in solve.residual_history]
    result.history_geometry = [g for g, solve in enumerate(solves) for _ in solve.residual_history]
    result.records, result.residual_history = records, history


class SlidingSolve:
    """Finite sliding's geometry iteration and small sliding's slide measure of a contact problem's step."""

    _settings: SolverSettings
    p: int
    _previous: npt.NDArray[np.float64] | None
    _previous_delta: npt.NDArray[np.float64] | None
    #: (u, the pairing of X + u) last computed by the geometry iteration (finite sliding with contact pairs).
    _known: tuple[npt.NDArray[np.float64], Pairing] | None

    if TYPE_CHECKING:  # the problem's
        @property
        def model(self) -> ContactModel:
            """The algebraic model."""

        @property
        def solver(self) -> SCDNewtonSolver:
            """The SCD semismooth* Newton solver."""

        def _place(self) -> None:
            """Assemble l̃ and place the obstacles."""

        def _solve_placed(self, start: npt.NDArray[np.float64], reduction: float | None = None) -> SolveResult:
            """One SCD solve of the model as placed."""

        def initial_displacement(self, u0: dolfinx.fem.Function | None = None) -> npt.NDArray[np.float64]:
            """ũ⁽⁰⁾ on the owned DOFs."""

        def _verify(self, result: SolveResult) -> None:
            """The physics checks of a converged solve."""

        def _finish(self, result: SolveResult, commit: bool = False) -> dolfinx.fem.Function:
            """The result's displacement into the problem's Function."""

        def _log(self, message: str) -> None:
            """A line on rank 0."""

        def _accuracy(self, result: SolveResult | None = None) -> float:
            """The relative displacement accuracy of a solve."""

    @property
    def settings(self) -> SolverSettings:
        """The solver's settings (read-only: :meth:`~fenics_coulomb.problem.ContactProblem.set_solver` replaces the
        solver with new ones; an assignment would reach only some of the places that read them)."""
        return self._settings

    def _measure_slide(self, result: SolveResult) -> None:
        """Small sliding says when it breaks: the largest slide of a contact node against its partner in units of
        the partner's size (:func:`~fenics_coulomb.model.small_sliding.largest_slide`), kept in the result and a
        warning above :data:`~fenics_coulomb.model.small_sliding.SMALL_SLIDE_WARNING` (collective)."""
        model = self.model
        z = np.asarray(result.displacement, dtype=np.float64)
        ratio, where = largest_slide(model, model.physical(z), z)
        result.largest_slide = {"slide_per_size": ratio, "node": where}
        if ratio > SMALL_SLIDE_WARNING and model.comm.rank == 0:
            logger.warning("small sliding: the contact node at (%s) has slid %.3g times its partner's size against "
                           "its partner; the reference configuration's contact geometry no longer describes it: use "
                           "sliding = \"finite\"", ", ".join(f"{c:.6g}" for c in where), ratio)

    def _configure(self, u: npt.NDArray[np.float64] | None, pairing: Pairing | None = None,
                   resolution: float | None = None) -> None:
        """Evaluate the contact geometry in X + u known to ``resolution`` (None: a converged solve's u, its
        displacement error); hand the solver the model's new Ã when it changed (collective)."""
        if u is not None and pairing is not None:
            self._remember_pairing(u, pairing)
        known = 0.0 if resolution is None else resolution
        if u is not None and resolution is None:
            scale = self.model.comm.allreduce(float(np.max(np.abs(u), initial=0.0)), op=MPI.MAX)
            known = ERROR_PER_RTOL * self.settings.reduction * scale
        if self.model.configure(u, pairing, known):
            self.solver.rebind()
            self.p = self.model.p

    def _remember_pairing(self, u: npt.NDArray[np.float64], pairing: Pairing) -> None:
        """Keep the pairing of X + u (without obstacles only: they move between steps and take part in the
        pairing's merge)."""
        self._known = None if self.model.obstacles else (u, pairing)

    def _known_pairing(self, u: npt.NDArray[np.float64] | None
                       ) -> tuple[npt.NDArray[np.float64] | None, Pairing | None]:
        """The configuration to evaluate for the previous step's u and its pairing when known (collective): the
        last configuration whose pairing was computed (a geometry update's, or a settled check's) when it is u to
        round-off — within 1e-12 of |u|∞, the geometry iteration's own test of a solve that returned its
        configuration —, else u with None."""
        known = self._known
        if known is None or u is None or known[0].shape != u.shape:
            close = False
        else:
            comm = self.model.comm
            scale = comm.allreduce(float(np.max(np.abs(u), initial=0.0)), op=MPI.MAX)
            close = comm.allreduce(float(np.max(np.abs(u - known[0]), initial=0.0)), op=MPI.MAX) <= 1e-12 * scale
        if not self.model.comm.allreduce(bool(close), op=MPI.LAND):
            return u, None
        assert known is not None
        return known[0], known[1]

    def _moved_through(self, result: SolveResult) -> str:
        """"" unless the body moved onto or past an obstacle's core within the solve (its contact nodes, all on one
        side, never met it: :meth:`~fenics_coulomb.model.placement.ObstaclePlacement.buried`), else what
        (collective)."""
        model = self.model
        u = model.physical(np.asarray(result.displacement, dtype=np.float64)).reshape(-1, 3)
        moved = u - (0.0 if self._previous is None else self._previous.reshape(-1, 3))
        shift = model.comm.allreduce(moved.sum(axis=0)) / max(model.comm.allreduce(len(moved)), 1)
        if getattr(model.coupling, "num_bodies", 1) > 1:  # bodies moving apart have no one motion to sweep along
            shift = np.zeros(3)
        return model.placement.buried(model.obstacles, model.V, model.ghosted(u.ravel()), shift,
                                      self._previous_delta)

    def _solve_finite(self, u0: dolfinx.fem.Function | None) -> tuple[dolfinx.fem.Function, SolveResult]:
        """Finite sliding: iterate the geometry (:class:`~fenics_coulomb.model.sliding.GeometryIteration`): solve
        with G(u⁽ᵐ⁾) linearized about u⁽ᵐ⁾, from u⁽ᵐ⁾, until G(u⁽ᵐ⁺¹⁾) has the same contact nodes and stencil supports
        and its linearization moves no node's gap or slip by more than the solve's accuracy (collective)."""
        model = self.model
        configuration = self._previous  # u⁽⁰⁾: the previous step's physical u (None: the reference X)
        if configuration is not None or model.configuration is not None:
            self._configure(*self._known_pairing(configuration))
        self._place()
        iteration = GeometryIteration(model, self.settings.reduction, ERROR_PER_RTOL, self._previous,
                                      self.settings.accuracy)
        reduction = iteration.reduction
        result = self._solve_placed(self.initial_displacement(u0), reduction)
        newton, krylov = result.iterations, result.krylov_iterations
        solves = [result]  # every solve of the geometry iteration: their histories, one after the other
        while True:
            z = np.array(result.displacement, dtype=np.float64)
            u = model.physical(z)
            ratio = result.residual_history[0] / result.target if result.residual_history and result.target > 0 \
                else 0.0
            step = iteration.after(u, z, reduction, result.iterations, result.states != OPEN, ratio,
                                   result.contact_force)
            if step.change is not None:
                logger.debug("finite sliding: solved in %s, new %s: %s", step.change.old_signature[:8],
                             step.change.new_signature[:8], step.action)
            if step.action == "settled":
                if step.change is not None and step.change.pairing is not None:
                    self._remember_pairing(u, step.change.pairing)  # the next step configures X + u first
                break
            if step.action == "fail":
                _join_histories(result, solves)
                result.iterations, result.krylov_iterations = newton, krylov
                result.geometry_updates = iteration.updates
                result.converged, result.reason = False, "geometry"
                result.checks = physics_residuals(model, z, balance=False, accuracy=self._accuracy(result))
                self._finish(result)
                both = physics_failure({"shared_penetration": result.checks.get("shared_penetration", 0.0)},
                                       self.settings.reduction)
                shared = model.coupling.shared_nodes()
                if shared and not both:  # nodes that may alternate between a pair and an obstacle
                    both = (f"{shared} contact node(s) lie on both a pair's slave surface and the obstacles' contact "
                            f"boundary; if they alternate between the two: {ONE_CONSTRAINT}")
                raise SolverError(step.message + (f"; {both}" if both else ""), "geometry", result)
            if step.action == "update":
                assert step.change is not None
                self._configure(u, step.change.pairing, step.change.resolution)
                self._place()
                start = model.relative(u)
                start[model.dirichlet_rows] = model.dirichlet_values
                self._log(f"finite sliding: geometry update {iteration.updates} ({step.message})")
            else:  # the same geometry, on to rtol
                start = z
                self._log(f"finite sliding: {step.message}")
            reduction = iteration.reduction
            earlier = result.timings
            try:
                result = self._solve_placed(start, reduction)
            except SolverError as err:  # the failed solve's result with every earlier solve's history
                if err.result is not None:
                    _join_histories(err.result, [*solves, err.result])
                    err.result.iterations += newton
                    err.result.krylov_iterations += krylov
                    err.result.geometry_updates = iteration.updates
                raise
            solves.append(result)
            newton, krylov = newton + result.iterations, krylov + result.krylov_iterations
            result.timings["total"] = result.timings.get("total", 0.0) + earlier.get("total", 0.0)  # every geometry
        result.geometry_updates = iteration.updates
        result.iterations, result.krylov_iterations = newton, krylov  # over every geometry of the solve
        _join_histories(result, solves)
        # the answer's reduction is the iteration's rtol (a solve carried on past it to resolve an update does not
        # make the checks' bound or the reported rtol tighter than asked)
        result.rtol = max(result.rtol, self.settings.reduction)
        self._verify(result)
        return self._finish(result, commit=result.converged), result
