"""Quasi-static load paths: the loads of each step applied in place, the plan of solves, the path's run.

A path is a sequence of steps k = 1..N; step k is the static contact problem with its own tractions, body
force, prescribed displacements and obstacle displacements δₖ, with friction acting on the slip increment
s = T(uₖ − uₖ₋₁) − T(δₖ − δₖ₋₁) (u₀ = 0, δ₀ = 0). :class:`~fenics_coulomb.ContactProblem` keeps the history:
each ``solve()`` re-assembles the load from the current values of the coefficients of L and of the Dirichlet
values, places the obstacles at their current displacements and commits the step. This module supplies
what a scene adds to that:

* :class:`LoadState`: every load of one step as plain data (tractions per boundary, body force,
  prescribed values per boundary, δ per scene obstacle); :func:`scene_state`, :func:`step_state`,
  :func:`zero_state` make them from a scene (what a ``[[path.step]]`` does not set takes the SCENE's value).
* :class:`PathSolve` and :func:`plan`: the solves of a path. ``--steps N`` ramps the scene's loads from 0
  with load factor j/N; ``[[path.step]]`` tables with ``substeps = m`` reach step k in m equal increments of
  every load from step k − 1's values (time = k − 1 + j/m, so a step's last solve has time k).
* :class:`StepLoads`: the load coefficients of the form (a vector Constant per boundary with constant
  tractions, a P1 Function where any state gives expressions, a body-force Constant, a Constant per
  prescribed boundary held by its DirichletBC), set to the blend (1 − w)·start + w·end of two states.
* :func:`run_path`: solve the planned steps in order, one record (:class:`StepRecord`) and one callback
  per solve; a step that does not converge stops the path.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import InputError, SolverError, check_all
from fenics_coulomb.model.obstacles import _rotation, obstacle_names
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scenes.scene import FREE, MAX_LOAD, PathStep, Scene

__all__ = ["ZERO", "GROUP_KEYS", "LoadState", "scene_state", "zero_state", "step_state", "blend_vector", "PathSolve",
           "plan", "obstacle_labels", "StepLoads", "StepRecord", "contact_groups", "remaining_time", "run_path",
           "INPUT_STOP"]

logger = logging.getLogger(__name__)

#: How :func:`run_path`'s reason starts when a later solve's input (its placement) was refused.
INPUT_STOP = "bad input at step "

#: A traction: three components, each a number or a function of points x (shape (3, m)).
Traction = tuple[Any, Any, Any]
ZERO = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class LoadState:
    """All loads of one step (GPa, the mesh's length unit).

    Attributes:
        tractions: Boundary name → traction (numbers or callables of x; the load scale applied).
        body_force: The body force.
        prescribed: Boundary name → prescribed displacement (every boundary of the scene's ``[prescribed]``).
        obstacles: δ of each scene obstacle, in scene order.
        rotations: The rotation [angle_deg, axis, centre] of each scene obstacle (None: none), in scene order.
    """

    tractions: dict[str, Traction]
    body_force: tuple[float, float, float]
    prescribed: dict[str, tuple[float, float, float]]
    obstacles: tuple[tuple[float, float, float], ...]
    rotations: tuple[Any, ...] = ()


def _vec(value: Sequence[float]) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


def _held(value: Sequence[float | str]) -> tuple[float, float, float]:
    """A ``[prescribed]`` value as 3 numbers ("free" components, which no condition holds, as 0)."""
    return _vec([0.0 if c == FREE else c for c in value])  # type: ignore[misc]


def scene_state(scene: Scene) -> LoadState:
    """The scene's own loads (its static problem)."""
    return LoadState(tractions=dict(scene.traction_table()), body_force=_vec(scene.load.body_force),
                     prescribed={k: _held(v) for k, v in scene.prescribed.items()},
                     obstacles=tuple(_vec(o.displacement) for o in scene.obstacles),
                     rotations=tuple(getattr(o, "rotation", None) for o in scene.obstacles))


def zero_state(scene: Scene) -> LoadState:
    """Step 0 of every path: no load, δ = 0, prescribed displacements 0."""
    return LoadState(tractions={}, body_force=ZERO, prescribed={k: ZERO for k in scene.prescribed},
                     obstacles=tuple(ZERO for _ in scene.obstacles), rotations=tuple(None for _ in scene.obstacles))


def step_state(scene: Scene, step: PathStep) -> LoadState:
    """The loads of a ``[[path.step]]``: its values, and the scene's where it sets none (per boundary for
    tractions and prescribed displacements, per obstacle for δ)."""
    base = scene_state(scene)
    tractions = {**base.tractions, **{k: scene.scaled_traction(k, v) for k, v in step.tractions.items()}}
    names = [getattr(o, "name", None) for o in scene.obstacles]
    obstacles = tuple(_vec(step.move[name]) if name is not None and name in step.move else delta
                      for name, delta in zip(names, base.obstacles, strict=True))
    rotations = tuple(_rotation(step.rotate[name], f"[[path.step]] rotate of {name!r}")
                      if name is not None and name in step.rotate else rotation
                      for name, rotation in zip(names, base.rotations, strict=True))
    return LoadState(tractions=tractions,
                     body_force=base.body_force if step.body_force is None else _vec(step.body_force),
                     prescribed={k: _held(step.prescribed.get(k, v)) for k, v in base.prescribed.items()},
                     obstacles=obstacles, rotations=rotations)


def blend_rotation(a: Any, b: Any, w: float) -> Any:
    """The rotation between ``a`` and ``b`` at weight w: the angle blended about b's axis and centre (a None is
    the angle 0 about them); two rotations about different axes or centres cannot be blended (InputError)."""
    if b is None and a is None:
        return None
    if a is None:
        a = (0.0, b[1], b[2])
    if b is None:
        b = (0.0, a[1], a[2])
    if w == 1.0:
        return b
    if w == 0.0:
        return a
    if not (np.allclose(a[1], b[1], rtol=0, atol=1e-12) and np.allclose(a[2], b[2], rtol=0, atol=1e-12)):
        raise InputError(f"substeps between rotations about different axes or centres ({a} and {b}): give the "
                         "step one substep, or rotate about one axis and centre")
    return (_blend(a[0], b[0], w), b[1], b[2])


def _plain_rotation(rotation: Any) -> list | None:
    """A rotation as plain JSON data [angle_deg, [ax, ay, az], [cx, cy, cz]] (None: none)."""
    if rotation is None:
        return None
    angle, axis, centre = rotation
    return [float(angle), [float(c) for c in axis], [float(c) for c in centre]]


def _blend(a: float, b: float, w: float) -> float:
    """(1 − w)·a + w·b: exactly b at w = 1, exactly a at w = 0."""
    return (1.0 - w) * a + w * b


def blend_vector(a: Sequence[float], b: Sequence[float], w: float) -> tuple[float, float, float]:
    """Component-wise :func:`_blend` of two 3-vectors."""
    return (_blend(a[0], b[0], w), _blend(a[1], b[1], w), _blend(a[2], b[2], w))


@dataclass(frozen=True)
class PathSolve:
    """One solve of a path: the blend (1 − weight)·start + weight·end of two load states.

    Attributes:
        index: 1-based number of the solve in the path.
        time: The output time: the step number (k − 1 + j/m for substep j of m of step k).
        step: The path step k it belongs to (1-based).
        substep: j (1..substeps).
        substeps: m.
        weight: The blend weight j/m (for ``--steps N``: the load factor k/N, with start = 0).
        load_factor: k/N for ``--steps N``; the blend weight j/m within the step for ``[[path.step]]``.
        start: The state of the previous step (weight 0).
        end: The state of this step (weight 1).
    """

    index: int
    time: float
    step: int
    substep: int
    substeps: int
    weight: float
    load_factor: float
    start: LoadState
    end: LoadState

    @property
    def obstacle_displacements(self) -> list[tuple[float, float, float]]:
        """δ of each scene obstacle at this solve."""
        return [blend_vector(a, b, self.weight) for a, b in zip(self.start.obstacles, self.end.obstacles,
                                                                  strict=True)]

    @property
    def obstacle_rotations(self) -> list[Any]:
        """The rotation of each scene obstacle at this solve (None: none)."""
        start = self.start.rotations or (None,) * len(self.start.obstacles)
        end = self.end.rotations or (None,) * len(self.end.obstacles)
        return [blend_rotation(a, b, self.weight) for a, b in zip(start, end, strict=True)]


def plan(scene: Scene, steps: int | None = None) -> list[PathSolve]:
    """The solves of the scene's path: ``steps`` (``--steps N``: the scene's loads times k/N, k = 1..N) or the
    scene's ``[[path.step]]`` tables (with their substeps); empty for a static scene without ``steps``."""
    zero = zero_state(scene)
    if steps is not None:
        end = scene_state(scene)
        return [PathSolve(index=k, time=float(k), step=k, substep=1, substeps=1, weight=k / steps,
                          load_factor=k / steps, start=zero, end=end) for k in range(1, steps + 1)]
    solves: list[PathSolve] = []
    previous = zero
    for k, table in enumerate(scene.path, 1):
        state = step_state(scene, table)
        m = int(table.substeps)
        for j in range(1, m + 1):
            t = float(k) if j == m else (k - 1) + j / m
            solves.append(PathSolve(index=len(solves) + 1, time=t, step=k, substep=j, substeps=m, weight=j / m,
                                    load_factor=j / m, start=previous, end=state))
        previous = state
    for solve in solves:  # rotations that cannot be blended fail here, before anything is solved
        _ = solve.obstacle_rotations
    return solves


def obstacle_labels(scene: Scene) -> list[str]:
    """Names of the scene's obstacles for records and columns
    (:func:`~fenics_coulomb.model.obstacles.obstacle_names`)."""
    return obstacle_names(scene.obstacles)


class StepLoads:
    """The load coefficients of a scene's load form, updated in place for each solve of a path.

    Per boundary a vector ``Constant`` (constant tractions) or a P1 ``Function`` (where any of the given
    states has an expression), a body-force ``Constant``, and a ``Constant`` per prescribed boundary (the
    value its DirichletBC holds: give ``prescribed`` to the builder's Dirichlet conditions). Constructed
    with the values of ``initial`` (the scene's static problem), so that a static scene's form is that of a
    plain build.

    Args:
        V: The displacement space.
        facet_tags: The boundary facet tags.
        tags: Boundary name → facet tag.
        initial: The state whose values the coefficients start with.
        states: Every state a path may blend (decides which boundaries carry a Function); the boundaries of
            all states get a coefficient.
    """

    def __init__(self, V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags, tags: dict[str, int],
                 initial: LoadState, states: Sequence[LoadState] = ()) -> None:
        msh = V.mesh
        self.V = V
        self.facet_tags = facet_tags
        self.tags = dict(tags)
        boundaries = list(initial.tractions)
        for state in states:
            boundaries += [name for name in state.tractions if name not in boundaries]
        fields = {name for state in (initial, *states) for name, value in state.tractions.items()
                  if any(callable(c) for c in value)}
        #: Boundary name → its traction coefficient (Constant or P1 Function).
        self.tractions: dict[str, dolfinx.fem.Constant | dolfinx.fem.Function] = {}
        for name in boundaries:
            if name in fields:
                self.tractions[name] = dolfinx.fem.Function(V)
            else:
                self.tractions[name] = dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))
        self.body_force = dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))
        #: Prescribed boundary name → the Constant its DirichletBC holds.
        self.prescribed = {name: dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))
                           for name in initial.prescribed}
        #: Prescribed boundary name → a scalar Constant per component (the values of the conditions on single
        #: components, ``V.sub(i)``, of a boundary with "free" components), set with :attr:`prescribed`.
        self.prescribed_components = {name: [dolfinx.fem.Constant(msh, PETSc.ScalarType(0.0)) for _ in range(3)]
                                      for name in initial.prescribed}
        # keyed by the traction itself (numbers and callables, held by the key): an id() of a state could be
        # reused by a later state once the first is freed, and hand it the first state's field
        self._cache: dict[Traction, npt.NDArray[np.float64]] = {}
        for state in (initial, *states):  # every expression evaluated and checked before anything is solved
            for name in fields & set(state.tractions):
                self._check_field(name, state.tractions[name], self._field(state, name))
        self.apply(initial, initial, 1.0)

    def _check_field(self, name: str, traction: Traction, values: npt.NDArray[np.float64]) -> None:
        """InputError on every rank unless the traction ``name`` is finite and at most MAX_LOAD at every node of
        its boundary (collective): an expression that overflows or divides by zero there would give a load of
        inf or 1e300 that no solver reports."""
        V = self.V
        facets = self.facet_tags.find(self.tags[name])
        blocks = dolfinx.fem.locate_dofs_topological(V, V.mesh.topology.dim - 1, facets)
        blocks = blocks[blocks < V.dofmap.index_map.size_local]
        at = values.reshape(-1, 3)[blocks]
        bad = np.flatnonzero(~(np.all(np.isfinite(at), axis=1) & np.all(np.abs(at) <= MAX_LOAD, axis=1)))
        message = ""
        if bad.size:
            x = V.tabulate_dof_coordinates()[blocks[bad[0]]]
            text = [getattr(c, "__name__", c) if callable(c) else c for c in traction]
            message = (f"traction on {name!r} = {text}: {at[bad[0]].tolist()} at the boundary node "
                       f"({', '.join(f'{c:.6g}' for c in x)}) is not finite or exceeds {MAX_LOAD:g} GPa in magnitude")
        check_all(V.mesh.comm, not message, message)

    def form(self, v: ufl.Argument) -> ufl.Form:
        """The load form ∫ f·v dx + Σ ∫ t_b·v ds(b) on the coefficients (built once)."""
        msh = self.V.mesh
        ds = ufl.Measure("ds", domain=msh, subdomain_data=self.facet_tags)
        L = ufl.inner(self.body_force, v) * ufl.dx
        for name, coefficient in self.tractions.items():
            L = L + ufl.inner(coefficient, v) * ds(self.tags[name])
        return L

    def _field(self, state: LoadState, name: str) -> npt.NDArray[np.float64]:
        """The traction of ``state`` on ``name`` interpolated into P1 (cached per traction; local array)."""
        value = key = tuple(state.tractions.get(name, ZERO))
        if key not in self._cache:
            g = dolfinx.fem.Function(self.V)
            g.interpolate(lambda x: np.vstack(
                [c(x) if callable(c) else np.full(x.shape[1], float(c)) for c in value]))
            self._cache[key] = g.x.array.copy()
        return self._cache[key]

    def apply(self, start: LoadState, end: LoadState, weight: float) -> None:
        """Set every coefficient to (1 − weight)·start + weight·end (no communication)."""
        for name, coefficient in self.tractions.items():
            if isinstance(coefficient, dolfinx.fem.Function):
                a, b = self._field(start, name), self._field(end, name)
                coefficient.x.array[:] = b if weight == 1.0 else (1.0 - weight) * a + weight * b
            else:
                coefficient.value[:] = blend_vector(start.tractions.get(name, ZERO),
                                                    end.tractions.get(name, ZERO), weight)
        self.body_force.value[:] = blend_vector(start.body_force, end.body_force, weight)
        for name, constant in self.prescribed.items():
            constant.value[:] = blend_vector(start.prescribed.get(name, ZERO), end.prescribed.get(name, ZERO), weight)
            for component, value in zip(self.prescribed_components[name], constant.value, strict=True):
                component.value = value


@dataclass
class StepRecord:
    """What one solve of a path reports (identical on all ranks)."""

    index: int
    time: float
    step: int
    substep: int
    substeps: int
    load_factor: float
    converged: bool
    reason: str
    newton_iterations: int
    krylov_iterations: int
    counts: dict[str, int]
    contact_force: list[float]
    applied_load: list[float]
    reactions: dict[str, list[float]]
    obstacle_displacements: dict[str, list[float]]
    wall_time_s: float
    residual_history: list[float] = field(default_factory=list)
    #: Each obstacle's rotation [angle_deg, [ax, ay, az], [cx, cy, cz]] at this solve (None: not rotated).
    obstacle_rotations: dict[str, Any] = field(default_factory=dict)
    #: Finite sliding: the geometry updates of this solve (:mod:`fenics_coulomb.model.sliding`).
    geometry_updates: int = 0
    #: Contact pairs: the free slave nodes that penetrate the master, {"nodes", "depth"}; empty when none does.
    free_slave_penetration: dict[str, Any] = field(default_factory=dict)
    #: Per obstacle (its name) and contact pair ("pair NAME"): normal and tangential force, peak pressure, contact
    #: area, nodes in contact, open/stick/slip nodes (:func:`contact_groups`).
    groups: dict[str, dict[str, Any]] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """The record as plain data (summary.json "steps")."""
        return {
            "index": self.index, "time": self.time, "step": self.step, "substep": self.substep,
            "substeps": self.substeps, "load_factor": self.load_factor, "converged": self.converged,
            "reason": self.reason, "newton_iterations": self.newton_iterations,
            "krylov_iterations": self.krylov_iterations, "geometry_updates": self.geometry_updates,
            "state_counts": dict(self.counts),
            "contact_force": self.contact_force, "applied_load": self.applied_load, "reactions": self.reactions,
            "obstacle_displacements": self.obstacle_displacements, "obstacle_rotations": self.obstacle_rotations,
            "groups": self.groups, "wall_time_s": self.wall_time_s,
            "residual_history": self.residual_history,
            **({"free_slave_penetration": dict(self.free_slave_penetration)} if self.free_slave_penetration else {}),
        }


#: The quantities of each obstacle and contact pair a path records per solve (:func:`contact_groups`).
GROUP_KEYS = ("normal_force", "tangential_force", "peak_pressure", "contact_area", "contact_nodes", "open", "stick",
              "slip")


def contact_groups(model: Any, result: SolveResult) -> dict[str, dict[str, Any]]:
    """Per obstacle (keyed by its name) and per contact pair (keyed "pair NAME", or "pair N" unnamed) the
    :data:`GROUP_KEYS` of :func:`~fenics_coulomb.io.fields.contact_statistics` (collective)."""
    from fenics_coulomb.io.fields import contact_statistics

    statistics = contact_statistics(model, result)
    groups = {name: {key: entry[key] for key in GROUP_KEYS} for name, entry in statistics["obstacles"].items()}
    for entry in statistics["contact_pairs"]:
        name = entry["name"] if entry["name"].startswith("pair ") else f"pair {entry['name']}"
        groups[name] = {key: entry[key] for key in GROUP_KEYS}
    return groups


def remaining_time(walls: Sequence[float], left: int) -> float:
    """The expected wall time of the ``left`` solves still to run, from the wall times ``walls`` of those done.

    The first solve of a path starts from the undeformed body (or a start file) and settles the contact set
    from scratch; every later one starts from the previous step's solution and changes it by one increment,
    so it is typically several times cheaper. The estimate is therefore the median of the solves after the
    first (robust to one slow step) times ``left``, and the first solve's own time only while it is the only
    one done (an overestimate then, which the next line corrects).
    """
    if left <= 0 or not walls:
        return 0.0
    warm = walls[1:] if len(walls) > 1 else walls
    return float(np.median(warm)) * left


def run_path(
    problem: Any,
    loads: StepLoads,
    solves: Sequence[PathSolve],
    labels: Sequence[str],
    groups: dict[str, npt.NDArray[np.int32]],
    u0: dolfinx.fem.Function | None = None,
    on_solve: Callable[[PathSolve, StepRecord, SolveResult], None] | None = None,
    last_step: int | None = None,
) -> tuple[list[StepRecord], SolveResult | None, str]:
    """Solve ``solves`` in order on ``problem`` (a path-aware ContactProblem) (collective).

    Before each solve the load coefficients take the solve's blend and the scene obstacles are moved to their
    δ; the first solve starts from ``u0`` (or the problem's own start), every later one from the previous
    solution (the problem's history). After each solve, converged or not, ``on_solve(solve, record,
    result)`` is called (e.g. to append the output grid). A solve that does not converge stops the path.

    Args:
        problem: The ContactProblem built with ``loads``' form and prescribed Constants.
        loads: The load coefficients.
        solves: The solves to run (e.g. :func:`plan`'s, or its tail for a resumed path).
        labels: A name per scene obstacle (:func:`obstacle_labels`).
        groups: Local DOF blocks per Dirichlet boundary (for the reactions).
        u0: Start of the first solve (default: the problem's).
        on_solve: Called after every solve.
        last_step: Number of steps of the whole path (for the progress line; default the last solve's step).

    Returns:
        The records, the last solve's result (None if ``solves`` is empty) and "" or the reason the path
        stopped: a solve that did not converge (its record and result are the last), or, starting with
        :data:`INPUT_STOP`, an InputError of a later solve's placement (an obstacle buried in or moved through the
        body where the previous solve left it; the records and result are the solves before it). An InputError of
        the first solve is raised.
    """
    from fenics_coulomb.report import make_report

    model = problem.model
    comm: MPI.Comm = model.comm
    last_step = last_step or (solves[-1].step if solves else 0)
    records: list[StepRecord] = []
    result: SolveResult | None = None
    walls: list[float] = []  # each solve's wall time, for the remaining time (remaining_time)
    for i, solve in enumerate(solves):
        t0 = time.perf_counter()
        loads.apply(solve.start, solve.end, solve.weight)
        deltas, rotations = solve.obstacle_displacements, solve.obstacle_rotations
        failure = ""
        try:
            for j, (delta, rotation) in enumerate(zip(deltas, rotations, strict=True)):
                problem.move(j, delta, rotation=rotation)
            step_result: SolveResult
            _, step_result = problem.solve(u0 if i == 0 else None)
        except SolverError as err:
            if err.result is None:
                raise
            step_result = err.result
            failure = str(err)
        except InputError as err:  # a placement only the body's configuration refuses: keep the steps before it
            if not records:
                raise
            return records, result, f"{INPUT_STOP}{solve.step}: {err}"
        if not failure and not step_result.converged:
            failure = step_result.reason
        wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        counts = step_result.counts
        report = make_report(model, step_result, model.obstacles, groups)  # the forces: one definition
        record = StepRecord(
            index=solve.index, time=solve.time, step=solve.step, substep=solve.substep, substeps=solve.substeps,
            load_factor=solve.load_factor, converged=not failure, reason=failure or step_result.reason,
            newton_iterations=int(step_result.iterations), krylov_iterations=int(step_result.krylov_iterations),
            counts=dict(counts), contact_force=[float(c) for c in report.total_force],
            applied_load=[float(c) for c in report.applied_load],
            reactions={name: [float(c) for c in v] for name, v in report.reactions.items()},
            obstacle_displacements={name: list(d) for name, d in zip(labels, deltas, strict=True)},
            obstacle_rotations={name: _plain_rotation(r) for name, r in zip(labels, rotations, strict=True)},
            wall_time_s=wall, residual_history=[float(r) for r in step_result.residual_history],
            geometry_updates=int(step_result.geometry_updates), groups=contact_groups(model, step_result),
            free_slave_penetration=dict(step_result.free_penetration))
        records.append(record)
        if solve.substeps == 1:
            where = f"step {solve.step}/{last_step} (load factor {solve.load_factor:.4g})"
        else:
            where = (f"step {solve.step}/{last_step}, substep {solve.substep}/{solve.substeps} "
                     f"(t = {solve.time:.4g}, weight {solve.weight:.4g})")
        walls.append(wall)
        left = len(solves) - i - 1
        eta = f", about {remaining_time(walls, left):.1f} s left" if left and not failure else ""
        updates = f", {record.geometry_updates} geometry update(s)" if record.geometry_updates else ""
        logger.info("solve %d/%d, %s: %s, %d Newton / %d Krylov iterations%s, open/stick/slip %d/%d/%d, contact "
                    "force (%s), %.2f s%s", i + 1, len(solves), where,
                    "converged" if not failure else f"NOT converged ({failure})",
                    record.newton_iterations, record.krylov_iterations, updates, counts["open"], counts["stick"],
                    counts["slip"], ", ".join(f"{c:.6g}" for c in record.contact_force), wall, eta)
        if on_solve is not None:
            on_solve(solve, record, step_result)
        result = step_result
        if failure:
            return records, result, failure
    return records, result, ""
