"""An assembly of the support reactions of our own, for the reaction tests: K and l assembled by DOLFINx without
boundary conditions (a PETSc matrix, not the library's UFL action), r = K u − l, and per support the sum of r
(minus the contact forces acting there, when given) over the DOFs the support holds, component by component."""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl


def held_dofs(V: dolfinx.fem.FunctionSpace, blocks: np.ndarray, components=(0, 1, 2)) -> np.ndarray:
    """Unrolled local DOFs of the given components of the node blocks."""
    blocks = np.asarray(blocks, dtype=np.int64)
    return (3 * blocks[:, None] + np.asarray(components, dtype=np.int64)[None, :]).ravel()


def bc_dofs(bcs) -> np.ndarray:
    """Unrolled local DOFs (owned and ghost) that a list of DirichletBCs holds (on V or on V.sub(i))."""
    return np.unique(np.concatenate([np.asarray(bc.dof_indices()[0], dtype=np.int64) for bc in bcs]))


def bc_blocks(bcs) -> np.ndarray:
    """The local node blocks (owned and ghost) a list of DirichletBCs holds in some component."""
    return np.unique(bc_dofs(bcs) // 3)


def assembled_reactions(a: ufl.Form, L: ufl.Form | None, u: np.ndarray, supports: dict[str, np.ndarray],
                        comm: MPI.Comm, minus: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """name → Σ over the support's owned DOFs of (K u − l − minus) per component (collective).

    Args:
        a, L: The bilinear and linear forms (L None: no load).
        u: The physical displacement on the owned DOFs.
        supports: name → unrolled local DOFs (owned and ghost) the support holds.
        minus: Forces other than the supports' acting on the owned DOFs (contact forces), shape (owned nodes, 3).
    """
    K = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(a))
    K.assemble()
    x, r = K.createVecs()
    x.array[:] = u
    K.mult(x, r)
    if L is not None:
        b = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(L))
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        r.axpy(-1.0, b)
        b.destroy()
    values = r.getArray(readonly=True).copy()
    if minus is not None:
        values -= np.asarray(minus, dtype=np.float64).ravel()
    out = {}
    for name, dofs in supports.items():
        owned = np.unique(dofs[dofs < values.size])
        local = np.bincount(owned % 3, weights=values[owned], minlength=3)
        out[name] = np.asarray(comm.allreduce(local, op=MPI.SUM))
    for obj in (K, x, r):
        obj.destroy()
    return out
