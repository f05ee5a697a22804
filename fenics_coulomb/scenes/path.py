"""Quasi-static load paths: the plan of solves and the path's run.

A path is a sequence of steps k = 1..N; step k is the static contact problem with its own tractions, body
force, prescribed displacements and obstacle displacements δₖ, with friction acting on the slip increment
s = T(uₖ − uₖ₋₁) − T(δₖ − δₖ₋₁) (u₀ = 0, δ₀ = 0). :class:`~fenics_coulomb.ContactProblem` keeps the history:
each ``solve()`` re-assembles the load from the current values of the coefficients of L and of the Dirichlet
values, places the obstacles at their current displacements and commits the step. This module and
:mod:`fenics_coulomb.scenes.loads` (each step's loads, and the form's coefficients set to them) supply what a
scene adds to that:

* :class:`PathSolve` and :func:`plan`: the solves of a path. ``--steps N`` ramps the scene's loads from 0
  with load factor j/N; ``[[path.step]]`` tables with ``substeps = m`` reach step k in m equal increments of
  every load from step k − 1's values (time = k − 1 + j/m, so a step's last solve has time k).
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

import dolfinx
import dolfinx.fem
import numpy as np

from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.model.obstacles import obstacle_names
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scenes.loads import (LoadState, StepLoads, blend_rotation, blend_vector, plain_rotation,
                                         scene_state, step_state, zero_state)
from fenics_coulomb.scenes.scene import Scene

__all__ = ["GROUP_KEYS", "INPUT_STOP", "PathSolve", "StepRecord", "contact_groups", "obstacle_labels", "plan",
           "remaining_time", "run_path"]

logger = logging.getLogger(__name__)

#: How :func:`run_path`'s reason starts when a later solve's input (its placement) was refused.
INPUT_STOP = "bad input at step "


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
    #: Contact pairs: the force on each pair's slave body (its master body takes the opposite).
    pair_forces: list[list[float]] = field(default_factory=list)
    #: Small sliding: the largest slide of a contact node in partner sizes and that node
    #: (:func:`~fenics_coulomb.model.small_sliding.largest_slide`); empty under finite sliding.
    small_sliding: dict[str, Any] = field(default_factory=dict)

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
            **({"pair_forces": self.pair_forces} if self.pair_forces else {}),
            "residual_history": self.residual_history,
            **({"free_slave_penetration": dict(self.free_slave_penetration)} if self.free_slave_penetration else {}),
            **({"small_sliding": dict(self.small_sliding)} if self.small_sliding else {}),
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
    groups: dict[str, Any],
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
            obstacle_rotations={name: plain_rotation(r) for name, r in zip(labels, rotations, strict=True)},
            wall_time_s=wall, residual_history=[float(r) for r in step_result.residual_history],
            geometry_updates=int(step_result.geometry_updates), groups=contact_groups(model, step_result),
            free_slave_penetration=dict(step_result.free_penetration),
            pair_forces=[[float(c) for c in p["force_on_slave_body"]] for p in report.pair_forces],
            small_sliding=dict(step_result.largest_slide))
        records.append(record)
        if solve.substeps == 1:
            where = f"step {solve.step}/{last_step} (load factor {solve.load_factor:.4g})"
        else:
            where = (f"step {solve.step}/{last_step}, substep {solve.substep}/{solve.substeps} "
                     f"(t = {solve.time:.4g}, weight {solve.weight:.4g})")
        walls.append(wall)
        left = len(solves) - i - 1
        eta = f", about {remaining_time(walls, left):.1f} s left" if left and not failure else ""
        # every solve whose contact geometry follows the deformation says how often it was evaluated again (0 too)
        updates = f", {record.geometry_updates} geometry update(s)" if problem.finite_sliding else ""
        forces = [f"contact force ({', '.join(f'{c:.6g}' for c in record.contact_force)})"] if model.obstacles else []
        forces += [f"pair {k + 1} on the slave side ({', '.join(f'{c:.6g}' for c in f)})"
                   for k, f in enumerate(record.pair_forces)]
        logger.info("solve %d/%d, %s: %s, %d Newton / %d Krylov iterations%s, open/stick/slip %d/%d/%d, %s, %.2f s%s",
                    i + 1, len(solves), where, "converged" if not failure else f"NOT converged ({failure})",
                    record.newton_iterations, record.krylov_iterations, updates, counts["open"], counts["stick"],
                    counts["slip"], ", ".join(forces) or "no contact force", wall, eta)
        if on_solve is not None:
            on_solve(solve, record, step_result)
        result = step_result
        if failure:
            return records, result, failure
    return records, result, ""
