"""The linear-elastic reference: one solve of A ũ = l̃ on the mesh of a case, assembly included.

CG + GAMG with the rigid-body near-nullspace, relative residual 1e-8 (options prefix ``elastic_``), on the
same model (mesh, Dirichlet rows, load) as the contact solve. Importable (``linear_elastic``, used in
process by ratio.py) and a command that reports the same phases as the contact CLI's summary.json
(mesh, assembly, setup, solve, output: the displacement written to solution.xdmf), run by scale.py under
``mpirun`` exactly like ``python3 -m fenics_coulomb``:

    container/run mpirun -n 2 python3 benchmarks/elastic.py --lev 8 --case d3/L2 --out out/elastic

Exit status 0 when CG converged, 3 otherwise.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import dolfinx.io

from fenics_coulomb.scenes.builder import build_body, clamp, isotropic_forms
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.io.xdmf_read import displacement_function
from fenics_coulomb.io.summary import software_versions
from fenics_coulomb.model.nullspace import rigid_body_modes

PREFIX = "elastic_"
RTOL = 1e-8


@dataclass
class ElasticSolve:
    """Result of one linear-elastic solve.

    Attributes:
        n: Unknowns after the Dirichlet DOFs (the contact model's n).
        iterations: CG iterations.
        converged: Whether CG reached the tolerance.
        timings: Wall time per phase (max over ranks): mesh, assembly, setup (near-nullspace and the GAMG
            hierarchy), solve, output, and ``total`` (their sum).
    """

    n: int
    iterations: int
    converged: bool
    timings: dict[str, float] = field(default_factory=dict)


def linear_elastic(comm: MPI.Comm, lev: int, gap: str, load: str, out: Path | None = None) -> ElasticSolve:
    """Assemble and solve A ũ = l̃ with CG + GAMG (rtol 1e-8); write ũ to ``out/solution.xdmf`` if given."""
    comm.barrier()
    clock = [time.perf_counter()]

    def lap() -> float:
        clock.append(time.perf_counter())
        return clock[-1] - clock[-2]

    local: dict[str, float] = {}
    scene = Scene().override(lev=lev, gap=gap, load=load)
    body = build_body(scene, comm)
    local["mesh"] = lap()
    V = dolfinx.fem.functionspace(body.mesh, ("Lagrange", 1, (3,)))
    tractions = {body.tag(name): value for name, value in scene.traction_table().items()}
    a, L = isotropic_forms(V, scene.material.material(), body.facet_tags, tractions)
    model = ContactModel(a, L, [clamp(V, body)], (body.facet_tags, [body.tag(name) for name in body.contact]),
                         scene.friction.coefficient, prefix=PREFIX)
    local["assembly"] = lap()
    ns = rigid_body_modes(model.V)
    model.A.setNearNullSpace(ns)
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix(PREFIX)
    ksp.setOperators(model.A)
    ksp.setType("cg")
    ksp.getPC().setType("gamg")
    ksp.setTolerances(rtol=RTOL)
    ksp.setFromOptions()
    ksp.setUp()
    local["setup"] = lap()
    x = model.A.createVecRight()
    ksp.solve(model.load, x)
    local["solve"] = lap()
    if out is not None:
        u = displacement_function(model.V, x.getArray(readonly=True))
        with dolfinx.io.XDMFFile(comm, str(out / "solution.xdmf"), "w") as xdmf:
            xdmf.write_mesh(model.V.mesh)
            xdmf.write_function(u, 0.0)
    local["output"] = lap()
    timings = {key: comm.allreduce(value, op=MPI.MAX) for key, value in local.items()}
    timings["total"] = sum(timings.values())
    result = ElasticSolve(n=model.n, iterations=ksp.getIterationNumber(), converged=ksp.getConvergedReason() > 0,
                          timings=timings)
    for obj in (ksp, x, ns):
        obj.destroy()
    model.destroy()
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lev", type=int, required=True)
    parser.add_argument("--case", default="d3/L2", help="gap/load, e.g. d3/L2")
    parser.add_argument("--out", default="out/elastic")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    gap, load = args.case.split("/")
    out = Path(args.out)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    result = linear_elastic(comm, args.lev, gap, load, out)
    if comm.rank == 0:
        data = {"n": result.n, "converged": result.converged, "krylov_iterations": result.iterations,
                "newton_iterations": 0, "solver": f"cg + gamg (rigid-body near-nullspace), rtol {RTOL:g}",
                "timings_s": result.timings, "ranks": comm.size, "versions": software_versions()}
        (out / "summary.json").write_text(json.dumps(data, indent=2) + "\n")
        print(f"linear elastic, lev {args.lev}: n = {result.n}, {result.iterations} CG iterations, "
              f"{result.timings['total']:.2f} s", flush=True)
    return 0 if result.converged else 3


if __name__ == "__main__":
    sys.exit(main())
