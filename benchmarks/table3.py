"""Table 3 of the paper: nested iteration — each level starts from the previous level's solution,
interpolated onto the (non-matching) finer hexahedral mesh — against the start u⁽⁰⁾ = 0.

    container/run mpirun -n 2 python3 benchmarks/table3.py --levels 2 3 4 5 6 7 8 --out docs/table3
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

from common import CASES, build, solve, write_table

from fenics_coulomb.settings import SolverSettings


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[2, 3, 4, 5, 6])
    parser.add_argument("--pc", default="ilu")
    parser.add_argument("--tol", type=float, default=0.1)
    parser.add_argument("--out", default="docs/table3")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    settings = SolverSettings(rtol=1e-12, pc=args.pc, tol=args.tol)
    rows = []
    for gap, load in CASES:
        previous = None  # the previous level's problem (holding its solution) and the solution
        for lev in args.levels:
            model, _ = build(comm, lev, gap, load)
            zero, t_zero = solve(model, settings)
            u_zero = model.u.copy()
            row = {"case": f"{gap}/{load}", "lev": lev, "p": model.p, "n": model.n,
                   "newton_zero": zero.iterations, "krylov_zero": zero.krylov_iterations, "time_zero_s": t_zero}
            if previous is not None:
                old_model, old_u = previous
                nested, t_nested = solve(model, settings, old_u)
                old_model.destroy()
                row.update(newton_nested=nested.iterations, krylov_nested=nested.krylov_iterations,
                           time_nested_s=t_nested,
                           krylov_reduction_pct=100.0 * (1 - nested.krylov_iterations / zero.krylov_iterations),
                           same_states=nested.state_counts(comm) == zero.state_counts(comm))
                u = model.u.copy()
            else:
                row.update(newton_nested="", krylov_nested="", time_nested_s="", krylov_reduction_pct="",
                           same_states="")
                u = u_zero
            previous = (model, u)
            rows.append(row)
            if comm.rank == 0:
                print(row, flush=True)
        if previous is not None:
            previous[0].destroy()
    write_table(Path(args.out), "table3",
                f"Table 3: nested iteration vs u(0) = 0 (tol {args.tol}, pc {args.pc}, {comm.size} ranks)", rows, comm)
    return 0


if __name__ == "__main__":
    sys.exit(main())
