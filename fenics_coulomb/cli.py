"""Command line: ``python3 -m fenics_coulomb [flags]`` (runs unchanged under ``mpirun -n N``).

Exit status: 0 solved, 2 bad input (one line naming the value, on every rank, before any collective
call), 3 no convergence (the last iterate and the history are still written).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
import traceback
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from fenics_coulomb.builder import build_problem
from fenics_coulomb.checks import boundary_reactions, total_contact_force
from fenics_coulomb.config import Scene
from fenics_coulomb.errors import InputError, SolverError, check_all
from fenics_coulomb.model import ContactModel
from fenics_coulomb.obstacles import frames_from_normals, to_local
from fenics_coulomb.output import summary, write_convergence_csv, write_summary, write_xdmf
from fenics_coulomb.records import SolveResult
from fenics_coulomb.scene import GAP_PROFILES, LOAD_CASES
from fenics_coulomb.settings import PRECONDITIONERS

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
    """Flags → scene → problem → solve → output; return the exit status."""
    t0 = time.perf_counter()
    scene = scene_from_args(args)
    out = prepare_output(comm, args.out)
    built = build_problem(scene, comm)
    with built.problem as problem:
        model = problem.model
        t_model = time.perf_counter() - t0
        logger.info("%s: n = %d unknowns, p = %d contact nodes, F = %g, %d rank(s)", built.body.description,
                    problem.n, problem.p, scene.friction.coefficient, comm.size)
        status = 0
        try:
            _, result = problem.solve(start_function(scene.start, problem.V))
        except SolverError as err:
            result = err.result
            status = EXIT_DIVERGED
            logger.error("fenics-coulomb: the solve did not converge: %s", err)
        t_write = time.perf_counter()
        write_xdmf(out / "solution.xdmf", model, result)
        data = summary(model, result, {"scene": scene.as_dict(), "settings": vars(problem.settings),
                                       "body": built.body.description})
        data["timings_s"]["model"] = comm.allreduce(t_model, op=MPI.MAX)
        data["reactions"] = boundary_reactions(model, result.displacement, built.dirichlet_groups or {})
        data["contact_force"] = total_contact_force(model, result.contact_force)
        write_convergence_csv(out / "convergence.csv", result, comm)
        if not args.no_plots:
            write_figures(out, model, result, scene.label)
        data["timings_s"]["output"] = comm.allreduce(time.perf_counter() - t_write, op=MPI.MAX)
        write_summary(out / "summary.json", data, comm)
    counts = data["state_counts"]
    if comm.rank == 0:
        print(
            f"{'converged' if result.converged else 'NOT converged (' + result.reason + ')'}: "
            f"{result.iterations} Newton / {result.krylov_iterations} Krylov iterations, "
            f"open/stick/slip {counts['open']}/{counts['stick']}/{counts['slip']}, "
            f"{data['wall_time_s']:.2f} s; results in {out}/ (solution.xdmf, summary.json, convergence.csv"
            f"{'' if args.no_plots else ', convergence.png, contact_states.png, deformed.png'})",
            flush=True,
        )
        print(f"total contact force on the body {_vector_text(data['contact_force'])}; reactions: "
              + ", ".join(f"{name} {_vector_text(v)}" for name, v in data["reactions"].items()), flush=True)
    return status


def _vector_text(v: list[float]) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in v) + ")"


def write_figures(out: Path, model: ContactModel, result: SolveResult, label: str) -> None:
    """The PNG figures: deformed body, convergence history, contact states (collective)."""
    from fenics_coulomb.figures import gather_contact, plot_contact_states, plot_convergence, plot_deformed

    plot_deformed(model.V, result.displacement, model.contact.coordinates,
                  result.displacement[model.contact.local_dofs], result.states, out / "deformed.png",
                  f"Deformed body, {label}")
    # the contact surface in its own projection: onto the plane ⊥ the mean contact normal (x1, x2 for the
    # paper's plane)
    normal = np.asarray(model.comm.allreduce(model.contact.normals.sum(axis=0), op=MPI.SUM))
    normal = normal / np.linalg.norm(normal) if np.linalg.norm(normal) > 0 else np.array([0.0, 0.0, 1.0])
    frame = frames_from_normals(normal)
    axes = ("$x_1$", "$x_2$") if np.allclose(frame[0], np.eye(3)) else ("$t_1$", "$t_2$")
    projected = to_local(np.broadcast_to(frame, (model.contact.size, 3, 3)), model.contact.coordinates)
    gathered = gather_contact(model.comm, projected, result.states)
    if gathered is not None:
        plot_convergence({label: result.residual_history}, out / "convergence.png", f"Convergence, {label}")
        plot_contact_states(*gathered, out / "contact_states.png", f"Contact states, {label}", axes)


def start_function(start: str, V: dolfinx.fem.FunctionSpace) -> dolfinx.fem.Function | None:
    """The start ũ⁽⁰⁾ of a start setting: None (the paper's u⁽⁰⁾ = 0), zero, or an earlier run's solution."""
    if start == "zero":
        return None
    u0 = dolfinx.fem.Function(V)
    if start == "undeformed":
        return u0
    from fenics_coulomb.output import read_displacement

    comm = V.mesh.comm
    message = ""
    if comm.rank == 0:
        try:
            import h5py

            with h5py.File(Path(start).with_suffix(".h5"), "r") as h5:
                shape = h5["Function/displacement/0"].shape
                if len(shape) != 2 or shape[1] != 3:
                    message = f"--start {start!r}: 'displacement' is not a 3-vector field (shape {shape})"
        except (OSError, KeyError) as err:
            message = f"--start {start!r}: no displacement from an earlier run can be read ({err})"
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)
    u0.x.petsc_vec.array[:] = read_displacement(Path(start), V)
    u0.x.scatter_forward()
    return u0


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
