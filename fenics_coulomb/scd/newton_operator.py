r"""The Newton matrix as an operator: explicit (a copy of A with its contact rows overwritten) or matrix-free.

The Newton matrix of both variants is A with the rows of every contact node i replaced by Bⁱ Aⁱ + Cⁱ
(Bⁱ, Cⁱ ∈ R^{3×3}, Aⁱ the node's three rows of A, Cⁱ acting on the node's own three columns), i.e.

    M x = D (A x) + C x,      Mᵀ y = Aᵀ (Dᵀ y) + Cᵀ y,

with block-diagonal D (Bⁱ on the contact nodes, I elsewhere) and C (Cⁱ on the contact nodes, 0 elsewhere).
GMRES needs only products with M (and Mᵀ for variant 4b), so when the preconditioner is built on A (GAMG
with the reused hierarchy) M is applied as a PETSc shell from A and the blocks: no second copy of A is
stored. Preconditioners that factor or read M itself (ILU, LU, Jacobi, hypre) get the explicit
copy, updated in place by :class:`~fenics_coulomb.scd.contact_rows.ContactRows`.

Both forms take the SAME blocks (Bⁱ, Cⁱ) — the ones :meth:`NewtonStep.rows` returns — so whatever those
blocks contain (e.g. per-node frames of the obstacle) applies to either.
"""

from __future__ import annotations

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

from fenics_coulomb.scd.contact_rows import ContactRows

__all__ = ["MATRIX_FREE_PCS", "ShellContext", "NewtonOperator"]

Array = npt.NDArray[np.float64]

#: Preconditioners that never read the Newton matrix's entries (built on A, or none): M can be a shell.
MATRIX_FREE_PCS = ("gamg", "none")


class ShellContext:
    """The petsc4py ``python`` context of the matrix-free Newton matrix M x = D(A x) + C x.

    Args:
        A: The stiffness matrix (not owned).
        cdofs: Local (owned) DOFs of the contact nodes, shape (m, 3).
    """

    def __init__(self, A: PETSc.Mat, cdofs: npt.NDArray[np.int32]) -> None:
        self.A = A
        self.cdofs = np.asarray(cdofs)
        m = self.cdofs.shape[0]
        self.left: Array = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
        self.right: Array = np.zeros((m, 3, 3))
        self._work = A.createVecLeft()

    def set_blocks(self, left: Array, right: Array) -> None:
        """Take the blocks (Bⁱ, Cⁱ) of the new contact rows (copied)."""
        self.left[...] = left
        self.right[...] = right

    def set_identity(self) -> None:
        """M = A (Bⁱ = I, Cⁱ = 0)."""
        self.left[...] = np.eye(3)
        self.right[...] = 0.0

    def mult(self, mat: PETSc.Mat, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = D(A x) + C x."""
        self.A.mult(x, y)
        cd = self.cdofs
        xa = x.getArray(readonly=True)
        ya = y.getArray()
        ya[cd] = np.einsum("iab,ib->ia", self.left, ya[cd]) + np.einsum("iab,ib->ia", self.right, xa[cd])

    def multTranspose(self, mat: PETSc.Mat, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = Aᵀ(Dᵀ x) + Cᵀ x."""
        cd = self.cdofs
        xa = x.getArray(readonly=True)
        w = self._work
        wa = w.getArray()
        wa[:] = xa
        wa[cd] = np.einsum("iba,ib->ia", self.left, xa[cd])
        self.A.multTranspose(w, y)
        ya = y.getArray()
        ya[cd] += np.einsum("iba,ib->ia", self.right, xa[cd])

    def destroy(self, mat: PETSc.Mat | None = None) -> None:
        """Destroy the work vector (petsc4py calls this when the shell itself is destroyed)."""
        self._work.destroy()


class NewtonOperator:
    """Owns the Newton matrix ``M`` (explicit copy of A or a shell) and updates it from the blocks (Bⁱ, Cⁱ).

    Created once per solver; :meth:`update` changes M in place every Newton step. Call :meth:`destroy`.

    Args:
        A: The stiffness matrix (not owned).
        rows: The contact rows of A (for the explicit form).
        cdofs: Local DOFs of the contact nodes, shape (m, 3).
        matrix_free: Apply M as a shell instead of storing it.
        prefix: Options prefix of M.
    """

    def __init__(self, A: PETSc.Mat, rows: ContactRows, cdofs: npt.NDArray[np.int32], matrix_free: bool,
                 prefix: str) -> None:
        self.A = A
        self.rows = rows
        self.matrix_free = matrix_free
        self._context: ShellContext | None = None
        if matrix_free:
            self._context = ShellContext(A, cdofs)
            self.M = PETSc.Mat().createPython(A.getSizes(), self._context, comm=A.getComm())
            self.M.setBlockSize(A.getBlockSize())
            self.M.setOptionsPrefix(prefix)
            self.M.setUp()
        else:
            self.M = A.duplicate(copy=True)
            self.M.setOptionsPrefix(prefix)

    def update(self, left: Array, right: Array) -> None:
        """Make M the Newton matrix with contact rows Bⁱ Aⁱ + Cⁱ (collective)."""
        if self._context is not None:
            self._context.set_blocks(left, right)
            self.M.assemble()  # bumps the state: the KSP sees a changed operator
        else:
            self.rows.update(self.M, left, right)

    def set_stiffness(self) -> None:
        """Make M equal to A (collective)."""
        if self._context is not None:
            self._context.set_identity()
            self.M.assemble()
        else:
            self.A.copy(self.M, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)

    def rebind(self, A: PETSc.Mat, rows: ContactRows, cdofs: npt.NDArray[np.int32]) -> None:
        """Take another stiffness of the same layout and other contact nodes (a geometry update of finite sliding;
        collective): the shell keeps its Mat and work vector and reads the new A, M = A until the next
        :meth:`update`; the explicit copy becomes a copy of the new A (a new Mat under the same prefix: the KSP that
        reads it is created anew as well)."""
        self.A, self.rows = A, rows
        if self._context is not None:
            context = self._context
            context.A = A
            context.cdofs = np.asarray(cdofs)
            m = context.cdofs.shape[0]
            context.left = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
            context.right = np.zeros((m, 3, 3))
            self.M.assemble()  # bumps the state: the KSP sees a changed operator
            return
        prefix = self.M.getOptionsPrefix()
        self.M.destroy()
        self.M = A.duplicate(copy=True)
        self.M.setOptionsPrefix(prefix)

    def destroy(self) -> None:
        """Destroy M (a shell frees its context's work vector when its last reference goes)."""
        self.M.destroy()
