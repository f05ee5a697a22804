"""Run a scene as the command line does: one solve, or a load path, into a result directory.

:func:`run` validates the scene's values before any collective call (memory, start file, path arguments,
nested levels), builds the problem (:func:`~fenics_coulomb.scenes.builder.build_problem`), solves (from the
coarse levels of nested iteration when they apply) and writes the result set with
:func:`~fenics_coulomb.io.writer.write_result_set`; :func:`run_load_path` solves the steps of a path into a
:class:`~fenics_coulomb.io.writer.PathResultSet` (one grid per solve). Both run check → build → solve or path →
write → print. Each returns the exit status."""

from __future__ import annotations

import argparse
import json
import logging
import shlex
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from fenics_coulomb.errors import InputError, SolverError, check_all
from fenics_coulomb.errors import EXIT_DIVERGED
from fenics_coulomb.io.results import FAILED_SUFFIX, ResultDirectory
from fenics_coulomb.io.start import check_start_file, start_function
from fenics_coulomb.io.writer import PathResultSet, add_figures, write_result_set
from fenics_coulomb.model.dof_values import set_owned_values
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.cuboid import expected_sizes
from fenics_coulomb.scenes.nested import (NESTED_LEVEL_STEP, nested_levels, resolve_nested, solve_coarse_levels,
                                          start_from_coarse)
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.settings import ERROR_PER_RTOL, START_RULES, rtol_and_accuracy, rtol_for_accuracy

if TYPE_CHECKING:
    from fenics_coulomb.scd.records import SolveResult
    from fenics_coulomb.scenes.path import PathSolve, StepRecord

__all__ = ["BYTES_PER_UNKNOWN", "BYTES_PER_RANK", "scene_from_args", "prepare_output", "run",
           "check_path_arguments", "run_load_path", "friction_text", "force_lines", "contact_lines", "check_memory",
           "available_memory"]

logger = logging.getLogger("fenics_coulomb")


#: Peak memory (summed over ranks) of a cuboid solve: a base per rank plus bytes per unknown. With the
#: matrix-free Newton operator the measured peak RSS (docs/scale/idle-2026-11-23-2ranks-default-ptap, d3/L2,
#: GAMG, 2 ranks) is 1042 MiB at 209 088 and 6228 MiB at 1 622 400 unknowns: 3.84 kB per unknown above
#: ~150 MiB per rank; 4.2 kB leaves 10 % (the explicit Newton matrix of ILU/LU needs more: 5.1 kB, docs/table2).
BYTES_PER_UNKNOWN = 4.2e3


BYTES_PER_RANK = 150 * 2**20


def scene_from_args(args: argparse.Namespace) -> Scene:
    """Defaults < scene file < flags; raises InputError naming any bad value (no communication)."""
    if args.scene is not None and not args.scene.strip():
        raise InputError(f"--scene {args.scene!r}: give a scene file (TOML), or leave --scene out for the defaults")
    scene = Scene.from_toml(args.scene) if args.scene else Scene()
    _check_accuracy_and_rtol(scene, args)
    return scene.override(
        lev=args.lev, gap=args.gap, load=args.load, load_scale=args.load_scale, young=args.young,
        poisson=args.poisson, friction=args.friction, variant=args.variant, tol=args.tol, rtol=args.rtol,
        max_it=args.max_it, pc=args.pc, gamma_scale=args.gamma_scale, start=args.start, predictor=args.predictor,
        accuracy=args.accuracy, adaptive_tol=args.adaptive_tol, matrix_free=args.matrix_free,
        sliding=getattr(args, "sliding", None),
    )


def _check_accuracy_and_rtol(scene: Scene, args: argparse.Namespace) -> None:
    """``accuracy`` sets the residual reduction itself (rtol = accuracy/ERROR_PER_RTOL): both given in one place
    (the flags, or the scene's [solver]) is an InputError naming both; a flag replaces the scene's other one (said
    in one line on rank 0)."""
    rtol, accuracy = getattr(args, "rtol", None), getattr(args, "accuracy", None)
    if rtol is not None and accuracy is not None:
        raise InputError(f"--rtol {rtol:g} and --accuracy {accuracy:g}: give one (--accuracy sets the residual "
                         f"reduction itself, rtol = accuracy/{ERROR_PER_RTOL:g})")
    if {"rtol", "accuracy"} <= scene.given and scene.solver.accuracy is not None:
        raise InputError(rtol_and_accuracy(scene.solver.rtol, scene.solver.accuracy))
    if accuracy is not None and "rtol" in scene.given:
        logger.warning("--accuracy %g replaces the scene's rtol = %g (residual reduction %.3g)", accuracy,
                       scene.solver.rtol, rtol_for_accuracy(accuracy) if accuracy > 0 else float("nan"))
    elif rtol is not None and scene.solver.accuracy is not None:
        logger.warning("--rtol %g replaces the scene's accuracy = %g", rtol, scene.solver.accuracy)


def prepare_output(comm: MPI.Comm, out: str) -> ResultDirectory:
    """Check that the result set can go to ``out``; raise InputError on every rank if it cannot."""
    return ResultDirectory(comm, out)


def run(args: argparse.Namespace, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """Solve the scene described by ``args``; return the exit status."""
    t0 = time.perf_counter()
    scene = scene_from_args(args).with_scene_defaults()
    if not args.out.strip():
        raise InputError(f"--out {args.out!r}: give an output directory (an empty name would write into the "
                         "current directory)")
    check_memory(comm, scene)
    if scene.start not in START_RULES:
        check_start_file(comm, scene.start)
    nested = args.nested
    check_all(comm, nested is None or (not isinstance(nested, bool) and isinstance(nested, int) and nested >= 0),
              f"--nested {nested!r}: must be an integer >= 0")
    solves = check_path_arguments(comm, scene, args)
    if solves is not None:
        return run_load_path(args, comm, scene, solves, t0)
    nested = resolve_nested(nested, scene)
    if nested:
        check_all(comm, scene.body.shape == "cuboid", "--nested: nested iteration needs the cuboid body (lev)")
        check_all(comm, NESTED_LEVEL_STEP * nested <= scene.body.lev, f"--nested {nested}: the coarsest level "
                  f"would be lev {scene.body.lev - NESTED_LEVEL_STEP * nested} (lev = {scene.body.lev}, "
                  f"every nested level {NESTED_LEVEL_STEP} levels coarser)")
    out = prepare_output(comm, args.out)

    t_nested = time.perf_counter()
    coarse = solve_coarse_levels(scene, nested, comm) if nested else None
    t_nested = time.perf_counter() - t_nested
    built = build_problem(scene, comm)
    with built.problem as problem:
        t_model = time.perf_counter() - t0 - t_nested
        logger.info("%s: n = %d unknowns, p = %d contact nodes, %s, %d rank(s)", built.body.description,
                    problem.n, problem.p, friction_text(scene), comm.size)
        status, finite = 0, problem.finite_sliding
        try:
            t_start = time.perf_counter()
            u0 = start_from_coarse(coarse, scene, problem.V) if coarse else start_function(scene.start, problem.V)
            t_nested += time.perf_counter() - t_start
            _, result = problem.solve(u0)
        except SolverError as err:
            result = err.result
            status = EXIT_DIVERGED
            logger.error("fenics-coulomb: the solve did not converge: %s", err)
        if status == 0 and not result.converged:  # e.g. the linear solve of a body without contact nodes
            status = EXIT_DIVERGED
            logger.error("fenics-coulomb: the solve did not converge: %s", result.reason)
        t_write = time.perf_counter()
        out.failed = status != 0
        with out.writing() as tmp:
            data = write_result_set(
                tmp, problem, result, reactions=built.dirichlet_groups,
                extra={"scene": scene.as_dict(), "settings": vars(problem.settings), "body": built.body.description,
                       "nested": {"levels": nested_levels(scene.body.lev, nested) if coarse else [],
                                  "newton_iterations": [r.iterations for r in coarse.results] if coarse else [],
                                  "krylov_iterations": [r.krylov_iterations for r in coarse.results] if coarse
                                  else []}},
                timings={"model": t_model, "nested": t_nested, "mesh": built.mesh_time,
                         "assembly": problem.model_time}, started=t_write, wall_start=t0)
        if not args.no_plots:  # once the set is in place: an interrupt meanwhile leaves it without them
            from fenics_coulomb.io.figures import write_figures

            add_figures(out, data, lambda directory: write_figures(directory, problem.model, result, scene.label),
                        wall=True)
    counts = data["state_counts"]
    if comm.rank == 0:
        print(
            f"{'converged' if result.converged else 'NOT converged (' + result.reason + ')'}: "
            f"{result.iterations} Newton / {result.krylov_iterations} Krylov iterations, "
            + (f"{result.geometry_updates} geometry update(s), " if finite else "") +
            f"open/stick/slip {counts['open']}/{counts['stick']}/{counts['slip']}, "
            f"{data['wall_time_s']:.2f} s; results in {_shown(out, data['files'])}",
            flush=True,
        )
        print("\n".join(force_lines(data, scene)), flush=True)
        print("\n".join(contact_lines(data)), flush=True)
    return status


def check_path_arguments(comm: MPI.Comm, scene: Scene, args: argparse.Namespace) -> list | None:
    """Validate ``--steps``, ``--start-step`` and the scene's path (InputError on every rank); return the
    path's solves (:func:`fenics_coulomb.scenes.path.plan`) or None for a static run (collective)."""
    from fenics_coulomb.scenes.scene import MAX_PATH_SOLVES
    from fenics_coulomb.scenes.path import plan

    steps, start_step = getattr(args, "steps", None), getattr(args, "start_step", None)
    if steps is not None:
        check_all(comm, not isinstance(steps, bool) and 1 <= steps <= MAX_PATH_SOLVES,
                  f"--steps {steps!r}: must be an integer in [1, {MAX_PATH_SOLVES}]")
        check_all(comm, not scene.path, f"--steps {steps}: the scene defines its own load path "
                  f"({len(scene.path)} [[path.step]] tables); give either --steps or [[path.step]], not both")
    if steps is None and not scene.path:
        check_all(comm, start_step is None, f"--start-step {start_step}: only for a load path (--steps N or "
                  "[[path.step]] tables in the scene)")
        return None
    check_all(comm, not args.nested, "--nested: nested iteration is not available for a load path")
    solves = plan(scene, steps)
    if start_step is not None:
        last = solves[-1].step
        check_all(comm, scene.start not in START_RULES, f"--start-step {start_step}: give the earlier "
                  "path's solution.xdmf with --start FILE")
        check_all(comm, not isinstance(start_step, bool) and 1 <= start_step < last,
                  f"--start-step {start_step}: must lie in [1, {last - 1}] (the path has {last} steps; the last "
                  "one is solved after it)")
        message = ""
        if comm.rank == 0:
            from fenics_coulomb.io.xdmf_read import solution_datasets

            try:
                info = solution_datasets(Path(scene.start), float(start_step))
                if not info["converged"]:
                    message = f"its step {start_step} did not converge"
            except (OSError, ValueError, KeyError, ET.ParseError) as err:
                message = f"no step {start_step} in it ({err})"
            if not message:
                message = _other_path(Path(scene.start), scene, steps, start_step)
            if message:
                message = f"--start {scene.start!r} --start-step {start_step}: {message}"
        message = comm.bcast(message, root=0)
        check_all(comm, not message, message)
    return solves


#: The parts of a scene a resumed path may change: how it is solved, its name, not what is solved.
RESUMABLE_CHANGES = ("solver", "start", "given", "name")


def _first_difference(before: Any, now: Any, where: str) -> str:
    """Where two JSON values first differ, as "where: before against now" ("" when equal)."""
    if isinstance(before, dict) and isinstance(now, dict):
        for key in sorted(set(before) | set(now)):
            found = _first_difference(before.get(key), now.get(key), f"{where}.{key}")
            if found:
                return found
        return ""
    if isinstance(before, list) and isinstance(now, list) and len(before) == len(now):
        for i, (a, b) in enumerate(zip(before, now, strict=True)):
            found = _first_difference(a, b, f"{where}[{i}]")
            if found:
                return found
        return ""
    return "" if before == now else f"{where} = {json.dumps(before)[:80]} there, {json.dumps(now)[:80]} here"


def _comparable(scene: dict[str, Any], steps_done: int) -> dict[str, Any]:
    """A scene's summary.json entry as a resumed path compares it: without RESUMABLE_CHANGES, files by their name
    (a path is relative to where the command ran), the steps after the resumed one left out (they may change)."""
    data = {key: value for key, value in scene.items() if key not in RESUMABLE_CHANGES}
    data = json.loads(json.dumps(data))
    if isinstance(data.get("body"), dict) and data["body"].get("mesh"):
        data["body"]["mesh"] = Path(str(data["body"]["mesh"])).name
    for obstacle in data.get("obstacles") or []:
        if isinstance(obstacle, dict) and obstacle.get("file"):
            obstacle["file"] = Path(str(obstacle["file"])).name
    if isinstance(data.get("path"), list):
        data["path"] = data["path"][:steps_done]
    return data


def _other_path(start: Path, scene: Scene, steps: int | None, start_step: int) -> str:
    """"" when the result set of ``start`` (its summary.json beside it) was written by the same load path as
    ``scene`` with ``--steps`` ``steps`` up to its step ``start_step`` (:func:`_comparable`), else what differs
    (rank 0)."""
    summary = start.with_name("summary.json")
    try:
        earlier = json.loads(summary.read_text())
    except (OSError, ValueError) as err:
        return f"its result set has no readable summary.json ({err}), which says what path it belongs to"
    if not isinstance(earlier.get("scene"), dict):
        return "its summary.json holds no scene"
    difference = _first_difference(_comparable(earlier["scene"], start_step), _comparable(scene.as_dict(), start_step),
                                   "scene")
    if difference:
        return (f"the earlier path is another scene ({difference}); a resumed path may change [solver] and the "
                f"steps after {start_step} only")
    ramp = (earlier.get("path") or {}).get("ramp_steps")
    if ramp != steps:
        return f"the earlier path ran with --steps {ramp}, this one with --steps {steps}"
    return ""


def run_load_path(args: argparse.Namespace, comm: MPI.Comm, scene: Scene, solves: list, t0: float) -> int:
    """Solve a quasi-static load path (``--steps N`` or the scene's ``[[path.step]]``) and write its result set:
    solution.xdmf with one grid per solve (time = the step number), path.csv, summary.json with "steps",
    convergence.csv of the last solve, path.png and the last state's figures. A step that does not converge
    stops the path (exit 3) after its last iterate is written; the completed steps are kept."""
    from fenics_coulomb.io.xdmf_read import read_displacement
    from fenics_coulomb.scenes.path import INPUT_STOP, obstacle_labels, run_path

    out = prepare_output(comm, args.out)
    built = build_problem(scene, comm)
    start_step = getattr(args, "start_step", None)
    problem_logger = logging.getLogger("fenics_coulomb.problem")
    level = problem_logger.level
    if not args.verbose:  # each step's Newton lines, without the problem's remarks per step (those under -v)
        problem_logger.setLevel(logging.WARNING)
    try:
        with built.problem as problem:
            labels = obstacle_labels(scene)
            t_model = time.perf_counter() - t0
            logger.info("%s: n = %d unknowns, p = %d contact nodes, %s, %d rank(s); load path of %d step(s), "
                        "%d solve(s)", built.body.description, problem.n, problem.p, friction_text(scene),
                        comm.size, solves[-1].step, len(solves))
            u0 = None
            if start_step is not None:
                done = [s for s in solves if s.step <= start_step]
                previous = dolfinx.fem.Function(problem.V)
                set_owned_values(previous, read_displacement(Path(scene.start), problem.V,
                                                             time=float(start_step)))
                count = len(problem.obstacles)  # the scene's, or the paper's plane when it names none
                deltas = np.asarray(done[-1].obstacle_displacements or np.zeros((count, 3)), dtype=np.float64)
                problem.reset(previous, step=len(done), obstacle_displacements=deltas.reshape(count, 3),
                              obstacle_rotations=done[-1].obstacle_rotations or [None] * count)  # step K's placement
                todo = solves[len(done):]
                logger.info("resuming after step %d of %s: solving steps %d..%d", start_step, scene.start,
                            start_step + 1, solves[-1].step)
            else:
                u0 = start_function(scene.start, problem.V)
                todo = solves
            with out.writing() as tmp:
                results = PathResultSet(tmp, problem, initial=start_step is None)
                written: list[dict] = []  # the records of the solves written
                about = {"scene": scene.as_dict(), "settings": vars(problem.settings), "body": built.body.description}

                def path_entry(completed: int) -> dict[str, Any]:  # summary.json's "path"
                    return {"solves": len(solves), "steps": solves[-1].step, "completed": completed,
                            "start_step": start_step, "start": scene.start if start_step is not None else None,
                            "ramp_steps": getattr(args, "steps", None)}

                def write_grid(solve: PathSolve, record: StepRecord, result: SolveResult) -> None:
                    out.updating(tmp)
                    step = (f"step {solve.step}" if solve.substeps == 1
                            else f"step {solve.step} ({solve.substep}/{solve.substeps})")
                    results.write_solve(solve.time, step, result)
                    if not record.converged:  # the path stops here: finish writes the set
                        return
                    written.append(record.as_dict())
                    complete = results.progress(written, result, {**about, "path": path_entry(len(written))})
                    note = _interrupted_note(len(written), solve, solves[-1].step, start_step, scene.start)
                    out.keep_on_interrupt(tmp, note, complete)

                assert built.loads is not None  # a path scene's build has its load coefficients
                records, last, failure = run_path(problem, built.loads, todo, labels,
                                                    built.dirichlet_groups or {}, u0, write_grid,
                                                    last_step=solves[-1].step)
                out.updating(tmp)  # to its end: an interrupt now waits for the commit
                out.failed = bool(failure)
                path = path_entry(len(records) - bool(failure and not failure.startswith(INPUT_STOP)))
                assert last is not None  # at least one solve ran
                steps = [r.as_dict() for r in records]
                data = results.finish(
                    steps, last,
                    extra={**about, "converged": not failure, "reason": failure or "converged", "path": path},
                    timings={"model": t_model, "mesh": built.mesh_time, "assembly": problem.model_time}, wall_start=t0)
            if not args.no_plots:  # once the set is in place: an interrupt meanwhile leaves it without them
                from fenics_coulomb.io.figures import write_figures, write_path_figure

                add_figures(out, data, lambda directory: [
                    *write_figures(directory, problem.model, last, scene.label),
                    *write_path_figure(directory, steps, scene.label, comm)], wall=True)
    finally:
        problem_logger.setLevel(level)
    status = 0
    refused = failure.startswith(INPUT_STOP)
    if failure and not refused:
        status = EXIT_DIVERGED
        logger.error("fenics-coulomb: step %g of the load path did not converge: %s; the path stops (%d of %d "
                     "solves written, the last one NOT converged)", records[-1].time, failure, len(records),
                     len(todo))
    if comm.rank == 0:
        ending = "load path completed" if not failure else \
            f"load path STOPPED {'after' if refused else 'at'} step {records[-1].time:g}"
        print(f"{ending}: "
              f"{len(records)} solve(s), {data['newton_iterations_total']} Newton / "
              f"{data['krylov_iterations_total']} Krylov iterations, {data['wall_time_s']:.2f} s; results in "
              f"{_shown(out, data['files'])}", flush=True)
        print("\n".join(f"last step: {line}" for line in force_lines(data, scene)), flush=True)
        print("\n".join(f"last step: {line}" for line in contact_lines(data)), flush=True)
    if refused:  # the command's one error line (exit 2), after the result set of the solves before it
        raise InputError(f"{failure}; the path stops: the {len(records)} solve(s) before it are written, converged")
    return status


def _interrupted_note(solves: int, last: PathSolve, steps: int, start_step: int | None,
                      start: str) -> Callable[[str], str]:
    """What an interrupt after the solve ``last`` (the ``solves``-th this run wrote) keeps, for the interrupt's line,
    given the place it is kept in (quoted): the place and the options that resume the path — from the kept set
    when it holds a whole step before the path's last one, else (a resumed run interrupted within its first step)
    from this run's own start ``start`` after its ``start_step``, which is left in place."""
    whole = last.step if last.substep == last.substeps else last.step - 1

    def note(where: str) -> str:
        if whole > (start_step or 0) and whole < steps:
            resume = f" (resume: --start {where}/solution.xdmf --start-step {whole})"
        elif start_step is not None:
            resume = f" (resume: --start {shlex.quote(start)} --start-step {start_step})"
        else:
            resume = ""
        return f"the {solves} completed solve(s) of the path are kept in {where}{resume}"

    return note


def _shown(out: ResultDirectory, files: list[str]) -> str:
    """Where the results went, as the user named it (or the not-converged sibling of an earlier solution), with
    the ``files``: "OUT/ (a, b)"."""
    if out.committed == out.path:
        return f"{out.given}/ ({', '.join(files)})"
    return f"{out.given}{FAILED_SUFFIX}/ ({', '.join(files)}; the earlier solution in {out.given} is kept)"


def friction_text(scene: Scene) -> str:
    """The Coulomb coefficients a run uses: F of the obstacles' contact boundary, and each contact pair's own."""
    default = float(scene.friction.coefficient)
    parts = [] if scene.contact_pairs and not scene.obstacles else [f"F = {default:g}"]
    for i, pair in enumerate(scene.contact_pairs):
        name = f"{pair.name!r}" if pair.name else str(i + 1)
        parts.append(f"pair {name} F = {default if pair.friction is None else float(pair.friction):g}")
    return ", ".join(parts)


def force_lines(data: dict, scene: Scene) -> list[str]:
    """The force lines of the result, each naming what the force acts on: one body against obstacles: the total
    contact force on the body (and each obstacle's when there are several); contact pairs: each pair's force on
    its slave and on its master side (named by their boundaries) and each obstacle's force on its body; then the
    reaction of every support (summary.json's entries)."""
    obstacles = data.get("obstacles", {})
    pairs = data.get("contact_pairs", [])
    lines = []
    if not pairs:
        lines.append(f"total contact force on the body {_vector_text(data['contact_force'])}")
        if len(obstacles) > 1:
            lines += [f"  obstacle {name!r} on the body {_vector_text(d['force'])}" for name, d in obstacles.items()]
    else:
        sections = list(scene.contact_pairs)
        for k, d in enumerate(pairs):
            section = sections[k] if k < len(sections) else None
            slave = f" {'+'.join(section.slave)!r}" if section is not None else ""
            master = f" {'+'.join(section.master)!r}" if section is not None else ""
            lines.append(f"{_pair_label(d)}: contact force on the slave side{slave} "
                         f"{_vector_text(d['force_on_slave_body'])}, on the master side{master} "
                         f"{_vector_text(d['force_on_master_body'])}")
        lines += [f"obstacle {name!r}: contact force on the body {_vector_text(d['force'])}"
                  for name, d in obstacles.items()]
    lines.append("reactions: " + ", ".join(f"{name} {_vector_text(v)}"
                                    for name, v in data["reactions"].items()))
    return lines


def _pair_label(d: dict) -> str:
    """A pair of summary.json's ``contact_pairs`` as the result lines name it: pair N, or pair 'NAME' when named."""
    default = f"pair {d['pair'] + 1}"
    name = d.get("name") or default
    return default if name == default else f"pair {name!r}"


def contact_lines(data: dict) -> list[str]:
    """The result lines of the contact: area and peak pressure with its place, in total and per obstacle and
    contact pair when there are several (summary.json's entries)."""
    units = data.get("units", {})
    area, pressure = units.get("area", "L^2"), units.get("pressure", "GPa")

    def text(d: dict) -> str:
        at = d.get("peak_pressure_at")
        return (f"contact area {d['contact_area']:.6g} {area} ({d['contact_nodes']} nodes in contact), peak pressure "
                f"{d['peak_pressure']:.6g} {pressure}" + (f" at {_vector_text(at)}" if at else ""))

    lines = [f"contact: {text(data)}"]
    groups = [(f"obstacle {name!r}", d) for name, d in data.get("obstacles", {}).items()] + \
        [(_pair_label(d), d) for d in data.get("contact_pairs", [])]
    if len(groups) > 1:
        lines += [f"  {name}: {text(d)}" for name, d in groups]
    return lines


def _vector_text(v: list[float]) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in v) + ")"


def check_memory(comm: MPI.Comm, scene: Scene) -> None:
    """Refuse (InputError on every rank) a cuboid level whose estimated memory exceeds what the machine(s) of
    the ranks have available, before anything is allocated (collective: every rank must call it)."""
    if scene.body.shape != "cuboid":
        return
    n = expected_sizes(scene.body.lev)[1]
    need = comm.size * BYTES_PER_RANK + n * BYTES_PER_UNKNOWN
    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    local = available_memory() if node.rank == 0 else 0
    node.Free()
    available = comm.allreduce(local, op=MPI.SUM)
    if available > 0 and need > available:
        raise InputError(
            f"lev = {scene.body.lev}: {n:,} unknowns need about {need / 2**30:,.1f} GiB, but only "
            f"{available / 2**30:,.1f} GiB of memory are available (lower --lev)")


def available_memory() -> int:
    """MemAvailable of this machine in bytes (0 when unknown)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0

