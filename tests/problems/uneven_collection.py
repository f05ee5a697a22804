"""Two problems on one mesh, the first one's results freed by the cyclic garbage collector on rank 0 only.

Run as ``mpirun -n 2 python3 tests/problems/uneven_collection.py OUTDIR`` by
tests/problems/test_collective_lifetimes.py: a PETSc object that one rank destroys earlier than the others
(a Function's cached PETSc vector, freed by the collector) must not change what the next collective creation
on the mesh's communicator does, or the ranks deadlock.
"""

from __future__ import annotations

import gc
import sys

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from fenics_coulomb import ContactProblem, Sphere, write_results


def press(V: dolfinx.fem.FunctionSpace, depth: float, outdir: str | None) -> tuple[object, object]:
    """A ball pressed ``depth`` into the block of the space ``V``; the displacement and the report (results
    written to ``outdir``)."""
    msh = V.mesh
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(top).astype(np.int32), np.full(top.size, 1, np.int32))
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, bottom), V)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    a = ufl.inner(2 * 26.9 * eps(u) + 40.4 * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx
    ball = Sphere(center=[0.5, 0.5, 1.0], radius=0.5, displacement=[0, 0, -depth], name="ball")
    with ContactProblem(a, None, bcs=[clamp], contact=(tags, [1]), friction=0.3, obstacles=[ball],
                        petsc_options_prefix="uneven_") as problem:
        uh, result = problem.solve()
        report = problem.report(result, reactions={"bottom": clamp})
        if outdir is not None:
            write_results(outdir, problem, result, reactions={"bottom": clamp})
    return uh, report


def main() -> None:
    comm = MPI.COMM_WORLD
    gc.disable()  # the collector runs where this script says, not where allocations happen to trigger it
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], [1, 1, 0.5]], [6, 6, 3], dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))  # one space: its vectors share a communicator
    first = list(press(V, 0.01, sys.argv[1]))
    first.append(first)  # a reference cycle: only the cyclic collector frees the first solve's results
    del first
    if comm.rank == 0:
        gc.collect()
    _, report = press(V, 0.02, None)
    gc.enable()
    gc.collect()
    force = report.obstacle_forces["ball"][2]  # type: ignore[attr-defined]
    if comm.rank == 0:
        print(f"second solve: ball force {force:.6e}", flush=True)


if __name__ == "__main__":
    main()
