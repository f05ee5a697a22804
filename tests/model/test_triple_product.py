"""The pairs' triple product Mᵀ A M (model/reproducible.TripleProduct) against PETSc's own PtAP, new and in place,
on the stiffness A_free and the M = I + Φ of two blocks' mortar coupling (benchmarks/sliding.py), any rank count."""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest

from benchmarks.sliding import SlidingBlocks
from conftest import matrix_difference
from fenics_coulomb.model.reproducible import TripleProduct


def _difference(a: PETSc.Mat, b: PETSc.Mat) -> float:
    return matrix_difference(a, b, PETSc.NormType.INFINITY)


def test_triple_product_is_petsc_ptap_new_and_in_place():
    blocks = SlidingBlocks(MPI.COMM_WORLD, 0.5, prefix="triple_", n_lower=(8, 4, 2), n_upper=(6, 3, 2))
    coupling = blocks.problem.model.coupling
    A, M = coupling.A_free, coupling.M
    product = TripleProduct()
    with pytest.raises(ValueError, match="in-place product"):
        product(A, M, result=A)
    C = product(A, M)
    reference = A.ptap(M)
    assert _difference(C, reference) <= 1e-14
    # new values of M on its pattern: Φ scaled by 1/2, the product in place against a new PtAP
    scaled = M.duplicate(copy=True)
    scaled.shift(-1.0)
    scaled.scale(0.5)
    scaled.shift(1.0)
    scaled.copy(M, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    handle = C.handle
    C = product(A, M, result=C)
    assert C.handle == handle
    fresh = A.ptap(M)
    assert _difference(C, fresh) <= 1e-14 and _difference(C, reference) > 1e-6
    if MPI.COMM_WORLD.size == 1:  # one rank: PETSc's PtAP bit for bit
        assert np.array_equal(C.getValuesCSR()[2], fresh.getValuesCSR()[2])
    for mat in (C, reference, scaled, fresh):
        mat.destroy()
    product.destroy()
    blocks.destroy()
