"""Command line: ``python3 -m fenics_coulomb [flags]`` (runs unchanged under ``mpirun -n N``).

Exit status (:data:`EXIT_STATUSES`, also in ``--help``): 0 solved, the physics checks passed; 2 bad input (one
line naming the value, on every rank, before any collective call where the value is known before the mesh);
3 no convergence, or a solution that fails the physics checks (the last iterate and the history are written);
4 the results could not be written (disk full, a file-size limit; one line, the earlier results kept);
128 + signal (130 SIGINT, 143 SIGTERM, 129 SIGHUP) interrupted: every rank ends, the earlier results are kept and
no partial set is left (a load path's completed solves go to OUT.interrupted, resumable); 1 an unexpected error (a
bug: with a traceback).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import textwrap
import traceback
from typing import TYPE_CHECKING, NoReturn

from mpi4py import MPI
from petsc4py import PETSc

from fenics_coulomb.errors import (  # the exit statuses are the command's: re-exported
    EXIT_DIVERGED,
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OUTPUT,
    EXIT_STATUSES,
    InputError,
    Interrupted,
    OutputError,
)
from fenics_coulomb.io.display import virtual_display
from fenics_coulomb.launcher import _end_on_signals, _finish_together, exit_status
from fenics_coulomb.runner import run
from fenics_coulomb.scd.linear_solves import LINEAR_SOLVES
from fenics_coulomb.scd.options import option_read, set_petsc_options, unread_hint
from fenics_coulomb.scenes.cuboid import GAP_PROFILES, LOAD_CASES
from fenics_coulomb.scenes.nested import NESTED_AUTO_MIN_LEV, NESTED_COARSE_RTOL
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.settings import PRECONDITIONERS

if TYPE_CHECKING:
    from _typeshed import SupportsWrite

__all__ = ["EXIT_DIVERGED", "EXIT_INPUT", "EXIT_INTERRUPTED", "EXIT_OUTPUT", "EXIT_STATUSES", "ArgumentParser",
           "build_parser", "configure_logging", "main", "run_command"]


logger = logging.getLogger("fenics_coulomb")



class ArgumentParser(argparse.ArgumentParser):
    """argparse that prints on rank 0 only (help, usage, errors) and reports an error in one line.

    Every rank parses the same arguments, so every rank exits with status 2 (or 0 for --help) and only
    the message is not repeated once per rank.
    """

    def _print_message(self, message: str, file: SupportsWrite[str] | None = None) -> None:
        if MPI.COMM_WORLD.rank == 0:
            super()._print_message(message, file)

    def error(self, message: str) -> NoReturn:
        if MPI.COMM_WORLD.rank == 0:
            print(f"{self.prog}: error: {message} (see --help)", file=sys.stderr, flush=True)
        _finish_together(MPI.COMM_WORLD)
        sys.exit(EXIT_INPUT)


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
    p.add_argument("--sliding", help="contact geometry: finite (evaluated in the deformed configuration, the "
                                     "default) or small (in the reference configuration only)")
    p.add_argument("--variant", help="Newton step: 4a (S*Q, (5.4)) or 4b (SQ); default 4a")
    p.add_argument("--tol", type=float, help=f"relative GMRES residual per Newton step (default {d.solver.tol})")
    p.add_argument("--rtol", type=float, help=f"stop at |y| <= rtol |y0| (default {d.solver.rtol})")
    p.add_argument("--accuracy", type=float,
                   help="relative displacement error to reach instead of --rtol (e.g. 1e-6; not both); "
                   "mapped to rtol by the measured speed-accuracy table (docs/tradeoff)")
    p.add_argument("--adaptive-tol", action=argparse.BooleanOptionalAction, default=None,
                   help="safeguarded Eisenstat-Walker forcing terms <= --tol (superlinear tail, fewer Newton "
                   f"steps); --no-adaptive-tol keeps every GMRES solve at --tol, as the paper (default "
                   f"{'on' if d.solver.adaptive_tol else 'off'})")
    p.add_argument("--matrix-free", action=argparse.BooleanOptionalAction, default=None,
                   help="apply the Newton matrix as D(A x) + C x without a second copy of A when the "
                   "preconditioner is built on A (gamg); --no-matrix-free stores it (default "
                   f"{'on' if d.solver.matrix_free else 'off'})")
    p.add_argument("--max-it", type=int, help=f"maximal Newton iterations (default {d.solver.max_it})")
    p.add_argument("--pc", help=f"preconditioner: {', '.join(PRECONDITIONERS)} (default {d.solver.pc})")
    p.add_argument("--gamma-scale", type=float,
                   help="γ = scale × power-method estimate of λ_max(A); the paper uses 1 "
                   f"(default {d.solver.gamma_scale})")
    p.add_argument(
        "--start",
        help="'auto' (the default: 'zero' when the loads drive the body onto its obstacles, 'undeformed' when the "
        "obstacles overlap it), 'zero' (the paper's origin u = 0 of the shifted unknown, ũ = −d), 'undeformed' "
        "(ũ = 0) or the solution.xdmf of an earlier run, interpolated onto this mesh",
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
        solves = LINEAR_SOLVES[0]
        with virtual_display(enabled=not args.no_plots and comm.rank == 0):
            status = run(args, comm)
        # after a linear solve only: a preconditioner reads some options at its first set-up (a zero load solves none)
        unread = [f"-{key}" for key in given if option_read(key) is False] if LINEAR_SOLVES[0] > solves else []
        if unread and comm.rank == 0:  # PETSc's -options_left, which the options' removal below would silence
            logger.warning("PETSc options not read by any solver object: %s — misspelt, or options of another "
                           "preconditioner than the one in use%s", " ".join(unread), unread_hint(unread, comm.size > 1))
        return status
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
              f"ranks{getattr(err, 'kept', '')}", file=sys.stderr, flush=True)
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


def run_command(argv: list[str] | None = None, prog: str = "python3 -m fenics_coulomb") -> int:
    """The command line as a program: :func:`main`, then :func:`exit_status` (``python3 -m fenics_coulomb``, the
    ``fenics-coulomb`` script and the demos end through it; tests call :func:`main` in-process)."""
    return exit_status(main(argv, prog))


if __name__ == "__main__":
    sys.exit(run_command())
