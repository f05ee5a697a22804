"""Command line: ``python3 -m fenics_coulomb [flags]`` (runs unchanged under ``mpirun -n N``).

Exit status (:data:`EXIT_STATUSES`, also in ``--help``): 0 solved, the physics checks passed; 2 bad input (one
line naming the value, on every rank, before any collective call where the value is known before the mesh);
3 no convergence, or a solution that fails the physics checks (the last iterate and the history are written);
4 the results could not be written (disk full, a file-size limit; one line, the earlier results kept);
128 + signal (130 SIGINT, 143 SIGTERM, 129 SIGHUP) interrupted: every rank ends, the earlier results are kept and
no partial set is left; 1 an unexpected error (a bug: with a traceback).
"""

from __future__ import annotations

import argparse
import logging
import os
import re
import signal
import sys
import textwrap
import time
import traceback
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import numpy as np

from fenics_coulomb.scenes.builder import build_problem, cuboid_gap
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.io.display import virtual_display
from fenics_coulomb.errors import InputError, Interrupted, OutputError, SolverError, check_all
from fenics_coulomb.scd.preconditioner import OPTION_RANGES, check_option_value
from fenics_coulomb.io.results import FAILED_SUFFIX, ResultDirectory
from fenics_coulomb.io.summary import summary, write_convergence_csv, write_summary
from fenics_coulomb.io.writer import write_result_set
from fenics_coulomb.scenes.cuboid import GAP_PROFILES, LOAD_CASES, expected_sizes
from fenics_coulomb.settings import PRECONDITIONERS

__all__ = ["EXIT_INPUT", "EXIT_DIVERGED", "EXIT_OUTPUT", "EXIT_INTERRUPTED", "EXIT_STATUSES", "BYTES_PER_UNKNOWN",
           "BYTES_PER_RANK", "MAX_XDMF_BYTES", "START_CHECK_ROWS", "ArgumentParser", "NESTED_COARSE_RTOL",
           "NESTED_LEVEL_STEP", "NESTED_AUTO_MIN_LEV", "build_parser", "configure_logging", "scene_from_args",
           "prepare_output", "nested_levels", "CoarseStart", "coarse_level_options", "solve_coarse_levels",
           "start_from_coarse", "resolve_nested", "run", "check_path_arguments", "run_load_path",
           "friction_text", "start_function", "check_memory", "available_memory", "check_start_file", "main",
           "exit_status", "QUIET_EXIT_DELAY", "run_command", "set_petsc_options", "check_petsc_options",
           "check_option_values"]

logger = logging.getLogger("fenics_coulomb")

EXIT_INPUT = 2
EXIT_DIVERGED = 3
EXIT_OUTPUT = 4
EXIT_INTERRUPTED = 128  # + the signal number (130 SIGINT, 143 SIGTERM), as a shell reports it
#: What each exit status guarantees (the --help epilog and the README's table).
EXIT_STATUSES = {
    0: "solved: converged and the physics checks passed (summary.json physics_checks)",
    2: "bad input: one line naming the value; nothing was solved or written",
    3: "not converged, or the physics checks failed: the last iterate and the history are written (beside an "
       "earlier converged set in OUT, into OUT.not-converged)",
    4: "the results could not be written (disk full, a size limit): one line; the earlier results are kept",
    130: "interrupted (128 + the signal: 143 SIGTERM, 129 SIGHUP): every rank ended; the earlier results are "
         "kept, no partial set is left",
    1: "an unexpected error (a bug; it prints a traceback): please report it",
}

#: Peak memory (summed over ranks) of a cuboid solve: a base per rank plus bytes per unknown. With the
#: matrix-free Newton operator the measured peak RSS (docs/scale/idle-2026-11-23-2ranks-default-ptap, d3/L2,
#: GAMG, 2 ranks) is 1042 MiB at 209 088 and 6228 MiB at 1 622 400 unknowns: 3.84 kB per unknown above
#: ~150 MiB per rank; 4.2 kB leaves 10 % (the explicit Newton matrix of ILU/LU needs more: 5.1 kB, docs/table2).
BYTES_PER_UNKNOWN = 4.2e3
BYTES_PER_RANK = 150 * 2**20
#: Largest scene-independent start file read for validation (an XDMF is a few kB of XML).
MAX_XDMF_BYTES = 16 * 2**20
#: A start file's datasets are checked for non-finite values in blocks of this many rows.
START_CHECK_ROWS = 1 << 20


class ArgumentParser(argparse.ArgumentParser):
    """argparse that prints on rank 0 only (help, usage, errors) and reports an error in one line.

    Every rank parses the same arguments, so every rank exits with status 2 (or 0 for --help) and only
    the message is not repeated once per rank.
    """

    def _print_message(self, message: str, file=None) -> None:
        if MPI.COMM_WORLD.rank == 0:
            super()._print_message(message, file)

    def error(self, message: str) -> NoReturn:
        if MPI.COMM_WORLD.rank == 0:
            print(f"{self.prog}: error: {message} (see --help)", file=sys.stderr, flush=True)
        _finish_together(MPI.COMM_WORLD)
        sys.exit(EXIT_INPUT)

#: Residual reduction of the coarse levels of --nested. They only provide the start of the next level, but the
#: fine level needs fewer steps from an accurate one (2 ranks, d3/L2, lev 10 from lev 8, with the reduction then
#: relative to the paper's start: 1e-2 9 Newton / 126 Krylov, 66.0 s; 1e-4 8 / 96, 52.3 s; 1e-6 7 / 68, 45.9 s;
#: no gain below; benchmarks/nested.py, docs/nested). The stopping rule is now relative to ‖ŷ(ũ = 0)‖, which is
#: 53× smaller at lev 8 (25× at lev 6): 3e-5 asks for what 1e-6 asked then.
NESTED_COARSE_RTOL = 3e-5
#: --nested K solves the levels lev − NESTED_LEVEL_STEP·k, k = K, ..., 1 (h doubles from level to level).
NESTED_LEVEL_STEP = 2
#: Without --nested, the cuboid from this level on is solved with one coarser level (lev − 2) first: on 2 ranks
#: with the coarse reduction 1e-6 it saves 18-34 % of the time at lev 7-10 (d3/L2: lev 7 2.50 s against 3.25 s,
#: lev 10 46.8 s against 70.9 s; d1/L1 and d2/L2 at lev 8 alike; benchmarks/nested.py, docs/nested); lev 2-6 keep
#: the direct solve (the paper's Section 7 runs).
NESTED_AUTO_MIN_LEV = 7


def build_parser(prog: str = "python3 -m fenics_coulomb") -> argparse.ArgumentParser:
    """The argument parser shared by the CLI and the demo (scene values are None unless given)."""
    d = Scene()
    p = ArgumentParser(
        prog=prog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=textwrap.fill(
            "3D contact of linear-elastic bodies with rigid obstacles (planes, spheres, cylinders) and with each "
            "other (contact pairs) under Coulomb friction, static or along a quasi-static load path, solved by the "
            "SCD semismooth* Newton method (DOLFINx/PETSc, MPI-parallel). Without --scene: the paper's cuboid on "
            "the plane x3 = 0 (Section 7); a scene file (TOML) describes any body, obstacles, contact pairs, loads "
            "and load paths (README, demos/scenes/).", 100),
        epilog=textwrap.fill("Flags override the scene file's values. PETSc options for the Newton system can be "
                             "appended with the prefix -coulomb_, e.g. -coulomb_ksp_monitor -coulomb_pc_type gamg.",
                             100) + "\n\nexit status:\n"
        + "\n".join(textwrap.fill(text, 100, initial_indent=f"  {code:<5}", subsequent_indent=" " * 7)
                    for code, text in EXIT_STATUSES.items()),
    )
    p.add_argument("--scene", default=None, help="scene file (TOML), e.g. demos/scenes/d3_L2.toml")
    p.add_argument("--lev", type=int, help=f"discretization level of the cuboid (>= 0; default {d.body.lev})")
    p.add_argument("--gap", help=f"gap profile {', '.join(GAP_PROFILES)} or an expression in x1, x2 "
                   f"(default {d.body.gap})")
    p.add_argument("--load", help=f"load case {', '.join(LOAD_CASES)} (default {d.load.case})")
    p.add_argument("--load-scale", type=float, help="factor on the tractions (default 1)")
    p.add_argument("--young", type=float, help=f"Young's modulus E in GPa (default {d.material.young})")
    p.add_argument("--poisson", type=float, help=f"Poisson ratio (default {d.material.poisson})")
    p.add_argument("--friction", type=float, help=f"Coulomb coefficient F (default {d.friction.coefficient})")
    p.add_argument("--variant", help="Newton step: 4a (S*Q, (5.4)) or 4b (SQ); default 4a")
    p.add_argument("--tol", type=float, help=f"relative GMRES residual per Newton step (default {d.solver.tol})")
    p.add_argument("--rtol", type=float, help=f"stop at |y| <= rtol |y0| (default {d.solver.rtol})")
    p.add_argument("--accuracy", type=float,
                   help="relative displacement error to reach instead of --rtol (e.g. 1e-6); "
                   "mapped to rtol by the measured speed-accuracy table (docs/tradeoff)")
    p.add_argument("--adaptive-tol", action=argparse.BooleanOptionalAction, default=None,
                   help="safeguarded Eisenstat-Walker forcing terms <= --tol (superlinear tail, fewer Newton "
                   f"steps); --no-adaptive-tol keeps every GMRES solve at --tol, as the paper (default "
                   f"{'on' if d.solver.adaptive_tol else 'off'})")
    p.add_argument("--matrix-free", action=argparse.BooleanOptionalAction, default=None,
                   help="apply the Newton matrix as D(A x) + C x without a second copy of A when the "
                   "preconditioner is built on A (gamg); --no-matrix-free stores it (default "
                   f"{'on' if d.solver.matrix_free else 'off'})")
    p.add_argument("--galerkin-coarse", action=argparse.BooleanOptionalAction, default=None,
                   help="with GAMG (on A) and variant 4a: scale the contact rows to A's diagonal and keep GAMG's "
                   "coarse operators the Galerkin products of the Newton matrix, updated in place every Newton "
                   "step; --no-galerkin-coarse keeps A's (default "
                   f"{'on' if d.solver.galerkin_coarse else 'off'})")
    p.add_argument("--max-it", type=int, help=f"maximal Newton iterations (default {d.solver.max_it})")
    p.add_argument("--pc", help=f"preconditioner: {', '.join(PRECONDITIONERS)} (default {d.solver.pc})")
    p.add_argument("--gamma-scale", type=float,
                   help="γ = scale × power-method estimate of λ_max(A); the paper uses 1 "
                   f"(default {d.solver.gamma_scale})")
    p.add_argument(
        "--start",
        help="'zero' (the paper's origin u = 0 of the shifted unknown, ũ = −d), 'undeformed' (ũ = 0) or the "
        "solution.xdmf of an earlier run, interpolated onto this mesh (default zero)",
    )
    p.add_argument("--nested", type=int, default=None, metavar="K",
                   help="nested iteration for the cuboid: solve lev-2K, ..., lev-2 first (each to a residual "
                   f"reduction of {NESTED_COARSE_RTOL:g}), each from the previous level's solution interpolated, and "
                   "start lev from the last (default: 1 for the cuboid from lev "
                   f"{NESTED_AUTO_MIN_LEV} on when started from the paper's start, else 0; 0 switches it off)")
    p.add_argument("--steps", type=int, default=None, metavar="N",
                   help="quasi-static load path: ramp the scene's loads (tractions, body force, prescribed "
                   "displacements, obstacle displacements) from 0 in N equal steps, friction acting on each step's "
                   "slip increment (not with a scene's own [[path.step]] path)")
    p.add_argument("--start-step", type=int, default=None, metavar="K",
                   help="resume a load path after its step K: --start names the earlier path's solution.xdmf, "
                   "whose grid of time K is the state of step K; steps K+1..N are solved and written")
    p.add_argument("--predictor", action="store_const", const=True, default=None,
                   help="first solve the linear problem; if it does not touch the obstacle it is the solution")
    p.add_argument("--out", default="out", help="output directory (default ./out)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    p.add_argument("--quiet", action="store_true", help="only errors and the final line")
    p.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    return p


def configure_logging(comm: MPI.Comm, quiet: bool, verbose: bool) -> None:
    """Log to stderr on rank 0 only."""
    level = logging.WARNING if quiet else (logging.DEBUG if verbose else logging.INFO)
    handler: logging.Handler = logging.StreamHandler(sys.stderr) if comm.rank == 0 else logging.NullHandler()
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger.handlers[:] = [handler]
    logger.setLevel(level)
    logger.propagate = False


def scene_from_args(args: argparse.Namespace) -> Scene:
    """Defaults < scene file < flags; raises InputError naming any bad value (no communication)."""
    if args.scene is not None and not args.scene.strip():
        raise InputError(f"--scene {args.scene!r}: give a scene file (TOML), or leave --scene out for the defaults")
    scene = Scene.from_toml(args.scene) if args.scene else Scene()
    return scene.override(
        lev=args.lev, gap=args.gap, load=args.load, load_scale=args.load_scale, young=args.young,
        poisson=args.poisson, friction=args.friction, variant=args.variant, tol=args.tol, rtol=args.rtol,
        max_it=args.max_it, pc=args.pc, gamma_scale=args.gamma_scale, start=args.start, predictor=args.predictor,
        accuracy=args.accuracy, adaptive_tol=args.adaptive_tol, matrix_free=args.matrix_free,
        galerkin_coarse=args.galerkin_coarse,
    )


def prepare_output(comm: MPI.Comm, out: str) -> ResultDirectory:
    """Check that the result set can go to ``out``; raise InputError on every rank if it cannot."""
    return ResultDirectory(comm, out)


def nested_levels(lev: int, levels: int) -> list[int]:
    """The coarser cuboid levels of ``--nested K``, coarse to fine: lev − 2K, ..., lev − 2 (each halves the mesh
    size h, as the levels of full multigrid do; two levels are a factor 2 in h)."""
    return [lev - NESTED_LEVEL_STEP * k for k in range(levels, 0, -1)]


@dataclass
class CoarseStart:
    """The last coarse level's solution of nested iteration, its level and every coarse level's result."""

    u: dolfinx.fem.Function
    lev: int
    results: list


def coarse_level_options(lev: int) -> dict[str, str]:
    """The user's ``-coulomb_*`` PETSc options for the coarse level ``lev`` of nested iteration (prefix
    ``coulomb_nested<lev>_``), without the prefix: every option given for the solve, except those the user gave
    for this level itself (``-coulomb_nested<lev>_*``, read from the database under its own prefix, win) and those
    for other coarse levels."""
    opts = PETSc.Options()
    given = {name[len("coulomb_"):]: value for name, value in opts.getAll().items()
             if name.startswith("coulomb_") and not name.startswith("coulomb_nested")}
    return {key: value for key, value in given.items() if not opts.hasName(f"coulomb_nested{lev}_{key}")}


def solve_coarse_levels(scene: Scene, levels: int, comm: MPI.Comm) -> CoarseStart | None:
    """Solve the cuboid scene on its ``levels`` coarser levels (:func:`nested_levels`, coarse to fine, each from
    the previous solution, to NESTED_COARSE_RTOL) before the fine level is built, so that their memory is free
    again when it is; None (logged) when a coarse level does not converge: the fine level then starts as without
    nesting (collective). The user's ``-coulomb_*`` options apply to the coarse levels too
    (:func:`coarse_level_options`)."""
    from fenics_coulomb.scenes.nested import solve_nested

    coarse_levels = nested_levels(scene.body.lev, levels)
    coarse = [build_problem(scene.override(lev=lev, rtol=NESTED_COARSE_RTOL), comm,
                            petsc_options_prefix=f"coulomb_nested{lev}_",
                            petsc_options=coarse_level_options(lev)).problem
              for lev in coarse_levels]
    try:
        uh, _, nested = solve_nested(coarse, start_function(scene.start, coarse[0].V))
    except SolverError as err:
        logger.warning("nested iteration: a coarse level did not converge (%s); lev %d starts without it", err,
                       scene.body.lev)
        return None
    finally:
        for problem in coarse:
            problem.destroy()
    u = dolfinx.fem.Function(uh.function_space)  # the problem's own Function went with it
    u.x.array[:] = uh.x.array
    logger.info("nested iteration: lev %s, %d Newton / %d Krylov iterations", ", ".join(map(str, coarse_levels)),
                sum(r.iterations for r in nested.levels), sum(r.krylov_iterations for r in nested.levels))
    return CoarseStart(u, coarse_levels[-1], nested.levels)


def start_from_coarse(start: CoarseStart, scene: Scene, V: dolfinx.fem.FunctionSpace) -> dolfinx.fem.Function:
    """The coarse solution on V: through the box grid (:func:`~fenics_coulomb.scenes.nested.interpolate_cuboid`), or,
    should the coarse mesh not be its level's grid, by DOLFINx's non-matching interpolation in ``solve``."""
    from fenics_coulomb.scenes.nested import interpolate_cuboid

    u = interpolate_cuboid(start.u, start.lev, V, cuboid_gap(scene))
    return u if u is not None else start.u


def resolve_nested(nested: int | None, scene: Scene) -> int:
    """``--nested`` as given, or by default 1 for a cuboid of level NESTED_AUTO_MIN_LEV or finer started from the
    paper's start, 0 otherwise (docs/scale: nested iteration pays from lev 7 on)."""
    if nested is not None:
        return nested
    return int(scene.body.shape == "cuboid" and scene.body.lev >= NESTED_AUTO_MIN_LEV and scene.start == "zero")


def run(args: argparse.Namespace, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """Solve the scene described by ``args``; return the exit status."""
    t0 = time.perf_counter()
    scene = scene_from_args(args)
    if not args.out.strip():
        raise InputError(f"--out {args.out!r}: give an output directory (an empty name would write into the "
                         "current directory)")
    check_memory(comm, scene)
    if scene.start not in ("zero", "undeformed"):
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
        model = problem.model
        t_model = time.perf_counter() - t0 - t_nested
        logger.info("%s: n = %d unknowns, p = %d contact nodes, %s, %d rank(s)", built.body.description,
                    problem.n, problem.p, friction_text(scene), comm.size)
        status = 0
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
                tmp, problem, result, label=scene.label, plots=not args.no_plots, reactions=built.dirichlet_groups,
                extra={"scene": scene.as_dict(), "settings": vars(problem.settings), "body": built.body.description,
                       "nested": {"levels": nested_levels(scene.body.lev, nested) if coarse else [],
                                  "newton_iterations": [r.iterations for r in coarse.results] if coarse else [],
                                  "krylov_iterations": [r.krylov_iterations for r in coarse.results] if coarse
                                  else []}},
                timings={"model": t_model, "nested": t_nested, "mesh": built.mesh_time,
                         "assembly": problem.model_time}, started=t_write)
    counts = data["state_counts"]
    if comm.rank == 0:
        print(
            f"{'converged' if result.converged else 'NOT converged (' + result.reason + ')'}: "
            f"{result.iterations} Newton / {result.krylov_iterations} Krylov iterations, "
            f"open/stick/slip {counts['open']}/{counts['stick']}/{counts['slip']}, "
            f"{data['wall_time_s']:.2f} s; results in {_shown(out)}/ ({', '.join(data['files'])})",
            flush=True,
        )
        print(f"total contact force on the body {_vector_text(data['contact_force'])}; reactions: "
              + ", ".join(f"{name} {_vector_text(v)}" for name, v in data["reactions"].items()), flush=True)
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
        check_all(comm, scene.start not in ("zero", "undeformed"), f"--start-step {start_step}: give the earlier "
                  "path's solution.xdmf with --start FILE")
        check_all(comm, not isinstance(start_step, bool) and 1 <= start_step < last,
                  f"--start-step {start_step}: must lie in [1, {last - 1}] (the path has {last} steps; the last "
                  "one is solved after it)")
        message = ""
        if comm.rank == 0:
            from fenics_coulomb.io.xdmf import solution_datasets

            try:
                info = solution_datasets(Path(scene.start), float(start_step))
                if not info["converged"]:
                    message = f"its step {start_step} did not converge"
            except (OSError, ValueError, KeyError, ET.ParseError) as err:
                message = f"no step {start_step} in it ({err})"
            if message:
                message = f"--start {scene.start!r} --start-step {start_step}: {message}"
        message = comm.bcast(message, root=0)
        check_all(comm, not message, message)
    return solves


def run_load_path(args: argparse.Namespace, comm: MPI.Comm, scene: Scene, solves: list, t0: float) -> int:
    """Solve a quasi-static load path (``--steps N`` or the scene's ``[[path.step]]``) and write its result set:
    solution.xdmf with one grid per solve (time = the step number), path.csv, summary.json with "steps",
    convergence.csv of the last solve, path.png and the last state's figures. A step that does not converge
    stops the path (exit 3) after its last iterate is written; the completed steps are kept."""
    from fenics_coulomb.io.figures import write_path_figure
    from fenics_coulomb.io.xdmf import XDMFTimeSeries, read_displacement, write_result_grid
    from fenics_coulomb.io.summary import write_path_csv
    from fenics_coulomb.scenes.path import obstacle_labels, run_path

    out = prepare_output(comm, args.out)
    built = build_problem(scene, comm)
    start_step = getattr(args, "start_step", None)
    problem_logger = logging.getLogger("fenics_coulomb.problem")
    level = problem_logger.level
    if not args.verbose:  # each step's Newton lines, without the problem's remarks per step (those under -v)
        problem_logger.setLevel(logging.WARNING)
    try:
        with built.problem as problem:
            model = problem.model
            labels = obstacle_labels(scene)
            t_model = time.perf_counter() - t0
            logger.info("%s: n = %d unknowns, p = %d contact nodes, %s, %d rank(s); load path of %d step(s), "
                        "%d solve(s)", built.body.description, problem.n, problem.p, friction_text(scene),
                        comm.size, solves[-1].step, len(solves))
            u0 = None
            if start_step is not None:
                done = [s for s in solves if s.step <= start_step]
                previous = dolfinx.fem.Function(problem.V)
                previous.x.petsc_vec.array[:] = read_displacement(Path(scene.start), problem.V,
                                                                  time=float(start_step))
                previous.x.scatter_forward()
                deltas = done[-1].obstacle_displacements or [(0.0, 0.0, 0.0)] * len(problem.obstacles)
                problem.reset(previous, step=len(done), obstacle_displacements=deltas)
                todo = solves[len(done):]
                logger.info("resuming after step %d of %s: solving steps %d..%d", start_step, scene.start,
                            start_step + 1, solves[-1].step)
            else:
                u0 = start_function(scene.start, problem.V)
                todo = solves
            t_write = 0.0
            with out.writing() as tmp:
                xdmf = XDMFTimeSeries(tmp / "solution.xdmf", model.V.mesh)

                def write_grid(solve, record, result) -> None:  # noqa: ANN001
                    nonlocal t_write
                    t = time.perf_counter()
                    step = (f"step {solve.step}" if solve.substeps == 1
                            else f"step {solve.step} ({solve.substep}/{solve.substeps})")
                    write_result_grid(xdmf, model, result, solve.time, step)
                    t_write += time.perf_counter() - t

                records, result, failure = run_path(problem, built.loads, todo, labels,
                                                    built.dirichlet_groups or {}, u0, write_grid,
                                                    last_step=solves[-1].step)
                out.failed = bool(failure)
                t = time.perf_counter()
                steps = [r.as_dict() for r in records]
                write_convergence_csv(tmp / "convergence.csv", result, comm)
                write_path_csv(tmp / "path.csv", steps, comm)
                files = ["solution.xdmf", "solution.h5", "convergence.csv", "path.csv"]
                if not args.no_plots:
                    from fenics_coulomb.io.figures import write_figures

                    files += write_figures(tmp, model, result, scene.label)
                    files += write_path_figure(tmp, steps, scene.label, comm)
                data = summary(model, result, {"scene": scene.as_dict(), "settings": vars(problem.settings),
                                               "body": built.body.description})
                data["converged"] = not failure
                data["reason"] = failure or "converged"
                data["path"] = {"solves": len(solves), "steps": solves[-1].step, "completed": len(records) - bool(failure),
                                "start_step": start_step, "start": scene.start if start_step is not None else None,
                                "ramp_steps": getattr(args, "steps", None)}
                data["steps"] = steps
                data["reactions"] = records[-1].reactions
                data["contact_force"] = records[-1].contact_force
                data["newton_iterations_total"] = sum(r.newton_iterations for r in records)
                data["krylov_iterations_total"] = sum(r.krylov_iterations for r in records)
                data["timings_s"]["model"] = comm.allreduce(t_model, op=MPI.MAX)
                data["timings_s"]["mesh"] = comm.allreduce(built.mesh_time, op=MPI.MAX)
                data["timings_s"]["assembly"] = comm.allreduce(problem.model_time, op=MPI.MAX)
                data["timings_s"]["output"] = comm.allreduce(t_write + time.perf_counter() - t, op=MPI.MAX)
                data["wall_time_s"] = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
                data["files"] = [*files, "summary.json"]
                write_summary(tmp / "summary.json", data, comm)
    finally:
        problem_logger.setLevel(level)
    status = 0
    if failure:
        status = EXIT_DIVERGED
        logger.error("fenics-coulomb: step %g of the load path did not converge: %s; the path stops (%d of %d "
                     "solves written, the last one NOT converged)", records[-1].time, failure, len(records),
                     len(todo))
    if comm.rank == 0:
        print(f"{'load path completed' if not failure else 'load path STOPPED at step ' + format(records[-1].time, 'g')}: "
              f"{len(records)} solve(s), {data['newton_iterations_total']} Newton / "
              f"{data['krylov_iterations_total']} Krylov iterations, {data['wall_time_s']:.2f} s; results in "
              f"{_shown(out)}/ ({', '.join(data['files'])})", flush=True)
        print(f"last step: total contact force on the body {_vector_text(data['contact_force'])}; reactions: "
              + ", ".join(f"{name} {_vector_text(v)}" for name, v in data["reactions"].items()), flush=True)
    return status


def _shown(out: ResultDirectory) -> str:
    """Where the results went, as the user named it (or the not-converged sibling of an earlier solution)."""
    return out.given if out.committed == out.path else f"{out.given}{FAILED_SUFFIX} (the earlier solution in " \
        f"{out.given} is kept)"


def friction_text(scene: Scene) -> str:
    """The Coulomb coefficients a run uses: F of the obstacles' contact boundary, and each contact pair's own."""
    default = float(scene.friction.coefficient)
    parts = [] if scene.contact_pairs and not scene.obstacles else [f"F = {default:g}"]
    for i, pair in enumerate(scene.contact_pairs):
        name = f"{pair.name!r}" if pair.name else str(i + 1)
        parts.append(f"pair {name} F = {default if pair.friction is None else float(pair.friction):g}")
    return ", ".join(parts)


def _vector_text(v: list[float]) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in v) + ")"


def start_function(start: str, V: dolfinx.fem.FunctionSpace) -> dolfinx.fem.Function | None:
    """The start ũ⁽⁰⁾ of a start setting: None (the paper's u⁽⁰⁾ = 0), zero, or an earlier run's solution
    (checked beforehand by :func:`check_start_file`), interpolated onto V."""
    if start == "zero":
        return None
    u0 = dolfinx.fem.Function(V)
    if start == "undeformed":
        return u0
    from fenics_coulomb.io.xdmf import read_displacement

    u0.x.petsc_vec.array[:] = read_displacement(Path(start), V)
    u0.x.scatter_forward()
    return u0


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


def check_start_file(comm: MPI.Comm, start: str) -> None:
    """Check on rank 0 that ``start`` is the solution.xdmf of an earlier run: readable XML naming a 3D mesh
    (hexahedra or tetrahedra) with XYZ geometry and a 3-vector point field ``displacement`` whose HDF5
    datasets exist with matching shapes. InputError on every rank otherwise (collective)."""
    message = ""
    if comm.rank == 0:
        try:
            message = _start_file_problem(Path(start).with_suffix(".xdmf"))
        except Exception as err:  # any failure to read a foreign file is a bad input, reported in one line
            message = f"cannot be read ({type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''})"
        if message:
            message = f"--start {start!r}: {message}"
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)


def _start_file_problem(xdmf: Path) -> str:
    """What is wrong with ``xdmf`` as a start file ("" if nothing)."""
    import h5py

    if not xdmf.is_file():
        return "no such file"
    if xdmf.stat().st_size > MAX_XDMF_BYTES:
        return "too large for an XDMF file of fenics-coulomb"
    try:
        root = ET.fromstring(xdmf.read_bytes())
    except ET.ParseError as err:
        return f"not an XDMF (XML) file ({err})"
    strip = {el: el.tag.rsplit("}", 1)[-1] for el in root.iter()}
    topologies = [el for el, tag in strip.items() if tag == "Topology"]
    geometries = [el for el, tag in strip.items() if tag == "Geometry"]
    if not topologies or not geometries:
        return "no mesh (Topology/Geometry) in the XDMF file"
    kinds = {(el.get("TopologyType") or el.get("Type") or "").lower() for el in topologies}
    if not kinds <= {"hexahedron", "tetrahedron"}:
        return f"the mesh has cells of type {', '.join(sorted(kinds))}, not 3D hexahedra or tetrahedra"
    if any((el.get("GeometryType") or el.get("Type") or "XYZ").upper() != "XYZ" for el in geometries):
        return "the mesh geometry is not XYZ (3D)"
    fields = [el for el, tag in strip.items() if tag == "Attribute" and el.get("Name") == "displacement"]
    if not fields:
        return "no 'displacement' field in the XDMF file"

    def dataset(element: ET.Element, what: str) -> tuple[int, ...]:
        """The shape of an element's HDF5 dataset; ValueError naming the first non-finite value in it (read in
        blocks of rows, so that a large file is not loaded at once)."""
        item = next((el for el in element.iter() if el.tag.rsplit("}", 1)[-1] == "DataItem"), None)
        if item is None or (item.get("Format") or "XML").upper() != "HDF" or not item.text:
            raise ValueError("its data are not stored in HDF5")
        file, _, name = item.text.strip().partition(":")
        path = xdmf.parent / file if not Path(file).is_absolute() else Path(file)
        with h5py.File(path, "r") as h5:
            data = h5[name]
            if not isinstance(data, h5py.Dataset):
                raise ValueError(f"{file}:{name} is not a dataset")
            rows = data.shape[0] if data.ndim else 0
            for first in range(0, rows, START_CHECK_ROWS):
                block = np.asarray(data[first:first + START_CHECK_ROWS], dtype=np.float64).reshape(-1, 3) \
                    if data.ndim == 2 and data.shape[1] == 3 else None
                if block is None:
                    break
                bad = np.flatnonzero(~np.all(np.isfinite(block), axis=1))
                if bad.size:
                    raise ValueError(f"{what} of node {first + int(bad[0])} is {block[bad[0]].tolist()}: not finite")
            return tuple(data.shape)

    try:
        points = dataset(geometries[0], "the coordinates")
        values = dataset(fields[0], "the displacement")
        for field in fields[1:]:  # a load path's later grids
            dataset(field, "the displacement")
    except ValueError as err:
        return str(err)
    except (OSError, KeyError) as err:
        return f"the HDF5 data cannot be read ({err})"
    if len(points) != 2 or points[1] != 3 or points[0] == 0:
        return f"the mesh geometry has shape {points}, not (nodes, 3)"
    if len(values) != 2 or values[1] != 3 or values[0] != points[0]:
        return f"'displacement' has shape {values}, not ({points[0]}, 3) (a 3-vector per mesh node)"
    return ""


def main(argv: list[str] | None = None, prog: str = "python3 -m fenics_coulomb") -> int:
    """Entry point; returns the exit status (2 bad input, 3 no convergence, 128 + signal interrupted)."""
    comm = MPI.COMM_WORLD
    parser = build_parser(prog)
    args, petsc_args = parser.parse_known_args(argv)
    configure_logging(comm, args.quiet, args.verbose)
    handlers = _end_on_signals(comm)
    given: list[str] = []
    try:
        given = set_petsc_options(petsc_args)
        with virtual_display(enabled=not args.no_plots and comm.rank == 0):
            return run(args, comm)
    except InputError as err:
        if comm.rank == 0:
            print(f"{prog}: error: {err}", file=sys.stderr, flush=True)
        _finish_together(comm)
        return EXIT_INPUT
    except OutputError as err:  # raised on every rank together (output.ResultDirectory.writing)
        if comm.rank == 0:
            print(f"{prog}: error: {err}", file=sys.stderr, flush=True)
        _finish_together(comm)
        return EXIT_OUTPUT
    except OSError as err:  # a file that failed on this rank alone (e.g. in a collective HDF5 write)
        print(f"{prog}: error: results could not be written ({err.strerror or err}); the earlier results are kept",
              file=sys.stderr, flush=True)
        if comm.size > 1:
            comm.Abort(EXIT_OUTPUT)
        return EXIT_OUTPUT
    except (KeyboardInterrupt, Interrupted) as err:  # any rank interrupted ends all ranks, none hangs
        signum = err.signum if isinstance(err, Interrupted) else signal.SIGINT
        print(f"fenics-coulomb: interrupted by {signal.Signals(signum).name} on rank {comm.rank}; ending all "
              "ranks", file=sys.stderr, flush=True)
        comm.Abort(EXIT_INTERRUPTED + signum)
        return EXIT_INTERRUPTED + signum
    except Exception:  # an unexpected failure on any rank must end all ranks, not hang them
        print(f"[rank {comm.rank}] fenics-coulomb: unexpected error:\n{traceback.format_exc()}",
              file=sys.stderr, flush=True)
        comm.Abort(1)
        return 1
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
        options = PETSc.Options()
        for key in given:  # the command's PETSc options end with it (main may be called again in-process)
            options.delValue(key)


def exit_status(status: int, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """The process's exit status for the command ``status`` of :func:`main` (collective; call it once, as the
    program ends: it finalizes MPI).

    Under mpirun a rank that exits non-zero while others still run makes OpenMPI print a block about "one or more
    processes exited with non-zero status" after our one-line message, and the PMIx server sometimes a
    "PMIX ERROR: PMIX_ERR_UNREACH" line. So on a failure every rank synchronizes and finalizes MPI, the other
    ranks end with 0 and rank 0, a moment later, with the status, which mpirun (and srun: the largest status of
    its tasks) then reports alone: the launcher stays quiet. A failure ends without Python's shutdown (the
    streams flushed, PETSc and MPI finalized): no destructor runs after MPI or on a file a failed write broke.
    """
    if status == 0:
        return status
    sys.stdout.flush()
    sys.stderr.flush()
    comm.Barrier()
    rank, size = comm.rank, comm.size
    PETSc._finalize()
    MPI.Finalize()
    if rank == 0 and size > 1:
        time.sleep(QUIET_EXIT_DELAY)
    # no destructor may run after MPI (DOLFINx's objects at shutdown), nor one of a file a failed write left
    # broken (HDF5 crashed closing it at exit)
    os._exit(status if rank == 0 else 0)


#: Rank 0 ends this long after the others on a failure (:func:`exit_status`).
QUIET_EXIT_DELAY = 0.2


def run_command(argv: list[str] | None = None, prog: str = "python3 -m fenics_coulomb") -> int:
    """The command line as a program: :func:`main`, then :func:`exit_status` (``python3 -m fenics_coulomb``, the
    ``fenics-coulomb`` script and the demos end through it; tests call :func:`main` in-process)."""
    return exit_status(main(argv, prog))


def _finish_together(comm: MPI.Comm) -> None:
    """Synchronize the ranks before a non-zero exit: mpirun ends the job at the first non-zero exit, and a
    rank that is still starting up or finalizing then prints PMIx errors after the one-line message."""
    comm.Barrier()


def _end_on_signals(comm: MPI.Comm) -> dict[int, object]:
    """End the run at once on SIGINT, SIGTERM and SIGHUP: one line on stderr, the partial result set removed, and
    MPI_Abort with 128 + the signal (every rank ends; the earlier results stay untouched). Aborting from the
    handler, not by unwinding the stack: the signal may arrive inside a PETSc call (the matrix-free operator's
    mult runs in Python inside GMRES and a multigrid cycle), after which the PETSc objects are in no state to be
    destroyed collectively. Returns the previous handlers."""
    def handler(signum: int, frame: object) -> None:
        print(f"fenics-coulomb: interrupted by {signal.Signals(signum).name} on rank {comm.rank}; ending all ranks",
              file=sys.stderr, flush=True)
        from fenics_coulomb.io.results import abandon_results

        abandon_results()
        comm.Abort(EXIT_INTERRUPTED + signum)

    previous: dict[int, object] = {}
    try:
        for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            previous[signum] = signal.signal(signum, handler)
    except ValueError:  # not the main thread (e.g. main() called from a worker thread): keep the defaults
        pass
    return previous


def set_petsc_options(tokens: list[str]) -> list[str]:
    """Put ``-coulomb_*`` options from the command line into PETSc's options database and check them.

    Only prefixed options are accepted, so nothing outside fenics-coulomb's objects is changed. The options
    are tried on a small KSP set up as the solver's (GMRES, right preconditioning, unpreconditioned norm) on
    this rank alone (no communication): an option PETSc refuses (an unknown KSP or PC type, a norm the KSP
    cannot monitor, a missing factorization package) is an InputError; the options are then removed again.

    Returns:
        The option names set (``main`` removes them when it returns, so a second in-process call starts clean).
    """
    from petsc4py import PETSc

    opts = PETSc.Options()
    pairs = _petsc_pairs(tokens)
    for key, _ in pairs:
        if not key.startswith("coulomb_"):
            raise InputError(f"unrecognized argument -{key} (PETSc options must carry the prefix -coulomb_)")
        if key == "coulomb_":
            raise InputError("PETSc option -coulomb_ has no name after the prefix (e.g. -coulomb_ksp_monitor)")
    for key, value in pairs:
        opts[key] = value
    try:
        check_petsc_options("coulomb_")
    except InputError:
        for key, _ in pairs:
            opts.delValue(key)
        raise
    return [key for key, _ in pairs]


def check_petsc_options(prefix: str) -> None:
    """Set up a KSP with options prefix ``prefix`` like the solver's on PETSc.COMM_SELF; InputError naming the
    options when PETSc refuses them."""
    from petsc4py import PETSc

    n = 6
    A = PETSc.Mat().createAIJ([n, n], nnz=3, comm=PETSc.COMM_SELF)
    for i in range(n):  # the 1D Laplacian: SPD, so every sensible KSP/PC can set up on it
        A.setValue(i, i, 2.0)
        if i > 0:
            A.setValue(i, i - 1, -1.0)
        if i < n - 1:
            A.setValue(i, i + 1, -1.0)
    A.assemble()
    A.setOptionsPrefix(prefix)
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    try:
        ksp.setOptionsPrefix(prefix)
        ksp.setOperators(A)
        ksp.setType(PETSc.KSP.Type.GMRES)
        ksp.setPCSide(PETSc.PC.Side.RIGHT)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.getPC().setType("ilu")
        ksp.setFromOptions()
        ksp.setUp()
        check_option_values(prefix)
    except PETSc.Error as err:
        given = " ".join(f"-{k} {v}".strip() for k, v in PETSc.Options().getAll().items() if k.startswith(prefix))
        detail = [re.sub(r"^\[\d+\]\s*", "", line.strip()) for line in str(err).splitlines() if line.strip()]
        raise InputError(f"PETSc options {given!r} cannot be used by the solver: "
                         f"{detail[-1] if detail else err}") from None
    finally:
        ksp.destroy()
        A.destroy()


def check_option_values(prefix: str) -> None:
    """InputError naming a numeric option of the database (under ``prefix``) whose value is out of its range
    (:func:`~fenics_coulomb.scd.preconditioner.check_option_value`)."""
    opts = PETSc.Options()
    for key in OPTION_RANGES:
        if opts.hasName(f"{prefix}{key}"):
            check_option_value(f"{prefix}{key}", opts.getString(f"{prefix}{key}"))


def _petsc_pairs(tokens: list[str]) -> list[tuple[str, str]]:
    """Split ``-key [value]`` tokens into (key, value) pairs."""
    pairs: list[tuple[str, str]] = []
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if not token.startswith("-") or token.startswith("--"):
            raise InputError(f"unrecognized argument {token!r}")
        key = token.lstrip("-")
        value = ""
        if i + 1 < len(tokens) and not _is_option(tokens[i + 1]):
            value = tokens[i + 1]
            i += 1
        pairs.append((key, value))
        i += 1
    return pairs


def _is_option(token: str) -> bool:
    if not token.startswith("-"):
        return False
    try:
        float(token)
        return False
    except ValueError:
        return True


if __name__ == "__main__":
    sys.exit(run_command())
