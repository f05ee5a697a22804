"""GAMG for the Newton systems: prolongator smoothing steps and level-smoother sweeps, time and iterations.

For every case and level, the same problem is solved with every combination of ``--smooths``
(-coulomb_pc_gamg_agg_nsmooths: 1 is PETSc's smoothed aggregation, 0 unsmoothed) and ``--sweeps``
(-coulomb_mg_levels_ksp_max_it, Chebyshev sweeps per level), each by a new solver on the same model (the
GAMG hierarchy of A set up anew), in order; the solutions are compared with the first configuration's
(max-norm difference relative to its max norm: the preconditioner must not change the answer):

    container/run mpirun -n 2 python3 benchmarks/gamg_sweeps.py --levels 6 8 10 --out docs/gamg-sweeps
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np

from common import build, write_table

from fenics_coulomb import SolverError
from fenics_coulomb.model.dof_values import owned_values
from fenics_coulomb.settings import SolverSettings

SMOOTHS = "coulomb_pc_gamg_agg_nsmooths"
SWEEPS = "coulomb_mg_levels_ksp_max_it"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[6, 8])
    parser.add_argument("--cases", nargs="+", default=["d3/L2"], help="gap/load pairs, e.g. d3/L2 d1/L1")
    parser.add_argument("--smooths", type=int, nargs="+", default=[1, 0])
    parser.add_argument("--sweeps", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--out", default="docs/gamg-sweeps")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    opts = PETSc.Options()
    rows = []
    for case in args.cases:
        gap, load = case.split("/")
        for lev in args.levels:
            problem, _ = build(comm, lev, gap, load)
            reference = None
            for smooths in args.smooths:
                for sweeps in args.sweeps:
                    opts[SMOOTHS], opts[SWEEPS] = smooths, sweeps
                    try:
                        problem.set_solver(SolverSettings(pc="gamg"))
                        problem.reset()  # the static problem again, not a load path's next step
                        comm.barrier()
                        t0 = time.perf_counter()
                        try:
                            uh, result = problem.solve()
                        except SolverError as err:
                            if err.result is None:
                                raise
                            uh, result = None, err.result
                        t_solve = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
                    finally:
                        del opts[SMOOTHS], opts[SWEEPS]
                    diff = float("nan")
                    if uh is not None:
                        x = owned_values(uh)
                        if reference is None:
                            reference = x
                        else:
                            diff = (comm.allreduce(float(np.max(np.abs(x - reference), initial=0.0)), op=MPI.MAX)
                                    / comm.allreduce(float(np.max(np.abs(reference), initial=0.0)), op=MPI.MAX))
                    rows.append({"case": case, "lev": lev, "n": problem.model.n, "smooths": smooths,
                                 "sweeps": sweeps, "newton": result.iterations, "krylov": result.krylov_iterations,
                                 "solve_s": t_solve, "converged": result.converged, "rel_diff": diff})
                    if comm.rank == 0:
                        print(rows[-1], flush=True)
            problem.destroy()
    write_table(Path(args.out), "gamg-sweeps",
                f"GAMG prolongator smoothing (pc_gamg_agg_nsmooths) and Chebyshev sweeps per level, rtol 1e-8, "
                f"{comm.size} ranks", rows, comm)
    return 0


if __name__ == "__main__":
    sys.exit(main())
