"""Cost of the contact solve relative to one linear-elastic solve of the same mesh on the same ranks.

Both include assembly. The linear-elastic reference is CG + GAMG with the rigid-body near-nullspace to
rtol 1e-8; the contact solve is the SCD semismooth* Newton method with the chosen preconditioner.

    container/run mpirun -n 2 python3 benchmarks/ratio.py --levels 6 8 --pc gamg --out docs/ratio
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem.petsc
from common import build, peak_rss_mib, solve, write_table

from fenics_coulomb.builder import build_body, clamp, isotropic_forms
from fenics_coulomb.config import Scene
from fenics_coulomb.preconditioner import rigid_body_modes
from fenics_coulomb.settings import SolverSettings


def linear_elastic(comm: MPI.Comm, lev: int, gap: str, load: str) -> tuple[float, int]:
    """Assemble and solve the same linear-elastic problem without contact with DOLFINx's LinearProblem, CG +
    GAMG with the rigid-body near-nullspace (rtol 1e-8); return (wall time, CG iterations)."""
    comm.barrier()
    t0 = time.perf_counter()
    scene = Scene().override(lev=lev, gap=gap, load=load)
    body = build_body(scene, comm)
    V = dolfinx.fem.functionspace(body.mesh, ("Lagrange", 1, (3,)))
    tractions = {body.tag(name): value for name, value in scene.traction_table().items()}
    a, L = isotropic_forms(V, scene.material.material(), body.facet_tags, tractions)
    problem = dolfinx.fem.petsc.LinearProblem(a, L, bcs=[clamp(V, body)], petsc_options={
        "ksp_type": "cg", "pc_type": "gamg", "ksp_rtol": 1e-8})
    ns = rigid_body_modes(V)
    problem.A.setNearNullSpace(ns)
    problem.solve()
    its = problem.solver.getIterationNumber()
    elapsed = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    ns.destroy()
    return elapsed, its


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
        t_lin, its_lin = linear_elastic(comm, lev, gap, load)
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
