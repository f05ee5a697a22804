r"""Parallel sums in a fixed order: the same matrices, and so the same bits, on every run on the same ranks.

PETSc adds a matrix's off-process contributions in the order their messages arrive: ``MatAssemblyEnd`` takes
the stash's messages as they come (MPI_Waitsome), and the default parallel triple product PᵀAP does the same.
On two ranks every rank has one neighbour and the order is fixed; on three and more, an entry that receives
contributions from two other ranks (a vertex shared by three ranks) is summed in a different order from run to
run, and every later bit can differ (measured: a 16×16×4 tetrahedral box [0, 2]×[0, 2]×[0, 0.5] on 3 ranks
with the deterministic partition, 5 assemblies of the elasticity matrix: 4 different value arrays).

* :func:`assemble_matrix` assembles into DOLFINx's own CSR matrix, whose reverse scatter adds the ghost rows'
  contributions in neighbour order, and copies the owned rows into a PETSc AIJ matrix (block size of the space,
  columns sorted). On one rank it equals ``dolfinx.fem.petsc.assemble_matrix`` bit for bit; below
  :data:`MIN_RANKS` ranks that function is used as it is (the same bits as ever).
* :class:`TripleProduct` forms the pairs' Mᵀ A M from an explicit transpose and two products, each entry summed
  by the owner of its row (no off-process sums); GAMG's own coarse products use PETSc's fixed-order PtAP
  (:data:`FIXED_ORDER_PTAP`, set by the solver around its solves).
"""

from __future__ import annotations

from collections.abc import Sequence

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem.petsc
import numpy as np

__all__ = ["FIXED_ORDER_PTAP", "MIN_RANKS", "TripleProduct", "assemble_matrix", "same_pattern"]

#: From this many ranks a matrix entry can receive off-process contributions from more than one rank.
MIN_RANKS = 3
#: The unprefixed PETSc option (name, value) of a parallel PtAP that sums in a fixed order.
FIXED_ORDER_PTAP = ("matptap_via", "allatonce")


def assemble_matrix(form: dolfinx.fem.Form, bcs: Sequence[dolfinx.fem.DirichletBC] = (),
                    diagonal: float = 1.0) -> PETSc.Mat:
    """The assembled PETSc matrix of ``form`` (as ``dolfinx.fem.petsc.assemble_matrix(form, bcs, diagonal)``
    followed by ``assemble()``), its parallel sums in a fixed order.

    Args:
        form: A compiled bilinear form.
        bcs: Dirichlet conditions: their rows and columns zero, ``diagonal`` on their owned diagonal entries.
        diagonal: The diagonal value of a constrained row.

    Returns:
        An assembled AIJ matrix with the block size of the form's test space (no options prefix).
    """
    comm = form.mesh.comm
    if comm.size < MIN_RANKS:
        A = dolfinx.fem.petsc.assemble_matrix(form, bcs=list(bcs), diagonal=diagonal)
        A.assemble()
        return A
    # Not dolfinx.fem.assemble_matrix: its insert_diagonal also sets the diagonal of ghost rows of constrained
    # DOFs (fine for PETSc's INSERT, added up by the CSR's reverse scatter) and, with ghosted cells
    # (GhostMode.shared_facet), fails with "Entry not in sparsity" on 3 ranks. The owned diagonal is set below.
    csr = dolfinx.fem.create_matrix(form, block_mode=dolfinx.la.BlockMode.expanded)
    dolfinx.cpp.fem.assemble_matrix(csr._cpp_object, form._cpp_object, dolfinx.cpp.fem.pack_constants(form._cpp_object),
                                    dolfinx.cpp.fem.pack_coefficients(form._cpp_object),
                                    [bc._cpp_object for bc in bcs])
    csr.scatter_reverse()
    V = form.function_spaces[0]
    rows_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    cols_map = csr.index_map(1)  # the expanded column map: one index per DOF, ghosts included
    owned = rows_map.size_local * bs
    indptr = np.asarray(csr.indptr[: owned + 1], dtype=np.int64)
    nnz = int(indptr[-1])
    local_cols = np.asarray(csr.indices[:nnz], dtype=np.int64)
    to_global = cols_map.local_to_global(np.arange(cols_map.size_local + cols_map.num_ghosts, dtype=np.int32))
    cols = np.asarray(to_global, dtype=np.int64)[local_cols]
    rows = np.repeat(np.arange(owned, dtype=np.int64), np.diff(indptr))
    data = np.array(csr.data[:nnz], dtype=PETSc.ScalarType)
    if form.function_spaces[1] is V:  # as dolfinx: ``diagonal`` on the owned diagonal of constrained DOFs
        constrained = np.zeros(owned, dtype=bool)
        for bc in bcs:
            if V.contains(bc.function_space):
                dofs = bc.dof_indices()[0]
                constrained[dofs[dofs < owned]] = True
        data[constrained[rows] & (local_cols == rows)] = diagonal
    order = np.lexsort((cols, rows))  # PETSc wants each row's columns ascending
    size = (owned, rows_map.size_global * bs)
    A = PETSc.Mat().createAIJ(size=(size, size), bsize=bs, comm=comm,
                              csr=(indptr.astype(PETSc.IntType), cols[order].astype(PETSc.IntType),
                                   data[order]))
    A.assemble()
    return A


class TripleProduct:
    """Mᵀ A M formed as Mᵀ·(A·M) with Mᵀ explicit: every entry of each product is summed by the rank that owns its
    row, in the order of the sparse rows, with no off-process sums — the same bits on every run on the same ranks.

    PETSc's PtAP needs its "allatonce" algorithm for that from :data:`MIN_RANKS` ranks, which costs: on the
    two-body Hertz mesh (benchmarks/verification_two_body.py, level 0, 3 ranks) 0.08 s for a new product and
    0.048 s for the numeric phase, against 0.021 s and 0.0024 s here. On one rank the result equals PETSc's
    default PtAP bit for bit (level 1, 23 781 unknowns: 0.048 s against 0.13 s, numeric phase 0.0098 s against
    0.021 s); on two ranks it differs from the default's in the last bits (3e-14 of |Ã|∞), numeric phase 0.012 s
    against 0.088 s. The object keeps Mᵀ and A·M for the numeric phase of the next product of the same A and
    the same M (new values, the same nonzero pattern): A·M is one more matrix of A's size while the coupling
    lives (PETSc's PtAP kept its own intermediate products for its numeric phase too); :meth:`destroy` frees them.
    """

    def __init__(self) -> None:
        self._transpose: PETSc.Mat | None = None
        self._right: PETSc.Mat | None = None

    def __call__(self, A: PETSc.Mat, M: PETSc.Mat, result: PETSc.Mat | None = None) -> PETSc.Mat:
        """Mᵀ A M: a new matrix, or with ``result`` (the last product of this A and this M, whose values M has
        replaced with its pattern unchanged) overwritten in place by the numeric phases (collective)."""
        if result is None:
            self.destroy()
            self._transpose = M.transpose(PETSc.Mat())
            self._right = A.matMult(M)
            return self._transpose.matMult(self._right)
        transpose, right = self._transpose, self._right
        if transpose is None or right is None:
            raise ValueError("TripleProduct: an in-place product needs a product of the same A and M before")
        M.transpose(transpose)
        A.matMult(M, result=right)
        return transpose.matMult(right, result=result)

    def destroy(self) -> None:
        """Free Mᵀ and A·M."""
        for mat in (self._transpose, self._right):
            if mat is not None:
                mat.destroy()
        self._transpose = self._right = None


def same_pattern(a: PETSc.Mat, b: PETSc.Mat) -> bool:
    """Whether two matrices of one layout have the same nonzero pattern on every rank (collective): a new M of the
    same pattern lets :class:`TripleProduct` overwrite its last product in place."""
    ia, ja, _ = a.getValuesCSR()
    ib, jb, _ = b.getValuesCSR()
    same = bool(np.array_equal(ia, ib) and np.array_equal(ja, jb))
    return bool(a.getComm().tompi4py().allreduce(same, op=MPI.LAND))
