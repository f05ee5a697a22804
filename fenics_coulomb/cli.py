"""Command line: ``python3 -m fenics_coulomb [flags]`` (runs unchanged under ``mpirun -n N``).

Exit status: 0 solved, 2 bad input (one line naming the value, on every rank, before any collective
call), 3 no convergence (the last iterate and the history are still written).
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import sys
import time
import traceback
from pathlib import Path
from typing import Any

from mpi4py import MPI

from fenics_coulomb.errors import InputError, SolverError, check_all
from fenics_coulomb.model import ContactModel, Material, validate_friction
from fenics_coulomb.newton import PRECONDITIONERS, SCDNewtonSolver, SolverSettings
from fenics_coulomb.output import summary, write_convergence_csv, write_summary, write_xdmf
from fenics_coulomb.scene import FACE_NAMES, GAP_PROFILES, LOAD_CASES, create_cuboid

logger = logging.getLogger("fenics_coulomb")

EXIT_INPUT = 2
EXIT_DIVERGED = 3


def build_parser(prog: str = "python3 -m fenics_coulomb") -> argparse.ArgumentParser:
    """The argument parser shared by the CLI and the demo."""
    p = argparse.ArgumentParser(
        prog=prog,
        description="3D static contact of a linear-elastic cuboid with a rigid plane under Coulomb friction, "
        "solved by the SCD semismooth* Newton method (DOLFINx/PETSc, MPI-parallel).",
        epilog="PETSc options for the Newton system can be appended with the prefix -coulomb_, "
        "e.g. -coulomb_ksp_monitor -coulomb_pc_type gamg.",
    )
    p.add_argument("--lev", type=int, default=4, help="discretization level (>= 0), default 4")
    p.add_argument("--gap", default="d3", help=f"gap profile: {', '.join(GAP_PROFILES)} (default d3)")
    p.add_argument("--load", default="L2", help=f"load case: {', '.join(LOAD_CASES)} (default L2)")
    p.add_argument("--load-scale", type=float, default=1.0, help="factor on the tractions (default 1)")
    p.add_argument("--young", type=float, default=70.0, help="Young's modulus E in GPa (default 70)")
    p.add_argument("--poisson", type=float, default=0.334, help="Poisson ratio (default 0.334)")
    p.add_argument("--friction", type=float, default=0.23, help="Coulomb coefficient F (default 0.23)")
    p.add_argument("--variant", default="4a", help="Newton step: 4a (S*Q, (5.4)) or 4b (SQ); default 4a")
    p.add_argument("--tol", type=float, default=0.1, help="relative GMRES residual per Newton step (0.1)")
    p.add_argument("--rtol", type=float, default=1e-12, help="stop at |y| <= rtol |y0| (default 1e-12)")
    p.add_argument("--max-it", type=int, default=100, help="maximal Newton iterations (default 100)")
    p.add_argument("--pc", default="ilu", help=f"preconditioner: {', '.join(PRECONDITIONERS)} (default ilu)")
    p.add_argument("--gamma", type=float, default=None, help="fixed γ (default: power method on A)")
    p.add_argument("--gamma-scale", type=float, default=0.01,
                   help="γ = scale × power-method estimate of λ_max(A); the paper uses 1 (default 0.01)")
    p.add_argument(
        "--start",
        default="zero",
        help="start: 'zero' (the paper's origin u = 0 of the shifted unknown, ũ = −d) or "
        "'undeformed' (ũ = 0); default zero",
    )
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


def validate_args(args: argparse.Namespace) -> None:
    """Raise InputError for any bad value (runs identically on every rank, no communication)."""
    if args.lev < 0:
        raise InputError(f"--lev {args.lev}: must be >= 0")
    if args.gap not in GAP_PROFILES:
        raise InputError(f"--gap {args.gap!r}: choose one of {sorted(GAP_PROFILES)}")
    if args.load not in LOAD_CASES:
        raise InputError(f"--load {args.load!r}: choose one of {sorted(LOAD_CASES)}")
    if not math.isfinite(args.load_scale):
        raise InputError(f"--load-scale {args.load_scale!r}: must be finite")
    Material(args.young, args.poisson).validate()
    validate_friction(args.friction)
    if args.start not in ("zero", "undeformed"):
        raise InputError(f"--start {args.start!r}: choose 'zero' or 'undeformed'")
    settings_from_args(args).validate()


def settings_from_args(args: argparse.Namespace) -> SolverSettings:
    """Solver settings of the command line."""
    return SolverSettings(
        variant=args.variant, tol=args.tol, rtol=args.rtol, max_iterations=args.max_it, pc=args.pc,
        gamma=args.gamma, gamma_scale=args.gamma_scale,
    )


def prepare_output(comm: MPI.Comm, out: str) -> Path:
    """Create the output directory on rank 0; raise InputError on every rank if it is unusable."""
    path = Path(out)
    message = ""
    if comm.rank == 0:
        try:
            path.mkdir(parents=True, exist_ok=True)
            probe = path / f".write-test-{os.getpid()}"
            probe.write_text("")
            probe.unlink()
        except OSError as err:
            message = f"--out {out!r}: output directory is not writable ({err.strerror or err})"
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)
    return path


def run(args: argparse.Namespace, comm: MPI.Comm = MPI.COMM_WORLD) -> int:
    """Solve the scene described by ``args``; return the exit status."""
    t0 = time.perf_counter()
    validate_args(args)
    out = prepare_output(comm, args.out)

    body = create_cuboid(comm, args.lev, args.gap)
    names = {tag: name for name, tag in FACE_NAMES.items()}
    tractions = {
        names[tag]: tuple(args.load_scale * c for c in value) for tag, value in LOAD_CASES[args.load].items()
    }
    model = ContactModel(body, Material(args.young, args.poisson), args.friction, tractions)
    t_model = time.perf_counter() - t0
    logger.info("%s: n = %d unknowns, p = %d contact nodes, %d rank(s)", body.description, model.n, model.p,
                comm.size)
    solver = SCDNewtonSolver(model, settings_from_args(args))
    start = None if args.start == "undeformed" else -model.shift.getArray(readonly=True).copy()
    status = 0
    try:
        result = solver.solve(start)
    except SolverError as err:
        result = err.result
        status = EXIT_DIVERGED
        logger.error("fenics-coulomb: the solve did not converge: %s", err)
    scene: dict[str, Any] = {
        "body": body.description, "lev": args.lev, "gap": args.gap, "load": args.load,
        "load_scale": args.load_scale, "young_GPa": args.young, "poisson": args.poisson,
        "friction": args.friction, "start": args.start,
    }
    settings = vars(settings_from_args(args))
    t_write = time.perf_counter()
    write_xdmf(out / "solution.xdmf", model, result)
    data = summary(model, result, {"scene": scene, "settings": settings})
    data["timings_s"]["model"] = comm.allreduce(t_model, op=MPI.MAX)
    data["timings_s"]["output"] = comm.allreduce(time.perf_counter() - t_write, op=MPI.MAX)
    write_summary(out / "summary.json", data, comm)
    write_convergence_csv(out / "convergence.csv", result, comm)
    if not args.no_plots:
        from fenics_coulomb.figures import gather_contact, plot_contact_states, plot_convergence

        gathered = gather_contact(comm, model.contact.coordinates, result.states)
        if gathered is not None:
            case = f"{args.gap}/{args.load}, lev {args.lev}"
            plot_convergence({case: result.residual_history}, out / "convergence.png", f"Convergence, {case}")
            plot_contact_states(*gathered, out / "contact_states.png", f"Contact states, {case}")
    counts = data["state_counts"]
    if comm.rank == 0:
        print(
            f"{'converged' if result.converged else 'NOT converged (' + result.reason + ')'}: "
            f"{result.iterations} Newton / {result.krylov_iterations} Krylov iterations, "
            f"open/stick/slip {counts['open']}/{counts['stick']}/{counts['slip']}, "
            f"{data['wall_time_s']:.2f} s; results in {out}/solution.xdmf and {out}/summary.json",
            flush=True,
        )
    solver.destroy()
    model.destroy()
    return status


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
