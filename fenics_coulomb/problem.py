"""``ContactProblem``: a DOLFINx-style contact problem, in the manner of ``dolfinx.fem.petsc.LinearProblem``.

::

    problem = ContactProblem(a, L, bcs=[bc], contact=(facet_tags, [BOTTOM]), friction=0.23,
                             petsc_options_prefix="coulomb_", petsc_options={"ksp_rtol": 0.1})
    uh, result = problem.solve()

**Load paths.** Each :meth:`ContactProblem.solve` is one step k of a quasi-static path and is kept as the
history of the next one: change the loads (the values of the Constants and Functions in L and in the
Dirichlet conditions' values) and the obstacles' displacements (:meth:`ContactProblem.move`) and solve again.
Step k solves the static problem with the obstacles placed at δ_k and friction on the increment: the slip of a
contact node is s = T(ũ_k − ũ_{k−1}) − T(δ_k − δ_{k−1}) (T the node's tangent rows at step k; ũ₀ = 0,
δ₀ = 0), i.e. the previous step enters the local shift (:meth:`ContactModel.place
<fenics_coulomb.model.contact_model.ContactModel.place>`) as the gap enters the normal component. The first step is the
static problem. Step k > 1 starts its Newton iteration from ũ_{k−1}. :meth:`ContactProblem.reset` forgets
the history (or sets it to a known previous step, to resume a path).

The problem owns the algebraic model (:class:`~fenics_coulomb.model.contact_model.ContactModel`: A, l̃, d, l, the contact
nodes) and the SCD semismooth* Newton solver (:class:`~fenics_coulomb.scd.newton.SCDNewtonSolver`: the Newton
matrix, its KSP). Every PETSc object it creates carries the options prefix; ``petsc_options`` are set under
it only while the solver reads them and removed again.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Mapping, Sequence
from typing import Any

from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import InputError, SolverError, check_all
from fenics_coulomb.model.checks import physics_failure, physics_residuals, reported_warnings
from fenics_coulomb.model.contact_model import ContactModel, Friction
from fenics_coulomb.model.dof_values import set_owned_values
from fenics_coulomb.model.obstacles import Obstacle, _vector
from fenics_coulomb.model.pairs import ContactPair, Pairing
from fenics_coulomb.problem_arguments import (as_settings, check_bcs, check_contact, check_petsc_options, check_prefix,
                                             form_ranks, history_placement, obstacle_index, show)
from fenics_coulomb.report import ContactReport, make_report
from fenics_coulomb.scd.newton import SCDNewtonSolver
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scd.resolvent import OPEN
from fenics_coulomb.settings import ERROR_PER_RTOL, SolverSettings
from fenics_coulomb.sliding_solve import SlidingSolve
from fenics_coulomb.start_rule import auto_start, interpolate_displacement

__all__ = ["ContactProblem"]

logger = logging.getLogger(__name__)


#: A serial number per problem in this process (results name theirs: an id() is reused once an object is freed).
_SERIALS = itertools.count(1)


class ContactProblem(SlidingSolve):
    """Static contact of a linear-elastic body with a rigid obstacle under Coulomb friction.

    Solved by the SCD semismooth* Newton method of the reference paper. Use as a context manager or call
    :meth:`destroy` (collective) when done.

    Args:
        a: Bilinear UFL form of linear elasticity on a vector P1/Q1 space (any material: isotropic,
            orthotropic, several materials, springs); the solver only uses its assembled matrix.
        L: Linear UFL form (tractions, body forces), or None.
        bcs: Dirichlet conditions, including non-zero values and single components. A node with any
            constrained component is never a contact node.
        contact: The facet tags and the markers of the contact boundary.
        friction: Coulomb coefficient: a number or a scalar field (a Function, interpolated at the nodes).
        obstacles: The rigid obstacles (:class:`~fenics_coulomb.model.obstacles.Plane`, ``Sphere``, ``Cylinder``,
            each possibly moved by its ``displacement`` δ); default the plane x3 = 0 (half-space x3 <= 0).
            Each contact node belongs to the obstacle with the smallest gap.
        settings: Solver settings (a :class:`~fenics_coulomb.settings.SolverSettings` or a dict of its
            fields), including the predictor and the no-contact shortcut.
        petsc_options_prefix: Options prefix of every PETSc object of the problem (required, non-empty).
        petsc_options: PETSc options (without prefix) of the Newton systems' KSP and preconditioner.
        form_compiler_options: FFCx options.
        jit_options: JIT options.
        contact_pairs: Two (or more) elastic bodies, disconnected parts of the mesh, in contact: the
            :class:`~fenics_coulomb.model.pairs.ContactPair` s (slave and master facet tags, friction); replaces
            ``contact`` and ``obstacles``. Solved in the variables z = M⁻¹u of
            :mod:`fenics_coulomb.model.pairs.two_body`; :attr:`u` and the result's ``displacement`` are the
            physical u = M z.

    Raises:
        InputError: for bad input (on every rank, before the first collective call where possible).
    """

    def __init__(
        self,
        a: ufl.Form,
        L: ufl.Form | None,
        bcs: Sequence[dolfinx.fem.DirichletBC] = (),
        contact: tuple[dolfinx.mesh.MeshTags, Sequence[int]] | None = None,
        friction: Friction = 0.0,
        obstacles: Sequence[Obstacle] | Obstacle | None = None,
        settings: SolverSettings | dict[str, Any] | None = None,
        *,
        petsc_options_prefix: str,
        petsc_options: dict[str, Any] | None = None,
        form_compiler_options: dict | None = None,
        jit_options: dict | None = None,
        contact_pairs: Sequence[ContactPair] | None = None,
        sliding: str = "finite",
    ) -> None:
        self._model: ContactModel | None = None
        self._solver: SCDNewtonSolver | None = None
        check_prefix(petsc_options_prefix)
        check_bcs(bcs)
        self._settings = as_settings(settings)
        check_petsc_options(petsc_options, petsc_options_prefix, form_ranks(a) > 1)
        check_contact(contact, contact_pairs)
        t0 = time.perf_counter()
        self._model = ContactModel(a, L, bcs, contact, friction, obstacles, petsc_options_prefix,
                                   form_compiler_options, jit_options, contact_pairs, sliding)
        #: Wall time of building the model (form compilation and assembly) on this rank.
        self.model_time = time.perf_counter() - t0
        try:
            self._solver = SCDNewtonSolver(self._model, self.settings, petsc_options_prefix, petsc_options)
        except BaseException:  # e.g. a fixed gamma out of range: the model's PETSc objects go with the problem
            self._model.destroy()
            raise
        self._petsc_options = dict(petsc_options or {})
        self.petsc_options_prefix = petsc_options_prefix
        #: The physical displacement of the last solve.
        self.u = dolfinx.fem.Function(self._model.V, name="displacement")
        #: Unknowns after removing the Dirichlet DOFs (global).
        self.n: int = self._model.n
        #: Contact nodes (global).
        self.p: int = self._model.p
        self._obstacles = list(self._model.obstacles)
        self._step = 0
        #: This problem's serial number and the number of its state changes (solve, move, reset): a result is
        #: this problem's of the current state (:meth:`check_result`).
        self._serial = next(_SERIALS)
        self._state = 0
        self._previous: npt.NDArray[np.float64] | None = None
        self._previous_delta: npt.NDArray[np.float64] | None = None
        #: The obstacles as placed at the previous step (their rotations; None before the first step).
        self._previous_obstacles: list[Obstacle] | None = None
        #: (u, the pairing of X + u) last computed by the geometry iteration (finite sliding with contact pairs).
        self._known: tuple[npt.NDArray[np.float64], Pairing] | None = None

    # -- access ------------------------------------------------------------------------------------
    @property
    def model(self) -> ContactModel:
        """The algebraic model (A, l̃, d, l, contact nodes)."""
        if self._model is None:
            raise RuntimeError("ContactProblem: the problem was destroyed (destroy() or its with block ended): "
                               "build a new one")
        return self._model

    @property
    def solver(self) -> SCDNewtonSolver:
        """The SCD semismooth* Newton solver (Newton matrix, KSP)."""
        if self._solver is None:
            raise RuntimeError("ContactProblem: the problem was destroyed (destroy() or its with block ended): "
                               "build a new one")
        return self._solver

    @property
    def ksp(self) -> PETSc.KSP:
        """The KSP of the Newton systems (options prefix ``petsc_options_prefix``; replaced by
        :meth:`set_solver` and by pc auto's escalation)."""
        return self.solver.ksp

    @property
    def V(self) -> dolfinx.fem.FunctionSpace:
        """The displacement space."""
        return self.model.V

    def checks(self, result: SolveResult) -> dict[str, float]:
        """The physics residuals of ``result`` with the global balance (collective): equilibrium, penetration,
        negative pressure, complementarity, the Coulomb cone, the slip direction and the balance of reactions,
        contact forces and loads, each relative (:func:`fenics_coulomb.model.checks.physics_residuals`). The
        solve itself checks all but the balance (``result.checks``) and does not converge when one fails."""
        self.check_result(result, "checks")
        unknown = result.relative_displacement if result.relative_displacement is not None else result.displacement
        return physics_residuals(self.model, unknown, accuracy=self._accuracy(result))

    def check_result(self, result: object, where: str) -> None:
        """InputError unless ``result`` is the SolveResult of this problem's last solve, its obstacles and history as
        they are now: a report, check or result set of an earlier state would mix that result with the current
        placement (a moved ball made a converged result's penetration 0.025)."""
        if not isinstance(result, SolveResult):
            plain = isinstance(result, str | int | float | list | tuple | dict) or result is None
            raise InputError(f"{where}: result = {show(result) if plain else type(result).__name__}: give the "
                             "SolveResult of this problem's solve()")
        origin = result.origin
        if origin is None or origin[0] != self._serial:
            raise InputError(f"{where}: the result is not one of this problem's solve() (a result of another problem "
                             "describes other nodes)")
        if origin[1] != self._state:
            raise InputError(f"{where}: the result of an earlier solve: this problem has been moved, reset or solved "
                             "since (report, check and write a result before the next move, reset or solve)")

    def _accuracy(self, result: SolveResult | None = None) -> float:
        """The relative displacement accuracy of a solve to its rtol (ERROR_PER_RTOL·rtol, docs/tradeoff)."""
        return ERROR_PER_RTOL * ((result.rtol if result is not None else None) or self.settings.reduction)

    def report(self, result: SolveResult, reactions: Mapping[str, Any] | None = None) -> ContactReport:
        """Forces and contact nodes of ``result``, the same on every rank (collective).

        Args:
            result: A result of this problem's :meth:`solve`.
            reactions: Named supports whose reaction forces to sum: name → a ``DirichletBC`` of ``bcs`` (on V or
                on a sub-space) or an array of local node blocks.

        Returns:
            A :class:`~fenics_coulomb.report.ContactReport`: the total contact force, the force of each obstacle
            and each contact pair, the reactions, the applied load, and every contact node (coordinates,
            normal, area, force, pressure, gap, state) gathered in global node order.
        """
        model = self.model
        self.check_result(result, "report")
        if reactions is not None and not isinstance(reactions, Mapping):
            raise InputError(f"report: reactions = {type(reactions).__name__}: give a dict name -> DirichletBC of bcs "
                             "(or node blocks)")
        return make_report(model, result, self._obstacles, reactions)

    @property
    def A(self) -> PETSc.Mat:
        """The stiffness matrix with the Dirichlet rows and columns of a scaled identity."""
        return self.model.A

    def set_solver(self, settings: SolverSettings | dict[str, Any] | None = None,
                   petsc_options: dict[str, Any] | None = None) -> None:
        """Replace the solver (settings and PETSc options) on the same assembled model (collective)."""
        settings = as_settings(settings)
        check_petsc_options(petsc_options, self.petsc_options_prefix, self.model.comm.size > 1)
        old = self.solver
        # the new solver first: a value it refuses (a fixed gamma out of range) leaves the old one in place
        solver = SCDNewtonSolver(self.model, settings, self.petsc_options_prefix, petsc_options)
        old.destroy()
        self._solver = solver
        self._settings = settings
        self._petsc_options = dict(petsc_options or {})

    @property
    def sliding(self) -> str:
        """The sliding model: "finite" (contact evaluated in the deformed configuration) or "small"."""
        return self.model.sliding

    @property
    def finite_sliding(self) -> bool:
        """Whether the contact geometry depends on the displacement: finite sliding with contact pairs, an obstacle
        that is not a plane (a plane's linearized gap is its gap at X, its frame constant), several obstacles, or a
        rotated obstacle (the material point beneath a node, whose motion is the slip's, is where the node is)."""
        model = self.model
        rotated = any(getattr(o, "rotation", None) is not None
                      for o in [*self._obstacles, *(self._previous_obstacles or [])])
        return model.sliding == "finite" and (model.coupling.follows_configuration or len(self._obstacles) > 1 or
                                             rotated or any(not o.affine for o in self._obstacles))

    # -- the load path ------------------------------------------------------------------------------
    @property
    def step(self) -> int:
        """The number of solved (committed) steps of the load path."""
        return self._step

    @property
    def obstacles(self) -> list[Obstacle]:
        """The obstacles as they will be placed in the next solve."""
        return list(self._obstacles)

    def move(self, obstacle: int | str, displacement: npt.ArrayLike, rotation: Any = "keep") -> None:
        """Set the total displacement δ of an obstacle (its index or name) for the next solve, and optionally its
        total rotation [angle_deg, [ax, ay, az], [cx, cy, cz]] about the centre (at its scene position; None: no
        rotation; default: keep the current one). The obstacle is then y ↦ R(y − centre) + centre + δ.

        A node's slip in the step is its tangential motion relative to the obstacle's material point it was
        closest to at the previous step, which moves by R_k R_{k−1}ᵀ(p − c_{k−1}) + c_k − p (c the map's
        translation part); without rotations that is δ_k − δ_{k−1} (:meth:`Obstacle.motion`).

        Raises:
            InputError: for an unknown obstacle, a displacement that is not a finite 3-vector or a bad rotation.
        """
        self.model  # noqa: B018  (RuntimeError after destroy())
        index = obstacle_index(self._obstacles, obstacle)
        target = self._obstacles[index]
        moved = target.moved(_vector(displacement, "displacement", f"move: {target.label}"))
        self._obstacles[index] = moved if isinstance(rotation, str) and rotation == "keep" else moved.rotated(rotation)
        self._state += 1

    def reset(self, u: dolfinx.fem.Function | None = None, *, step: int = 0,
              obstacle_displacements: npt.ArrayLike | None = None,
              obstacle_rotations: Sequence[Any] | None = None) -> None:
        """Forget the load path's history, or set it to a known previous step (collective with ``u``).

        Args:
            u: The (physical) displacement of the previous step (on any mesh, interpolated), or None for ũ₀ = 0.
            step: The number of that step (the next solve is step ``step + 1``).
            obstacle_displacements: δ of that step per obstacle, shape (number of obstacles, 3); None for 0.
            obstacle_rotations: The rotation [angle_deg, axis, centre] (or None) of each obstacle at that step;
                None for none. The next step's slip is measured from this placement, its rotation included.
        """
        self.model  # noqa: B018  (RuntimeError after destroy())
        if isinstance(step, bool) or not isinstance(step, int | np.integer) or step < 0:
            raise InputError(f"reset: step {step!r} must be an integer >= 0")
        delta, placed = history_placement(self._obstacles, obstacle_displacements, obstacle_rotations)
        self._previous = None if u is None else interpolate_displacement(u, self.model.V)
        if self._previous is not None and not self.finite_sliding:  # the history in the model's unknown
            self._previous = self.model.relative(self._previous)
        self._previous_delta = delta
        self._previous_obstacles = placed
        self._step = int(step)
        self._state += 1

    def _place(self) -> None:
        """Re-assemble l̃ from the current loads and place the obstacles with the history's shift."""
        model = self.model
        model.assemble_load()
        previous = None if self._previous is None else self._history()[model.contact.local_dofs]
        rotating = any(getattr(o, "rotation", None) is not None
                       for o in [*self._obstacles, *(self._previous_obstacles or [])])
        model.place(self._obstacles, previous,
                    self._previous_obstacles if rotating and self._previous_obstacles else self._previous_delta)

    def _history(self) -> npt.NDArray[np.float64]:
        """The previous step's solution in the model's unknown (z = M⁻¹u for contact pairs; collective): finite
        sliding keeps it physical and maps it with the current pairing (the slip against the master material
        point beneath the node now)."""
        assert self._previous is not None
        return self.model.relative(self._previous) if self.finite_sliding else self._previous

    def _commit(self, result: SolveResult) -> None:
        """Make the converged ``result`` the history of the next step."""
        self._previous = np.array(result.displacement, dtype=np.float64)
        self._previous_delta = np.array([o.displacement for o in self._obstacles], dtype=np.float64).reshape(-1, 3)
        self._previous_obstacles = list(self._obstacles)
        self._step += 1

    # -- solving -----------------------------------------------------------------------------------
    #: The start of the last :meth:`initial_displacement`: "zero" (ũ = −d), "undeformed" (ũ = 0), "approach" (onto the
    #: obstacles, :mod:`~fenics_coulomb.model.rigid_approach`), "previous" (a path's previous step) or "given" (``u0``).
    last_start: str | None = None

    def initial_displacement(self, u0: dolfinx.fem.Function | None = None) -> npt.NDArray[np.float64]:
        """ũ⁽⁰⁾ on the owned DOFs: ``u0`` (on any mesh, interpolated), else the previous step's solution on a load path,
        else the start of ``settings.start`` (:meth:`start_rule`), a body held by contact alone brought onto its
        obstacles (:attr:`last_start`); the Dirichlet values of the last load assembly imposed (collective)."""
        model = self.model
        self.last_start = "given" if u0 is not None else "previous" if self._previous is not None else None
        if u0 is not None:
            start = model.relative(interpolate_displacement(u0, model.V))
        elif self._previous is not None:
            start = self._history().copy()
            approach = model.coupling.approach(model, start)  # a body the last step left off its obstacles
            start = start if approach is None else start + approach
        else:
            self.last_start = self.start_rule()
            shift = model.shift.getArray(readonly=True)
            start = -shift.copy() if self.last_start == "zero" else np.zeros_like(shift)
            approach = model.coupling.approach(model)
            if approach is not None:  # a body held by contact alone: onto its obstacles first (not "zero")
                start, self.last_start = approach, "approach"
                self._log("start: the body brought onto its obstacles along its free rigid motion(s)")
        start[model.dirichlet_rows] = model.dirichlet_values  # as assemble_load (in _place) read them
        return start

    def start_rule(self) -> str:
        """The start of ``settings.start`` for the loads and obstacles as placed: "zero" or "undeformed" as given,
        or for "auto" the one the undeformed body's residual points to (:func:`~fenics_coulomb.start_rule.auto_start`,
        where the rule is derived; collective: one approximation step at ũ = 0, no product with A, no linear
        solve)."""
        rule = self.settings.start
        if rule != "auto":
            return rule
        choice, message = auto_start(self.solver)
        self._log(message)
        return choice

    def solve(self, u0: dolfinx.fem.Function | None = None) -> tuple[dolfinx.fem.Function, SolveResult]:
        """Solve the next step of the load path from ``u0`` (default: the paper's u⁽⁰⁾ = 0 of the shifted
        unknown at the first step, the previous step's solution after it); a converged step becomes the
        history of the next one (see the module docstring). The load l̃ is assembled from the current values of
        the coefficients of L and of the Dirichlet conditions, the obstacles are placed at their current
        displacements (:meth:`move`); the bilinear form and the friction are those of the construction (a
        changed value is an InputError).

        The stopping target does not depend on the start (:mod:`fenics_coulomb.scd.stopping`): every start, a
        coarser level's solution interpolated included, is asked for the same solution. With the ``predictor``
        setting (or no contact node and ``no_contact_shortcut``) the linear problem is solved first; if it does
        not reach the obstacle it is the solution (one linear solve).

        Returns:
            The physical displacement (a Function on the problem's space, owned by the problem: copy it to
            keep it across solves) and the result (iterations, histories, contact states and forces).

        Raises:
            SolverError: when the method does not converge; ``error.result`` holds the last iterate and
                :attr:`u` its displacement.
        """
        self.model  # noqa: B018  (RuntimeError after destroy())
        self._state += 1
        if self.finite_sliding:
            return self._solve_finite(u0)
        self._place()
        result = self._solve_placed(self.initial_displacement(u0))
        self._verify(result)
        if self.sliding == "small" and result.converged:
            self._measure_slide(result)
        return self._finish(result, commit=result.converged), result

    def _solve_placed(self, start: npt.NDArray[np.float64], reduction: float | None = None) -> SolveResult:
        """One SCD solve of the model as placed, from ``start``, to ``reduction`` (default rtol; the predictor and
        the no-contact shortcut first when set; collective). A SolverError keeps its last iterate as :attr:`u`."""
        model, solver, settings = self.model, self.solver, self.settings
        finite = bool(np.all(np.isfinite(model.rhs.getArray(readonly=True))))
        check_all(model.comm, finite, "solve: the load is not finite: a NaN or infinite body force, traction, "
                  "prescribed displacement or other coefficient of L or of the boundary conditions")
        check_all(model.comm, bool(np.all(np.isfinite(start))), "solve: the start u0 is not finite (NaN or inf)")
        try:
            if (model.p == 0 and settings.no_contact_shortcut) or settings.predictor:
                result = solver.solve_linear()
                if model.p == 0 and not result.converged:  # no SCD solve after it
                    raise SolverError(f"no contact boundary: the linear solve failed ({result.reason})", result.reason,
                                      result)
                if model.p == 0 or (result.converged and solver.is_separated(result)):
                    self._log("no contact boundary: one linear solve" if model.p == 0 else
                              "the linear solution does not reach the obstacle: it is the solution")
                    return result
                self._log("the linear solution penetrates the obstacle: SCD semismooth* Newton")
            return solver.solve(start, reduction)
        except SolverError as err:
            if err.result is not None:
                err.result.checks = physics_residuals(model, err.result.displacement, balance=False,
                                                      accuracy=self._accuracy(err.result))
                self._finish(err.result)
            why = model.coupling.lost_support(model, None if err.result is None else
                                              np.asarray(err.result.states) != OPEN)
            if why is None:
                raise
            raise SolverError(f"{err}; {why}", err.reason, err.result) from err

    def _verify(self, result: SolveResult) -> None:
        """Let the physics checks decide a converged solve (collective): the residuals are kept in the result,
        and a failure (:func:`~fenics_coulomb.model.checks.physics_failure`) makes it a SolverError "physics_check"."""
        result.checks = physics_residuals(self.model, result.displacement, balance=False,
                                          accuracy=self._accuracy(result))
        rtol = result.rtol or self.settings.reduction
        failure = physics_failure(result.checks, rtol)
        model = self.model
        if not failure and self.finite_sliding:  # a body moved onto or past a cored obstacle in one solve
            failure = self._moved_through(result)
        if not failure:  # a body held by contact alone that no contact node holds
            failure = model.coupling.lost_support(model, np.asarray(result.states) != OPEN, lifted_only=True) or ""
        if result.converged and not failure and self.model.comm.rank == 0:
            for warning in reported_warnings(result.checks, rtol):
                logger.warning(warning)
        if result.converged and failure:
            result.converged, result.reason = False, "physics_check"
            self._finish(result)
            raise SolverError(failure, "physics_check", result)

    def _log(self, message: str) -> None:
        if self.model.comm.rank == 0:
            logger.info(message)

    def _finish(self, result: SolveResult, commit: bool = False) -> dolfinx.fem.Function:
        result.origin = (self._serial, self._state)
        result.timings["model"] = self.model_time
        finite = self.finite_sliding
        if commit and not finite:
            self._commit(result)  # small sliding keeps the history in the model's unknown (z for contact pairs)
        self.model.coupling.finish(self.model, result)  # contact pairs: u = M z, the master forces
        if commit and finite:
            self._commit(result)  # finite sliding keeps the physical u (mapped by the next step's pairing)
        set_owned_values(self.u, result.displacement)
        return self.u

    # -- cleanup -----------------------------------------------------------------------------------
    def destroy(self) -> None:
        """Destroy every PETSc object of the problem (collective)."""
        if self._solver is not None:
            self._solver.destroy()
            self._solver = None
        if self._model is not None:
            self._model.destroy()
            self._model = None

    def __enter__(self) -> ContactProblem:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *args: object) -> None:
        if exc_type is not None and not issubclass(exc_type, Exception):
            # KeyboardInterrupt, SIGTERM, SystemExit: the run ends, possibly from inside a PETSc call (the
            # matrix-free operator's mult), after which destroying the objects collectively can crash or hang
            return
        self.destroy()
