"""Parallel sums on three ranks: the stiffness matrix, a triple product and a contact solve, each repeated.

Run as ``mpirun -n 3 python3 tests/problems/fixed_order_sums.py`` by tests/problems/test_fixed_order_sums.py. The
mesh is a tetrahedral box [0, 2]×[0, 2]×[0.01, 0.51] cut by the deterministic partition into one part and two
that meet it along a line (vertices shared by three ranks), where PETSc's own assembly and default triple
product sum an entry's off-process contributions in the order the messages arrive; the pairs' triple
product (:class:`~fenics_coulomb.model.reproducible.TripleProduct`) is formed new and in place in every
repeat. Prints one line per quantity: ``<name> <distinct digests over the repeats> <repeats>``, and for the
matrix its largest relative difference from PETSc's own assembly.
"""

from __future__ import annotations

import hashlib

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl

from fenics_coulomb import ContactProblem, box_partitioner
from fenics_coulomb.model.reproducible import TripleProduct, assemble_matrix

REPEATS = 6
POINTS, CELLS = [[0.0, 0.0, 0.01], [2.0, 2.0, 0.51]], [16, 16, 4]


def digest(comm: MPI.Comm, values: np.ndarray) -> str:
    """One digest of every rank's array (rank order)."""
    parts = comm.gather(np.ascontiguousarray(values).tobytes(), root=0)
    text = hashlib.sha256(b"".join(parts)).hexdigest() if comm.rank == 0 else ""
    return str(comm.bcast(text, root=0))


def main() -> None:
    comm = MPI.COMM_WORLD
    assert comm.size == 3, "run on 3 ranks"
    msh = dolfinx.mesh.create_box(comm, POINTS, CELLS, dolfinx.mesh.CellType.tetrahedron,
                                  ghost_mode=dolfinx.mesh.GhostMode.shared_facet,
                                  partitioner=box_partitioner(POINTS, CELLS))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    x = ufl.SpatialCoordinate(msh)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    mu, lmbda = 26.2 * (1.0 + 0.3 * x[0] * x[1]), 52.0  # a varying modulus: no two cell matrices alike
    a_ufl = ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx
    a = dolfinx.fem.form(a_ufl)
    left = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda y: np.isclose(y[0], 0.0))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, left), V)

    ours, theirs, products, default_products = [], [], [], []
    worst = 0.0
    for _ in range(REPEATS):
        A = assemble_matrix(a, bcs=[bc])
        B = dolfinx.fem.petsc.assemble_matrix(a, bcs=[bc])
        B.assemble()
        ia, ja, va = A.getValuesCSR()
        ib, jb, vb = B.getValuesCSR()
        assert np.array_equal(ia, ib) and np.array_equal(ja, jb), "the sparsity differs from PETSc's assembly"
        worst = max(worst, float(np.max(np.abs(va - vb))) / float(np.max(np.abs(vb))))
        ours.append(digest(comm, va))
        theirs.append(digest(comm, vb))
        product = TripleProduct()
        C = product(A, A)  # Aᵀ A A: a P with off-process rows on every rank
        products.append(digest(comm, C.getValuesCSR()[2]))
        product(A, A, result=C)  # the numeric phases again, in place
        products.append(digest(comm, C.getValuesCSR()[2]))
        product.destroy()
        D = A.ptap(A)
        default_products.append(digest(comm, D.getValuesCSR()[2]))
        for M in (A, B, C, D):
            M.destroy()
    worst = comm.allreduce(worst, op=MPI.MAX)
    bc_worst = constrained_rows()

    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda y: np.isclose(y[2], 0.51))
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda y: np.isclose(y[2], 0.01))
    facets = np.concatenate([bottom, top]).astype(np.int32)
    markers = np.concatenate([np.full(bottom.size, 1), np.full(top.size, 2)]).astype(np.int32)
    order = np.argsort(facets)
    tags = dolfinx.mesh.meshtags(msh, 2, facets[order], markers[order])
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    L = ufl.inner(dolfinx.fem.Constant(msh, np.array([0.1, 0.0, -1.0])), v) * ds(2)
    solutions = []
    for k in range(2):
        with ContactProblem(a_ufl, L, bcs=[bc], contact=(tags, [1]), friction=0.23,
                            settings={"pc": "gamg", "rtol": 1e-10},
                            petsc_options_prefix=f"fixed_order_{k}_") as problem:
            uh, result = problem.solve()
            assert result.converged
            solutions.append(digest(comm, uh.x.array[: 3 * V.dofmap.index_map.size_local]))
    if comm.rank == 0:
        print(f"matrix {len(set(ours))} {REPEATS} worst {worst:.3e}")
        print(f"petsc-matrix {len(set(theirs))} {REPEATS}")
        print(f"ptap {len(set(products))} {len(products)}")
        print(f"petsc-ptap {len(set(default_products))} {REPEATS}")
        print(f"solve {len(set(solutions))} 2")
        print(f"bc-matrix {bc_worst:.3e}")


def constrained_rows() -> float:
    """Dirichlet rows of a whole and of a component (V.sub) condition, ghosted cells, the default partition
    (ghost DOFs of constrained rows) and a diagonal of 2.5: the largest relative difference from PETSc's
    assembly (the same sparsity, block size and constrained diagonal asserted). dolfinx's own CSR
    insert_diagonal failed here with "Entry not in sparsity"."""
    comm = MPI.COMM_WORLD
    msh = dolfinx.mesh.create_box(comm, [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], [4, 4, 4],
                                  dolfinx.mesh.CellType.hexahedron, ghost_mode=dolfinx.mesh.GhostMode.shared_facet)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = dolfinx.fem.form(ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx)
    left = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda y: np.isclose(y[0], 0.0) & (y[1] < 0.3))
    whole = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, left), V)
    V2, _ = V.sub(2).collapse()
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda y: np.isclose(y[2], 0.0))
    component = dolfinx.fem.dirichletbc(dolfinx.fem.Function(V2),
                                        dolfinx.fem.locate_dofs_topological((V.sub(2), V2), 2, bottom), V.sub(2))
    A = assemble_matrix(a, bcs=[whole, component], diagonal=2.5)
    B = dolfinx.fem.petsc.assemble_matrix(a, bcs=[whole, component], diagonal=2.5)
    B.assemble()
    ia, ja, va = A.getValuesCSR()
    ib, jb, vb = B.getValuesCSR()
    same = (np.array_equal(ia, ib) and np.array_equal(ja, jb) and A.getBlockSize() == B.getBlockSize()
            and np.array_equal(A.getDiagonal().array == 2.5, B.getDiagonal().array == 2.5))
    assert comm.allreduce(same, op=MPI.LAND), "sparsity, block size or diagonal differ from PETSc's assembly"
    assert comm.allreduce(int(np.sum(B.getDiagonal().array == 2.5)), op=MPI.SUM) > 0
    worst = comm.allreduce(float(np.max(np.abs(va - vb), initial=0.0)), op=MPI.MAX) / B.norm()
    A.destroy()
    B.destroy()
    return worst


if __name__ == "__main__":
    main()
