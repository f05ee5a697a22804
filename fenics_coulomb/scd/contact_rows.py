"""In-place updates of the Newton matrix's contact rows (the only rows where it differs from A)."""

from __future__ import annotations

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

__all__ = ["ContactRows"]

Array = npt.NDArray[np.float64]


class ContactRows:
    """Contact rows of A as per-node 3-row blocks, for in-place updates of the Newton matrix.

    The three rows of a node share one column pattern (DOLFINx assembles blocked, bs = 3), so the new
    rows Bⁱ Aⁱ + Cⁱ (Bⁱ, Cⁱ ∈ R^{3×3}, Aⁱ the node's 3 rows, Cⁱ acting on the node's own columns) are a
    batched 3×3 product over the stored entries, computed with NumPy without a loop over nodes.
    """

    def __init__(self, A: PETSc.Mat, global_dofs: npt.NDArray[np.int64]) -> None:
        comm = A.getComm()
        rows = np.ascontiguousarray(global_dofs.ravel(), dtype=PETSc.IntType)
        self.rows = rows
        c0, c1 = A.getOwnershipRangeColumn()
        isrow = PETSc.IS().createGeneral(rows, comm=comm)
        iscol = PETSc.IS().createStride(c1 - c0, first=c0, step=1, comm=comm)
        sub = A.createSubMatrix(isrow, iscol)
        indptr, indices, data = sub.getValuesCSR()
        sub.destroy()
        isrow.destroy()
        iscol.destroy()
        self.indptr = np.asarray(indptr, dtype=PETSc.IntType)
        self.indices = np.asarray(indices, dtype=PETSc.IntType)
        m = global_dofs.shape[0]
        self.num_nodes = m
        lengths = np.diff(self.indptr).reshape(m, 3) if m else np.zeros((0, 3), dtype=PETSc.IntType)
        if not np.all(lengths == lengths[:, :1]):
            raise RuntimeError("contact rows of a node do not share their sparsity pattern")
        nnz = lengths[:, 0].astype(np.int64)
        self.node_of_entry = np.repeat(np.arange(m), nnz)
        first = np.cumsum(nnz) - nnz
        position = np.arange(int(nnz.sum())) - np.repeat(first, nnz)
        starts = self.indptr[:-1].reshape(m, 3) if m else np.zeros((0, 3), dtype=PETSc.IntType)
        # positions of row b of each node's block in the CSR arrays: shape (3, entries)
        self.positions = np.stack([np.repeat(starts[:, b], nnz) + position for b in range(3)])
        cols = self.indices[self.positions]
        if not np.all(cols == cols[:1]):
            raise RuntimeError("contact rows of a node do not share their column order")
        self.values = np.ascontiguousarray(np.asarray(data)[self.positions])  # (3, entries)
        # where each node's own three columns sit among its entries
        own = cols[0] // 3 == global_dofs[self.node_of_entry, 0] // 3
        entry = np.flatnonzero(own)
        comp = cols[0][entry] % 3
        diag = np.full((m, 3), -1, dtype=np.int64)
        diag[self.node_of_entry[entry], comp] = entry
        if np.any(diag < 0):
            raise RuntimeError("a contact row misses its diagonal block")
        self.diagonal_entries = diag.ravel()
        self._out = np.empty(len(self.indices), dtype=PETSc.ScalarType)

    def diagonal(self) -> Array:
        """A's diagonal entries of the contact rows, shape (m, 3) (row b of node i: A[(i, b), (i, b)])."""
        entries = self.diagonal_entries.reshape(self.num_nodes, 3)
        return np.take_along_axis(self.values.T, entries, axis=0) if self.num_nodes else np.zeros((0, 3))

    def diagonal_blocks(self) -> Array:
        """A's 3×3 diagonal blocks of the contact nodes, shape (m, 3, 3): [i, b, c] = A[(i, b), (i, c)]."""
        if not self.num_nodes:
            return np.zeros((0, 3, 3))
        entries = self.diagonal_entries.reshape(self.num_nodes, 3)
        return np.ascontiguousarray(np.moveaxis(self.values[:, entries], 0, 1))

    def combine(self, left: Array, right: Array) -> Array:
        """CSR values of the rows Bⁱ Aⁱ + Cⁱ for left = (Bⁱ), right = (Cⁱ), shapes (m, 3, 3)."""
        new = np.einsum("eab,be->ae", left[self.node_of_entry], self.values)
        # right[i, a, c] goes to row a, column (node i, component c)
        new[:, self.diagonal_entries] += np.moveaxis(right, 2, 1).reshape(-1, 3).T
        out = self._out
        for b in range(3):
            out[self.positions[b]] = new[b]
        return out

    def update(self, M: PETSc.Mat, left: Array, right: Array) -> None:
        """Overwrite the contact rows of M by Bⁱ Aⁱ + Cⁱ and assemble M (collective)."""
        values = self.combine(left, right)
        M.setValuesIJV(self.indptr, self.indices, values, rowmap=self.rows,
                       addv=PETSc.InsertMode.INSERT_VALUES)
        M.assemble()
