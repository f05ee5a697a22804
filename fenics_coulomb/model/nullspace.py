"""The rigid-body modes of a vector P1 space: the near-nullspace GAMG needs for elasticity, the rigid motions a
body's supports leave free, and the shift that lets GAMG factorize the stiffness of a body held by contact alone."""

from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.la
import numpy as np
import numpy.typing as npt

__all__ = ["HELD_BODY_SHIFT", "FreeMotions", "free_rigid_motions", "held_by_stiffness", "mean_free_diagonal",
           "rigid_body_modes", "rigid_modes_at", "shift_diagonal"]

Array = npt.NDArray[np.float64]

#: The relative raise of the diagonal of the matrix GAMG is built on, on a body held by contact alone (its
#: stiffness is singular: the Newton matrix holds its free rigid motions through the contact rows, which the
#: stiffness does not have). Two bodies (docs/verification/incline_two_bodies.toml with --pc gamg): 0 and 1e-10
#: break down (DIVERGED_BREAKDOWN in GAMG's coarsest LU, in Newton steps 5 and 17), 1e-8 and 1e-6 converge in 9
#: Newton / 77 Krylov iterations. One body (docs/verification/incline.toml with --pc gamg): 0 breaks down in
#: Newton step 10, 1e-6 converges (tests/problems/test_verification.py). Well below the smallest eigenvalue of an
#: elastic body's stiffness relative to its diagonal, O((h/L)²), on any mesh up to a thousand cells across; a
#: supported body is never shifted.
HELD_BODY_SHIFT = 1e-6


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



def rigid_modes_at(x: Array) -> Array:
    """The six rigid modes at points x (m, 3) as an array (m, 3, 6): translations, then rotations about e1..e3
    (the order of :func:`rigid_body_modes`' rotations is irrelevant here)."""
    m = x.shape[0]
    r = np.zeros((m, 3, 6))
    r[:, 0, 0] = r[:, 1, 1] = r[:, 2, 2] = 1.0
    r[:, 1, 3], r[:, 2, 3] = -x[:, 2], x[:, 1]    # rotation about e1: (0, −x3, x2)
    r[:, 0, 4], r[:, 2, 4] = x[:, 2], -x[:, 0]    # about e2: (x3, 0, −x1)
    r[:, 0, 5], r[:, 1, 5] = -x[:, 1], x[:, 0]    # about e3: (−x2, x1, 0)
    return r


@dataclass(frozen=True)
class FreeMotions:
    """The rigid motions the supports of each body leave free (:func:`free_rigid_motions`).

    Attributes:
        centroid: Each body's centroid in the reference configuration, shape (bodies, 3).
        extent: Each body's largest distance of a node from its centroid, shape (bodies,).
        eigenvectors: The eigenvectors of each body's support Gram matrix (columns, mode coefficients of
            :func:`rigid_modes_at` at (x − centroid) / extent), shape (bodies, 6, 6).
        free: Which of them the supports leave free, shape (bodies, 6).
    """

    centroid: Array
    extent: Array
    eigenvectors: Array
    free: npt.NDArray[np.bool_]

    @property
    def supported(self) -> npt.NDArray[np.bool_]:
        """Whether each body's supports hold all its rigid motions, shape (bodies,)."""
        return np.asarray(~self.free.any(axis=1))


def free_rigid_motions(V: dolfinx.fem.FunctionSpace, body: npt.NDArray[np.int64], num_bodies: int,
                       dirichlet: npt.NDArray[np.int32]) -> FreeMotions:
    """The rigid motions the prescribed DOFs ``dirichlet`` (owned, unrolled local indices) leave free, per body
    (``body``: the body of every local DOF block; collective, the same on every rank).

    The rigid modes r of body b restricted to its prescribed DOFs give the Gram matrix G = Σ r_Dᵀ r_D (summed over
    ranks; coordinates relative to the body's centroid, scaled by its size); its null space (eigenvalues ≤ 1e-10 ×
    its trace) are the motions the supports leave free.
    """
    comm = V.mesh.comm
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    owned_body = body[:n]
    sums = np.zeros((num_bodies, 4))
    np.add.at(sums, owned_body, np.column_stack([x, np.ones(n)]))
    comm.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
    centroid = sums[:, :3] / np.maximum(sums[:, 3:], 1.0)
    extent: Array = np.zeros(num_bodies)
    np.maximum.at(extent, owned_body, np.linalg.norm(x - centroid[owned_body], axis=1))
    comm.Allreduce(MPI.IN_PLACE, extent, op=MPI.MAX)
    extent = np.maximum(extent, np.finfo(float).tiny)
    dirichlet = np.asarray(dirichlet)
    blocks, comps = dirichlet // 3, dirichlet % 3
    blocks, comps = blocks[blocks < n], comps[blocks < n]
    b = owned_body[blocks]
    rows = rigid_modes_at((x[blocks] - centroid[b]) / extent[b, None])[np.arange(blocks.size), comps]  # (k, 6)
    gram = np.zeros((num_bodies, 6, 6))
    np.add.at(gram, b, np.einsum("ka,kb->kab", rows, rows))
    comm.Allreduce(MPI.IN_PLACE, gram, op=MPI.SUM)
    eigenvalues, eigenvectors = np.linalg.eigh(gram)
    floor = 1e-10 * np.maximum(np.trace(gram, axis1=1, axis2=2), 1.0)
    return FreeMotions(centroid, extent, eigenvectors, eigenvalues <= floor[:, None])


def shift_diagonal(A: PETSc.Mat, rows: npt.NDArray[np.bool_], shift: float = HELD_BODY_SHIFT) -> None:
    """Raise A's diagonal by ``shift`` of itself on the owned unrolled ``rows`` (a mask of the local rows; in place,
    collective)."""
    diagonal = A.getDiagonal()
    diagonal.array[rows] *= 1.0 + shift
    A.setDiagonal(diagonal, addv=PETSc.InsertMode.INSERT_VALUES)
    diagonal.destroy()


def mean_free_diagonal(A: PETSc.Mat, rows: npt.NDArray[np.int32], comm: MPI.Comm,
                       body: npt.NDArray[np.int64] | None = None, num_bodies: int = 1) -> Array:
    """The mean diagonal of A over all rows but the owned unrolled ``rows`` (the prescribed ones), per body
    (``body``: the body of every local DOF block; None: one), shape (num_bodies,) (collective)."""
    diagonal = A.getDiagonal()
    values = diagonal.array.copy()
    diagonal.destroy()
    free = np.ones(values.size, dtype=bool)
    free[rows] = False
    owner = np.zeros(values.size, dtype=np.int64) if body is None else np.repeat(np.asarray(body[:values.size // 3]), 3)
    sums = np.zeros((num_bodies, 2))
    np.add.at(sums, owner[free], np.column_stack([values[free], np.ones(int(free.sum()))]))
    comm.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
    return np.asarray(sums[:, 0] / np.maximum(sums[:, 1], 1.0))


def held_by_stiffness(A: PETSc.Mat, V: dolfinx.fem.FunctionSpace, motions: FreeMotions,
                      diagonal: float | Array, body: npt.NDArray[np.int64] | None = None) -> FreeMotions:
    """``motions`` less those the stiffness holds: springs in the bilinear form (``k·inner(u, v)·ds``) hold rigid
    motions that no Dirichlet condition does. Within the free motions R of a body the Gram matrix Rᵀ A R (the
    motions' elastic energy) has the truly free motions as its null space (eigenvalues ≤ 1e-10 × the body's mean
    free diagonal ``diagonal`` (per body, :func:`mean_free_diagonal`) × its number of DOFs: rigid motions cost
    round-off, a spring below that holds nothing a solve could resolve); ``body``: the body of every local DOF block
    (None: one body); collective."""
    num_bodies = motions.free.shape[0]
    diagonals = np.broadcast_to(np.asarray(diagonal, dtype=np.float64), (num_bodies,))
    n = V.dofmap.index_map.size_local
    owned_body = np.zeros(n, dtype=np.int64) if body is None else np.asarray(body[:n])
    x = V.tabulate_dof_coordinates()[:n]
    eigenvectors, still = motions.eigenvectors.copy(), motions.free.copy()
    for b in range(num_bodies):  # the bodies (a few), each with at most six motions
        free = np.flatnonzero(motions.free[b])
        if free.size == 0:
            continue
        mine = owned_body == b
        modes = np.zeros((n, 3, free.size))
        modes[mine] = np.einsum("nia,ak->nik", rigid_modes_at((x[mine] - motions.centroid[b]) / motions.extent[b]),
                                motions.eigenvectors[b][:, free])
        r, Ar = A.createVecRight(), A.createVecLeft()
        products = np.zeros((free.size, free.size))
        try:
            for k in range(free.size):
                r.array[:] = modes[:, :, k].ravel()
                A.mult(r, Ar)
                products[:, k] = np.einsum("nik,ni->k", modes, Ar.array.reshape(-1, 3))
        finally:
            r.destroy()
            Ar.destroy()
        V.mesh.comm.Allreduce(MPI.IN_PLACE, products, op=MPI.SUM)
        size = V.mesh.comm.allreduce(3 * int(np.sum(mine)), op=MPI.SUM)
        values, vectors = np.linalg.eigh(0.5 * (products + products.T))
        held = values > 1e-10 * max(float(diagonals[b]), np.finfo(float).tiny) * size
        if held.any():  # else unchanged, bit for bit (a rotation of round-off would depend on the ranks)
            eigenvectors[b][:, free] = motions.eigenvectors[b][:, free] @ vectors
            still[b, free] = ~held
    if np.array_equal(still, motions.free):
        return motions
    return FreeMotions(motions.centroid, motions.extent, eigenvectors, still)
