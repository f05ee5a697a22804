"""Table 4 and Fig. 3 of the paper: case d3/L2 at one level for several GMRES tolerances tol.

    container/run mpirun -n 2 python3 benchmarks/table4.py --lev 8 --out docs/table4
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

from common import build, peak_rss_mib, solve, write_table

from fenics_coulomb.io.figures import plot_convergence
from fenics_coulomb.settings import SolverSettings


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lev", type=int, default=6)
    parser.add_argument("--case", default="d3/L2")
    parser.add_argument("--tols", type=float, nargs="+", default=[0.5, 0.1, 0.01, 0.001])
    parser.add_argument("--pc", default="ilu")
    parser.add_argument("--out", default="docs/table4")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    gap, load = args.case.split("/")
    model, _ = build(comm, args.lev, gap, load)
    rows, histories = [], {}
    for tol in args.tols:
        result, t = solve(model, SolverSettings(rtol=1e-12, tol=tol, pc=args.pc))
        rows.append({"lev": args.lev, "case": args.case, "n": model.n, "tol": tol, "newton": result.iterations,
                     "krylov": result.krylov_iterations, "solve_s": t, "converged": result.converged,
                     "peak_rss_MiB": peak_rss_mib(comm)})
        histories[f"tol = {tol:g}"] = result.residual_history
        if comm.rank == 0:
            print(rows[-1], flush=True)
    model.destroy()
    out = Path(args.out)
    write_table(out, "table4", f"Table 4: case {args.case}, lev {args.lev}, pc {args.pc}, u(0) = 0, "
                f"{comm.size} ranks", rows, comm)
    if comm.rank == 0:
        plot_convergence(histories, out / "fig3.png", f"Convergence for several tol ({args.case}, lev {args.lev})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
