"""GAMG level-smoother sweeps for the Newton systems: time and iterations of one and two Chebyshev sweeps.

    container/run mpirun -n 2 python3 benchmarks/gamg_sweeps.py --levels 6 8 --out docs/gamg-sweeps
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

from common import build, solve, write_table

from fenics_coulomb.settings import SolverSettings


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[6, 8])
    parser.add_argument("--case", default="d3/L2")
    parser.add_argument("--sweeps", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--out", default="docs/gamg-sweeps")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    gap, load = args.case.split("/")
    opts = PETSc.Options()
    key = "coulomb_mg_levels_ksp_max_it"
    rows = []
    for lev in args.levels:
        model, _ = build(comm, lev, gap, load)
        for sweeps in args.sweeps:
            opts[key] = sweeps
            result, t_solve = solve(model, SolverSettings(pc="gamg"))
            del opts[key]
            rows.append({"lev": lev, "n": model.n, "sweeps": sweeps, "newton": result.iterations,
                         "krylov": result.krylov_iterations, "solve_s": t_solve, "converged": result.converged})
            if comm.rank == 0:
                print(rows[-1], flush=True)
        model.destroy()
    write_table(Path(args.out), "gamg-sweeps",
                f"GAMG Chebyshev sweeps per level, case {args.case}, rtol 1e-8, {comm.size} ranks", rows, comm)
    return 0


if __name__ == "__main__":
    sys.exit(main())
