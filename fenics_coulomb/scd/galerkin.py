r"""Coarse operators of A's GAMG hierarchy that follow the Newton matrix (Galerkin products of M).

GAMG is set up once on the stiffness A (aggregates, prolongators P_l, coarse operators A_l = P_lᵀ A_{l−1} P_l).
The Newton matrix differs from A only in its contact rows, M = A + E with

    E = (D − I) A + C     (rows of the contact nodes only: Eⁱ = (Bⁱ − I) Aⁱ + Cⁱ),

so the Galerkin coarse operators of M on the SAME prolongators are A_l + E_l with E_0 = E and
E_l = P_lᵀ E_{l−1} P_l. E_1 = P_{1,c}ᵀ (E_c P_1) involves only the contact rows c of P_1 and E: its cost is that
of the contact surface, not of the mesh, and the deeper products act on the (small) coarse levels. Every Newton
step adds the change ΔE of E to the level operators in place (same nonzero pattern), so the hierarchy is never
set up again; the fine level keeps Amat = M (smoother and residual on M) and Pmat = A.

Measured (d3/L2, 2 ranks, docs/scale/README.md): with the contact rows scaled to A's diagonal (see
:func:`row_scaling`) GMRES needs 58 instead of 91 iterations at lev 8 and 86 instead of 107 at lev 10 (without the
coarse update the coarse-grid correction ignores the constraints of sticking and sliding nodes), but the Newton
steps rise (12 → 16, 13 → 17), the whole job is not faster at lev 10 and takes about 10 % more memory (PETSc's
products keep a local copy of the prolongator), so it is opt-in (``galerkin_coarse``, ``--galerkin-coarse``).
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

from fenics_coulomb.scd.contact_rows import ContactRows

__all__ = ["row_scaling", "GalerkinCoarsening"]

Array = npt.NDArray[np.float64]


def row_scaling(left: Array, right: Array, diagonal: Array) -> Array:
    r"""Per-row factors that give every new contact row the size of A's diagonal (local frame).

    The local row j of node i is Bⁱ_j Aⁱ + Cⁱ_j with diagonal ≈ aᵢ Bⁱ_jj + Cⁱ_jj (aᵢ: mean of A's three diagonal
    entries of the node). Constrained rows (Bⁱ_j = 0, Cⁱ_jj = γ) are thus γ/aᵢ ≈ 1/25 of the unconstrained ones;
    the factor sⁱ_j = aᵢ/(aᵢ Bⁱ_jj + Cⁱ_jj) > 0 (both terms ≥ 0 and never both 0, :mod:`fenics_coulomb.scd.derivatives`)
    makes the scaled Newton matrix's diagonal ≈ A's, which the Jacobi smoothers (on A) and the Galerkin coarse
    operators need. Scaling rows does not change the Newton direction, only the norm GMRES minimizes.

    Args:
        left: Blocks Bⁱ in the local frame, shape (m, 3, 3).
        right: Blocks Cⁱ in the local frame, shape (m, 3, 3).
        diagonal: aᵢ, shape (m,).

    Returns:
        sⁱ_j, shape (m, 3).
    """
    a = np.asarray(diagonal, dtype=np.float64)[:, None]
    return a / (a * np.einsum("ijj->ij", left) + np.einsum("ijj->ij", right))


class GalerkinCoarsening:
    """Owns E (the contact rows of M − A) and the coarse products, and updates a GAMG hierarchy in place.

    Args:
        A: The stiffness matrix (not owned).
        rows: The contact rows of A (pattern and values of Aⁱ).
    """

    def __init__(self, A: PETSc.Mat, rows: ContactRows) -> None:
        comm = A.getComm()
        self.comm = comm.tompi4py()
        self.rows = rows
        #: aᵢ of :func:`row_scaling`: the mean of A's three diagonal entries of every contact node
        self.diagonal = rows.diagonal().mean(axis=1)
        n_rows = len(rows.rows)
        total = self.comm.allreduce(n_rows, op=MPI.SUM)
        # E restricted to the contact rows: (contact rows) × (columns of A), CSR from A's contact rows
        self.Ec = PETSc.Mat().createAIJ(((n_rows, total), A.getSizes()[1]),
                                        csr=(rows.indptr, rows.indices, np.zeros(len(rows.indices))), comm=comm)
        self.Ec.setOption(PETSc.Mat.Option.NEW_NONZERO_LOCATION_ERR, True)
        self.Ec.assemble()
        self.rowset = PETSc.IS().createGeneral(np.asarray(rows.rows, dtype=PETSc.IntType), comm=comm)
        self.current: npt.NDArray[np.float64] = np.zeros(len(rows.indices))
        self._identity = np.eye(3)[None]
        self._pc = 0  # the handle of the PC whose hierarchy holds self.current
        self._levels: list[int] = []
        self._products: dict[int, PETSc.Mat] = {}
        self._Pc: PETSc.Mat | None = None  # P_cᵀ
        self._EcP: PETSc.Mat | None = None

    def _level_operators(self, pc: PETSc.PC) -> list[PETSc.Mat]:
        """The operators of levels 0 .. L−2 (coarsest first), the ones the update writes."""
        return [pc.getMGSmoother(level).getOperators()[0] for level in range(pc.getMGLevels() - 1)]

    def _fingerprint(self, pc: PETSc.PC) -> list[int]:
        """The identities of the level operators and prolongators: a new GAMG set-up (A changed) creates new
        ones, and the hierarchy then holds A's Galerkin products again. (Their object states are no guide: PETSc
        bumps them during solves.)"""
        L = pc.getMGLevels()
        return [op.handle for op in self._level_operators(pc)] + \
            [pc.getMGInterpolation(level).handle for level in range(1, L)]

    def _attach(self, pc: PETSc.PC) -> None:
        """Start from A's hierarchy (E = 0 in it): after GAMG's (first or repeated) set-up."""
        self._release()
        self._pc = pc.handle
        self.current[:] = 0.0
        L = pc.getMGLevels()
        if L > 1:
            P = pc.getMGInterpolation(L - 1)
            c0, c1 = P.getOwnershipRangeColumn()
            cols = PETSc.IS().createStride(c1 - c0, first=c0, step=1, comm=P.getComm())
            rows = P.createSubMatrix(self.rowset, cols)  # the contact rows of the finest prolongator
            cols.destroy()
            # transposed once: a product with an explicit transpose computes each row on its owner in a fixed
            # order, where Pᵀ·B would add off-process contributions as they arrive (bits could vary on 3+ ranks)
            self._Pc = rows.transpose()  # in place (petsc4py without ``out``)
        self._levels = self._fingerprint(pc)

    def scale(self, left: Array, right: Array) -> tuple[Array, Array]:
        """The local-frame blocks (Bⁱ, Cⁱ) with every row scaled by :func:`row_scaling`."""
        factor = row_scaling(left, right, self.diagonal)[:, :, None]
        return factor * left, factor * right

    def update(self, pc: PETSc.PC, left: Array, right: Array) -> None:
        """Make the coarse operators of ``pc`` (a set-up GAMG on A) the Galerkin products of the Newton matrix
        with contact rows Bⁱ Aⁱ + Cⁱ (Cartesian blocks ``left`` = Bⁱ, ``right`` = Cⁱ). Collective."""
        if pc.handle != self._pc or self._fingerprint(pc) != self._levels:
            self._attach(pc)
        L = pc.getMGLevels()
        new = self.rows.combine(left - self._identity, right).copy()
        delta = new - self.current
        changed = self.comm.allreduce(bool(np.any(delta != 0.0)), op=MPI.LOR)
        if L < 2 or not changed:
            return
        self.current = new
        self.Ec.setValuesIJV(self.rows.indptr, self.rows.indices, delta,
                             rowmap=np.arange(*self.Ec.getOwnershipRange(), dtype=PETSc.IntType),
                             addv=PETSc.InsertMode.INSERT_VALUES)
        self.Ec.assemble()
        operators = self._level_operators(pc)
        # level L−2: P_cᵀ (ΔE_c P)
        P = pc.getMGInterpolation(L - 1)
        self._EcP = self.Ec.matMult(P, result=self._EcP)
        product = self._products.get(L - 1)
        assert self._Pc is not None  # set with the hierarchy (_attach)
        product = self._Pc.matMult(self._EcP, result=product)
        self._products[L - 1] = product
        operators[L - 2].axpy(1.0, product, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        for level in range(L - 2, 0, -1):  # deeper: ΔE_{l−1} = P_lᵀ ΔE_l P_l on the small coarse levels
            P = pc.getMGInterpolation(level)
            coarse = self._products.get(level)
            coarse = product.ptap(P, result=coarse)
            self._products[level] = coarse
            operators[level - 1].axpy(1.0, coarse, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            product = coarse
        self._levels = self._fingerprint(pc)

    def _release(self) -> None:
        for mat in (*self._products.values(), self._Pc, self._EcP):
            if mat is not None:
                mat.destroy()
        self._products = {}
        self._Pc = None
        self._EcP = None
        self._pc = 0

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        self._release()
        self.Ec.destroy()
        self.rowset.destroy()
