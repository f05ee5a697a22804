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
* :func:`fixed_order_products` makes the parallel PtAP products made inside it sum in a fixed order (PETSc's
  "allatonce" algorithm), read from the unprefixed option ``matptap_via`` because PETSc creates product
  matrices without an options prefix; set for the duration only, and never over a value the user gave.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem.petsc
import numpy as np

__all__ = ["FIXED_ORDER_PTAP", "MIN_RANKS", "assemble_matrix", "fixed_order_products"]

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


@contextlib.contextmanager
def fixed_order_products(comm: MPI.Comm) -> Iterator[None]:
    """Within the block, parallel PtAP products on ``comm`` sum in a fixed order (from :data:`MIN_RANKS` ranks;
    the option is removed afterwards, and a value the user set is left alone)."""
    opts = PETSc.Options()
    key, value = FIXED_ORDER_PTAP
    added = comm.size >= MIN_RANKS and not opts.hasName(key)
    if added:
        opts[key] = value
    try:
        yield
    finally:
        if added:
            opts.delValue(key)
