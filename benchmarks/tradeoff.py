"""The speed–accuracy trade: wall time against the error for the stopping reduction rtol, the GMRES
tolerance tol, the preconditioner and the mesh level.

Each setting is run with the fixed GMRES tolerance tol (the paper's forcing) and with the safeguarded
Eisenstat–Walker terms capped by tol (``forcing`` column).

Errors of a run on level L, case d3/L2:
* ``solve_error``: ‖ũ − ũ_ref‖/‖ũ_ref‖ against a tightly solved reference on the same mesh
  (rtol 1e-14, tol 1e-3, LU where it fits);
* ``wrong_state_pct``: percentage of contact nodes whose state (open/stick/slip) differs from the reference;
* ``discretization_error``: ‖I_h ũ_L − ũ_fine‖/‖ũ_fine‖ on the finest level's mesh (tight solves).

    container/run mpirun -n 2 python3 benchmarks/tradeoff.py --levels 4 6 --fine 8 --out docs/tradeoff
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import build, norm, solve, write_table

from fenics_coulomb.start_rule import interpolate_displacement
from fenics_coulomb.settings import SolverSettings

TIGHT = SolverSettings(rtol=1e-14, tol=1e-3, max_it=200)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=int, nargs="+", default=[4, 6])
    parser.add_argument("--fine", type=int, default=8)
    parser.add_argument("--case", default="d3/L2")
    parser.add_argument("--rtols", type=float, nargs="+", default=[1e-4, 1e-6, 1e-8, 1e-10, 1e-12])
    parser.add_argument("--tols", type=float, nargs="+", default=[0.5, 0.1, 0.01])
    parser.add_argument("--pcs", nargs="+", default=["ilu", "gamg"])
    parser.add_argument("--forcing", nargs="+", choices=["fixed", "ew"], default=["fixed", "ew"],
                        help="fixed GMRES tolerance tol (the paper's) and/or Eisenstat-Walker terms <= tol")
    parser.add_argument("--out", default="docs/tradeoff")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    gap, load = args.case.split("/")

    fine_model, _ = build(comm, args.fine, gap, load)
    fine, _ = solve(fine_model, TIGHT)
    fine_norm = norm(comm, fine.displacement)

    rows = []
    for lev in args.levels:
        model, _ = build(comm, lev, gap, load)
        ref, _t_ref = solve(model, TIGHT)
        ref_norm = norm(comm, ref.displacement)
        on_fine = interpolate_displacement(model.u, fine_model.V)
        disc = norm(comm, on_fine - fine.displacement) / fine_norm
        for pc in args.pcs:
            for forcing in args.forcing:
                for tol in args.tols:
                    for rtol in args.rtols:
                        settings = SolverSettings(rtol=rtol, tol=tol, pc=pc, adaptive_tol=forcing == "ew")
                        result, t = solve(model, settings)
                        wrong = comm.allreduce(int(np.sum(result.states != ref.states)), op=MPI.SUM)
                        rows.append({
                            "lev": lev, "n": model.n, "pc": pc, "forcing": forcing, "tol": tol, "rtol": rtol,
                            "converged": result.converged, "newton": result.iterations,
                            "krylov": result.krylov_iterations, "time_s": t,
                            "solve_error": norm(comm, result.displacement - ref.displacement) / ref_norm,
                            "wrong_state_pct": 100.0 * wrong / model.p, "discretization_error": disc,
                        })
                        if comm.rank == 0:
                            print(rows[-1], flush=True)
        model.destroy()
    fine_model.destroy()
    out = Path(args.out)
    write_table(out, "tradeoff", f"Speed-accuracy trade, case {args.case}, {comm.size} ranks "
                f"(reference: tight solve on the same mesh; discretization error against lev {args.fine})", rows, comm)
    if comm.rank == 0:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, len(args.levels), figsize=(6 * len(args.levels), 4.5), squeeze=False)
        for ax, lev in zip(axes[0], args.levels, strict=True):
            for pc, marker in zip(args.pcs, "os^", strict=False):
                for forcing, style in zip(args.forcing, ("-", "--"), strict=False):
                    for tol in args.tols:
                        sel = [r for r in rows if r["lev"] == lev and r["pc"] == pc and r["tol"] == tol
                               and r["forcing"] == forcing]
                        ax.loglog([r["time_s"] for r in sel], [max(r["solve_error"], 1e-16) for r in sel],
                                  marker=marker, ls=style, label=f"{pc}, tol {tol:g}, {forcing}")
            disc = next(r["discretization_error"] for r in rows if r["lev"] == lev)
            ax.axhline(disc, color="k", ls="--", lw=1, label="discretization error")
            ax.set_xlabel("wall time (s)")
            ax.set_ylabel("relative displacement error")
            ax.set_title(f"lev {lev}: points are rtol = {', '.join(f'{r:g}' for r in args.rtols)}", fontsize=9)
            ax.grid(True, which="both", alpha=0.3)
        axes[0][0].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "tradeoff.png", dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
