"""Table 2 of the paper: the six Section 7 cases for a range of levels (tol = 0.1, u⁽⁰⁾ = 0).

    container/run mpirun -n 2 python3 benchmarks/table2.py --levels 2 3 4 5 6 --out docs/table2

Writes ``table2.csv`` and ``table2.md`` (p, n, Newton iterations, Krylov iterations, wall time, peak
memory per case) with the machine and software versions.
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import platform
import sys
from pathlib import Path

from mpi4py import MPI

from common import CASES, peak_rss_mib, run_case

from fenics_coulomb.io.summary import software_versions
from fenics_coulomb.settings import SolverSettings


def row_of(comm: MPI.Comm, lev: int, gap: str, load: str, settings: SolverSettings) -> dict:
    """Solve one case; return its row (global numbers, identical on all ranks)."""
    run = run_case(comm, lev, gap, load, settings)
    result = run.result
    counts = result.state_counts(comm)
    row = {
        "lev": lev, "case": f"{gap}/{load}", "p": run.model.p, "n": run.model.n, "pc": result.pc,
        "converged": result.converged, "newton": result.iterations, "krylov": result.krylov_iterations,
        "solve_s": run.solve_s, "model_s": run.model_s, "peak_rss_MiB": peak_rss_mib(comm),
        "open": counts["open"], "stick": counts["stick"], "slip": counts["slip"],
    }
    run.destroy()
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[2, 3, 4, 5, 6])
    parser.add_argument("--tol", type=float, default=0.1)
    parser.add_argument("--pc", default=SolverSettings.pc)
    parser.add_argument("--variant", default="4a")
    parser.add_argument("--gamma-scale", type=float, default=SolverSettings.gamma_scale)
    parser.add_argument("--adaptive-tol", action="store_true",
                        help="safeguarded Eisenstat-Walker forcing terms <= tol instead of the paper's fixed tol")
    parser.add_argument("--out", default="docs/table2")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    logging.basicConfig(level=logging.WARNING)
    settings = SolverSettings(rtol=1e-12, tol=args.tol, pc=args.pc, variant=args.variant, gamma_scale=args.gamma_scale,
                              adaptive_tol=args.adaptive_tol)
    rows = []
    for lev in args.levels:
        for gap, load in CASES:
            row = row_of(comm, lev, gap, load, settings)
            rows.append(row)
            if comm.rank == 0:
                print(json.dumps(row), flush=True)
    if comm.rank == 0:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "table2.csv", "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        lines = [
            f"# Table 2: tol = {args.tol} "
            f"({'Eisenstat-Walker forcing terms <= tol' if args.adaptive_tol else 'fixed, the paper rule'}), "
            f"pc = {args.pc}, variant {args.variant}, "
            f"gamma = {args.gamma_scale} x power-method estimate, u(0) = 0, "
            f"{comm.size} rank(s)",
            "",
            f"Machine: {platform.machine()} {platform.processor() or ''}, {comm.size} MPI rank(s); "
            f"versions: {json.dumps(software_versions())}",
            "",
            "| lev | case | p | n | pc | Newton | Krylov | solve (s) | peak RSS (MiB) | open/stick/slip |",
            "|---:|:---|---:|---:|:---|---:|---:|---:|---:|:---|",
        ]
        for r in rows:
            flag = "" if r["converged"] else " (not converged)"
            lines.append(
                f"| {r['lev']} | {r['case']} | {r['p']} | {r['n']} | {r['pc']} | {r['newton']}{flag} | {r['krylov']} | "
                f"{r['solve_s']:.2f} | {r['peak_rss_MiB']:.0f} | {r['open']}/{r['stick']}/{r['slip']} |"
            )
        (out / "table2.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
