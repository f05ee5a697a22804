"""The rigid-body modes of a vector P1 space: the near-nullspace GAMG needs for elasticity."""

from __future__ import annotations

from petsc4py import PETSc

import dolfinx
import dolfinx.la
import numpy as np

__all__ = ["rigid_body_modes"]


def rigid_body_modes(V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
    """The six rigid-body modes of V as an orthonormal PETSc near-nullspace (for GAMG).

    They depend on the space only (the kernel of any elastic operator without supports).
    """
    imap = V.dofmap.index_map
    bs = V.dofmap.index_map_bs
    length = imap.size_local * bs
    basis = [dolfinx.la.vector(imap, bs=bs, dtype=PETSc.ScalarType) for _ in range(6)]
    b = [np.asarray(v.array) for v in basis]
    dofs = [V.sub(i).dofmap.list.flatten() for i in range(3)]
    for i in range(3):
        b[i][dofs[i]] = 1.0
    x = V.tabulate_dof_coordinates()
    dofs_block = V.dofmap.list.flatten()
    x0, x1, x2 = x[dofs_block, 0], x[dofs_block, 1], x[dofs_block, 2]
    b[3][dofs[0]] = -x1
    b[3][dofs[1]] = x0
    b[4][dofs[0]] = x2
    b[4][dofs[2]] = -x0
    b[5][dofs[2]] = x1
    b[5][dofs[1]] = -x2
    dolfinx.la.orthonormalize(basis)
    vecs = [PETSc.Vec().createWithArray(v[:length], bsize=bs, comm=V.mesh.comm) for v in b]
    return PETSc.NullSpace().create(vectors=vecs, comm=V.mesh.comm)

