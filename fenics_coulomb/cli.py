"""Command line: ``python3 -m fenics_coulomb [flags]`` (runs unchanged under ``mpirun -n N``).

Exit status: 0 solved, 2 bad input (one line naming the value, on every rank, before any collective
call), 3 no convergence (the last iterate and the history are still written).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
import traceback
from pathlib import Path

from mpi4py import MPI

import numpy as np

from fenics_coulomb.config import Scene
from fenics_coulomb.errors import InputError, SolverError, check_all
from fenics_coulomb.model import ContactModel, Material
from fenics_coulomb.newton import PRECONDITIONERS, SCDNewtonSolver, SolveResult
from fenics_coulomb.output import ResultDirectory, summary, write_convergence_csv, write_summary, write_xdmf
from fenics_coulomb.scene import GAP_PROFILES, LOAD_CASES

logger = logging.getLogger("fenics_coulomb")

EXIT_INPUT = 2
EXIT_DIVERGED = 3


def build_parser(prog: str = "python3 -m fenics_coulomb") -> argparse.ArgumentParser:
    """The argument parser shared by the CLI and the demo (scene values are None unless given)."""
    d = Scene()
    p = argparse.ArgumentParser(
        prog=prog,
        description="3D static contact of a linear-elastic body with a rigid plane under Coulomb friction, "
        "solved by the SCD semismooth* Newton method (DOLFINx/PETSc, MPI-parallel).",
        epilog="Flags override the scene file's values. PETSc options for the Newton system can be appended "
        "with the prefix -coulomb_, e.g. -coulomb_ksp_monitor -coulomb_pc_type gamg.",
    )
    p.add_argument("--scene", default=None, help="scene file (TOML), e.g. demos/scenes/d3_L2.toml")
    p.add_argument("--lev", type=int, help=f"discretization level of the cuboid (>= 0; default {d.lev})")
    p.add_argument("--gap", help=f"gap profile {', '.join(GAP_PROFILES)} or an expression in x1, x2 "
                   f"(default {d.gap})")
    p.add_argument("--load", help=f"load case {', '.join(LOAD_CASES)} (default {d.load})")
    p.add_argument("--load-scale", type=float, help="factor on the tractions (default 1)")
    p.add_argument("--young", type=float, help=f"Young's modulus E in GPa (default {d.young})")
    p.add_argument("--poisson", type=float, help=f"Poisson ratio (default {d.poisson})")
    p.add_argument("--friction", type=float, help=f"Coulomb coefficient F (default {d.friction})")
    p.add_argument("--variant", help="Newton step: 4a (S*Q, (5.4)) or 4b (SQ); default 4a")
    p.add_argument("--tol", type=float, help=f"relative GMRES residual per Newton step (default {d.tol})")
    p.add_argument("--rtol", type=float, help=f"stop at |y| <= rtol |y0| (default {d.rtol})")
    p.add_argument("--accuracy", type=float,
                   help="relative displacement error to reach instead of --rtol (e.g. 1e-6); "
                   "mapped to rtol by the measured speed-accuracy table (docs/tradeoff)")
    p.add_argument("--adaptive-tol", action=argparse.BooleanOptionalAction, default=None,
                   help="safeguarded Eisenstat-Walker forcing terms <= --tol (superlinear tail, fewer Newton "
                   f"steps); --no-adaptive-tol keeps every GMRES solve at --tol, as the paper (default "
                   f"{'on' if d.adaptive_tol else 'off'})")
    p.add_argument("--max-it", type=int, help=f"maximal Newton iterations (default {d.max_it})")
    p.add_argument("--pc", help=f"preconditioner: {', '.join(PRECONDITIONERS)} (default {d.pc})")
    p.add_argument("--gamma-scale", type=float,
                   help="γ = scale × power-method estimate of λ_max(A); the paper uses 1 "
                   f"(default {d.gamma_scale})")
    p.add_argument(
        "--start",
        help="'zero' (the paper's origin u = 0 of the shifted unknown, ũ = −d), 'undeformed' (ũ = 0) or the "
        "solution.xdmf of an earlier run, interpolated onto this mesh (default zero)",
    )
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
    scene = Scene.from_toml(args.scene) if args.scene else Scene()
    return scene.override(
        lev=args.lev, gap=args.gap, load=args.load, load_scale=args.load_scale, young=args.young,
        poisson=args.poisson, friction=args.friction, variant=args.variant, tol=args.tol, rtol=args.rtol,
        max_it=args.max_it, pc=args.pc, gamma_scale=args.gamma_scale, start=args.start, predictor=args.predictor,
        accuracy=args.accuracy, adaptive_tol=args.adaptive_tol,
    )


def prepare_output(comm: MPI.Comm, out: str) -> ResultDirectory:
    """Check that the result set can go to ``out``; raise InputError on every rank if it cannot."""
    return ResultDirectory(comm, out)


def run(args: argparse.Namespace, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """Solve the scene described by ``args``; return the exit status."""
    t0 = time.perf_counter()
    scene = scene_from_args(args)
    out = prepare_output(comm, args.out)

    body = scene.build_body(comm)
    model = ContactModel(body, Material(scene.young, scene.poisson), scene.friction, scene.traction_table(),
                         body_force=(scene.body_force[0], scene.body_force[1], scene.body_force[2]))
    t_model = time.perf_counter() - t0
    logger.info("%s: n = %d unknowns, p = %d contact nodes, F = %g, %d rank(s)", body.description, model.n,
                model.p, scene.friction, comm.size)
    solver = SCDNewtonSolver(model, scene.settings())
    status = 0
    try:
        result = None
        if model.p == 0 or scene.predictor:
            result = solver.solve_linear()
            if model.p == 0:
                logger.info("no contact boundary: one linear solve")
            elif result.converged and solver.is_separated(result):
                logger.info("the linear solution does not reach the obstacle: it is the solution")
            else:
                logger.info("the linear solution penetrates the obstacle: SCD semismooth* Newton")
                result = None
        if result is None:
            result = solver.solve(initial_displacement(scene.start, model))
    except SolverError as err:
        result = err.result
        status = EXIT_DIVERGED
        logger.error("fenics-coulomb: the solve did not converge: %s", err)
    t_write = time.perf_counter()
    label = scene.name if args.scene else f"{scene.gap}/{scene.load}, lev {scene.lev}"
    with out.writing() as tmp:
        files = write_results(tmp, model, result, label, plots=not args.no_plots)
        data = summary(model, result, {"scene": scene.as_dict(), "settings": vars(scene.settings()),
                                       "body": body.description})
        data["timings_s"]["model"] = comm.allreduce(t_model, op=MPI.MAX)
        data["timings_s"]["output"] = comm.allreduce(time.perf_counter() - t_write, op=MPI.MAX)
        data["files"] = [*files, "summary.json"]
        write_summary(tmp / "summary.json", data, comm)
    counts = data["state_counts"]
    if comm.rank == 0:
        print(
            f"{'converged' if result.converged else 'NOT converged (' + result.reason + ')'}: "
            f"{result.iterations} Newton / {result.krylov_iterations} Krylov iterations, "
            f"open/stick/slip {counts['open']}/{counts['stick']}/{counts['slip']}, "
            f"{data['wall_time_s']:.2f} s; results in {args.out}/ ({', '.join(data['files'])})",
            flush=True,
        )
    solver.destroy()
    model.destroy()
    return status


def write_results(directory: Path, model: ContactModel, result: SolveResult, label: str, plots: bool = True
                  ) -> list[str]:
    """Write the fields, the convergence history and (optionally) the figures into ``directory`` (collective).

    Returns:
        The names of the files written (figures that failed are left out; see figures.write_figures).
    """
    write_xdmf(directory / "solution.xdmf", model, result)
    write_convergence_csv(directory / "convergence.csv", result, model.V.mesh.comm)
    files = ["solution.xdmf", "solution.h5", "convergence.csv"]
    if plots:
        from fenics_coulomb.figures import write_figures

        files += write_figures(directory, model, result, label)
    return files


def initial_displacement(start: str, model: ContactModel) -> np.ndarray | None:
    """ũ⁽⁰⁾ on the owned DOFs for a start setting (None means ũ = 0)."""
    if start == "undeformed":
        return None
    if start == "zero":
        return -model.shift.getArray(readonly=True).copy()
    from fenics_coulomb.output import check_solution_file, read_displacement

    comm = model.V.mesh.comm
    message = ""
    if comm.rank == 0:
        problem = check_solution_file(Path(start))
        message = f"--start {start!r}: {problem}" if problem else ""
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)
    return read_displacement(Path(start), model.V)


def main(argv: list[str] | None = None, prog: str = "python3 -m fenics_coulomb") -> int:
    """Entry point; returns the exit status (2 bad input, 3 no convergence)."""
    comm = MPI.COMM_WORLD
    parser = build_parser(prog)
    args, petsc_args = parser.parse_known_args(argv)
    configure_logging(comm, args.quiet, args.verbose)
    try:
        set_petsc_options(petsc_args)
        return run(args, comm)
    except InputError as err:
        if comm.rank == 0:
            print(f"{prog}: error: {err}", file=sys.stderr, flush=True)
        return EXIT_INPUT
    except Exception:  # an unexpected failure on any rank must end all ranks, not hang them
        print(f"[rank {comm.rank}] fenics-coulomb: unexpected error:\n{traceback.format_exc()}",
              file=sys.stderr, flush=True)
        comm.Abort(1)
        return 1


def set_petsc_options(tokens: list[str]) -> None:
    """Put ``-coulomb_*`` options from the command line into PETSc's options database.

    Only prefixed options are accepted, so nothing outside fenics-coulomb's objects is changed.
    """
    from petsc4py import PETSc

    opts = PETSc.Options()
    for key, value in _petsc_pairs(tokens):
        if not key.startswith("coulomb_"):
            raise InputError(f"unrecognized argument -{key} (PETSc options must carry the prefix -coulomb_)")
        opts[key] = value


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
    sys.exit(main())
