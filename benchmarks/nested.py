"""Nested iteration of the command line: where it pays, and how accurately the coarse level must be solved.

For every level, case, ``--nested`` K and coarse reduction (``policy.NESTED_COARSE_RTOL``), the command line's
solve runs in this process (``cli.main``, the user's default settings otherwise) and its wall time (max over
ranks, from the parsing of the arguments to the written results: the build of the coarse and fine levels, both
solves, the interpolation and the output) is recorded with the fine and coarse Newton / Krylov counts from its
summary.json. The interpreter start and the imports, the same for every configuration, are not in it.

    container/run mpirun -n 2 python3 benchmarks/nested.py --levels 7 8 9 10 --out docs/nested
    container/run mpirun -n 2 python3 benchmarks/nested.py --levels 10 --nested 1 \
        --coarse-rtol 1e-2 1e-4 1e-6 1e-8 --out docs/nested/rtol
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from common import write_table

import fenics_coulomb.cli as cli
import fenics_coulomb.scenes.nested as policy


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[7, 8, 9, 10])
    parser.add_argument("--cases", nargs="+", default=["d3/L2"], help="gap/load pairs, e.g. d3/L2 d1/L1")
    parser.add_argument("--nested", type=int, nargs="+", default=[0, 1], help="values of --nested K")
    parser.add_argument("--coarse-rtol", type=float, nargs="+", default=[policy.NESTED_COARSE_RTOL],
                        help="coarse reductions to compare (runs with K = 0 are made once)")
    parser.add_argument("--out", default="docs/nested")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    default_rtol = policy.NESTED_COARSE_RTOL
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(comm.bcast(scratch if comm.rank == 0 else None))
        for case in args.cases:
            gap, load = case.split("/")
            for lev in args.levels:
                for nested in args.nested:
                    for rtol in (args.coarse_rtol if nested else [float("nan")]):
                        policy.NESTED_COARSE_RTOL = rtol if nested else default_rtol
                        out = work / f"{gap}{load}-{lev}-{nested}-{rtol:g}"
                        argv = ["--lev", str(lev), "--gap", gap, "--load", load, "--nested", str(nested),
                                "--no-plots", "--quiet", "--out", str(out)]
                        comm.barrier()
                        t0 = time.perf_counter()
                        status = cli.main(argv)
                        wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
                        data = json.loads((out / "summary.json").read_text())
                        rows.append({
                            "case": case, "lev": lev, "n": data["n"], "nested": nested,
                            "coarse_rtol": rtol, "exit": status, "wall_s": wall,
                            "newton": data["newton_iterations"], "krylov": data["krylov_iterations"],
                            "coarse_newton": sum(data["nested"]["newton_iterations"]),
                            "coarse_krylov": sum(data["nested"]["krylov_iterations"]),
                            "nested_s": data["timings_s"]["nested"],
                        })
                        if comm.rank == 0:
                            print(rows[-1], flush=True)
        policy.NESTED_COARSE_RTOL = default_rtol
    write_table(Path(args.out), "nested", f"Nested iteration of the command line, {comm.size} ranks "
                f"(nested_s: the coarse levels and the interpolation; wall_s from argument parsing to results)",
                rows, comm)
    return 0


if __name__ == "__main__":
    sys.exit(main())
