"""Numerical stability at the extremes: a parameter sweep that records, for every case, whether the solver
converged (or why not), its iterations and the physics-check residuals.

    container/run mpirun -n 2 python3 benchmarks/extremes.py --lev 4 --out docs/extremes

Large friction coefficients may make the discrete Coulomb problem non-unique: every friction case is also
solved from a second start (ũ = 0 besides the paper's origin) and the two solutions are compared.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
from common import norm, write_table

from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.errors import SolverError

CHECKS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction",
          "reaction_balance")


def cases(lev: int) -> list[tuple[str, dict[str, Any]]]:
    """(label, scene overrides) of the sweep."""
    out: list[tuple[str, dict[str, Any]]] = []
    out += [(f"F={F:g}", {"friction": F}) for F in (0.0, 1e-6, 0.23, 1.0, 5.0)]
    out += [(f"nu={nu:g}", {"poisson": nu}) for nu in (0.0, 0.3, 0.45, 0.49, 0.499)]
    out += [(f"nu={nu:g}, pc gamg", {"poisson": nu, "pc": "gamg"}) for nu in (0.49, 0.499)]
    out += [(f"load x{s:g}", {"load_scale": s}) for s in (1e-6, 1e-3, 0.1, 1.0, 3.0, 10.0)]
    out += [("zero load", {"load_scale": 0.0, "start": "undeformed"}),
            ("pulled away", {"load_scale": -1.0}),
            ("d = 0 (touching)", {"gap": "0"}),
            ("gap 0.5 (never reached)", {"gap": "0.5", "load_scale": 0.02})]
    out += [(f"E={E:g} GPa", {"young": E}) for E in (1e-3, 1.0, 70.0, 1e3)]
    out += [("lev 0", {"lev": 0}), ("lev 8", {"lev": 8})]
    out += [("variant 4b", {"variant": "4b"}), ("pc gamg", {"pc": "gamg"}), ("tol 0.5", {"tol": 0.5})]
    return out


def run_one(comm: MPI.Comm, scene: Scene, second_start: bool) -> dict[str, Any]:
    problem = build_problem(scene, comm).problem
    model = problem.model
    row: dict[str, Any] = {"n": problem.n}
    undeformed = dolfinx.fem.Function(problem.V)
    try:
        _, result = problem.solve(undeformed if scene.start == "undeformed" else None)
    except SolverError as err:
        result = err.result
    row.update(converged=result.converged, reason=result.reason, newton=result.iterations,
               krylov=result.krylov_iterations, max_u=float(comm.allreduce(
                   float(np.abs(result.displacement).max(initial=0.0)), op=MPI.MAX)))
    row.update(result.state_counts(comm))
    checks = physics_residuals(model, result.displacement)
    row["worst_check"] = max(CHECKS, key=lambda k: checks[k])
    row["worst_residual"] = max(checks[k] for k in CHECKS)
    row["second_start_diff"] = ""
    if second_start and result.converged:
        try:
            problem.reset()  # the same static problem, not the next step of a load path
            _, other = problem.solve(undeformed)
            diff = norm(comm, other.displacement - result.displacement) / max(norm(comm, result.displacement),
                                                                             1e-300)
            row["second_start_diff"] = diff
        except SolverError as err:
            row["second_start_diff"] = f"failed: {err.reason}"
    problem.destroy()
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lev", type=int, default=4)
    parser.add_argument("--case", default="d3/L2")
    parser.add_argument("--out", default="docs/extremes")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    gap, load = args.case.split("/")
    base = Scene().override(lev=args.lev, gap=gap, load=load)
    rows = []
    for label, overrides in cases(args.lev):
        scene = base.override(**overrides)
        row = {"case": label, **run_one(comm, scene, second_start=label.startswith("F="))}
        rows.append(row)
        if comm.rank == 0:
            print(row, flush=True)
    write_table(Path(args.out), "extremes", f"Extremes around case {args.case}, lev {args.lev} (default settings "
                "unless named; worst_residual = largest relative physics-check residual)", rows, comm)
    return 0


if __name__ == "__main__":
    sys.exit(main())
