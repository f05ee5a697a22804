"""Cost of the contact solve relative to one linear-elastic solve of the same mesh on the same ranks.

Both include assembly. The linear-elastic reference is CG + GAMG with the rigid-body near-nullspace to
rtol 1e-8; the contact solve is the SCD semismooth* Newton method with the chosen preconditioner.

    container/run mpirun -n 2 python3 benchmarks/ratio.py --levels 6 8 --pc gamg --out docs/ratio
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

from common import build, peak_rss_mib, solve, write_table
from elastic import linear_elastic

from fenics_coulomb.settings import SolverSettings


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[6, 8])
    parser.add_argument("--case", default="d3/L2")
    parser.add_argument("--pc", nargs="+", default=["gamg", "ilu"])
    parser.add_argument("--adaptive-tol", action="store_true", help="Eisenstat-Walker forcing terms")
    parser.add_argument("--out", default="docs/ratio")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    gap, load = args.case.split("/")
    rows = []
    for lev in args.levels:
        reference = linear_elastic(comm, lev, gap, load)
        t_lin, its_lin = reference.timings["total"], reference.iterations
        for pc in args.pc:
            comm.barrier()
            model, t_model = build(comm, lev, gap, load)
            result, t_solve = solve(model, SolverSettings(rtol=1e-12, pc=pc, adaptive_tol=args.adaptive_tol))
            label = (pc if pc == result.pc else f"{pc} ({result.pc})") + (" + EW" if args.adaptive_tol else "")
            row = {"lev": lev, "n": model.n, "pc": label, "newton": result.iterations,
                   "krylov": result.krylov_iterations, "contact_s": t_model + t_solve,
                   "assembly_s": t_model, "linear_elastic_s": t_lin, "cg_its": its_lin,
                   "ratio": (t_model + t_solve) / t_lin, "converged": result.converged,
                   "peak_rss_MiB": peak_rss_mib(comm)}
            model.destroy()
            rows.append(row)
            if comm.rank == 0:
                print(row, flush=True)
    write_table(Path(args.out), "ratio", f"Contact solve / linear-elastic solve, case {args.case}, {comm.size} ranks",
                rows, comm)
    return 0


if __name__ == "__main__":
    sys.exit(main())
