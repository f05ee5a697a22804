"""The power method for λ_max(A), which scales γ of the approximation step (6.17)."""

from __future__ import annotations

from petsc4py import PETSc

import numpy as np

__all__ = ["power_iteration"]


def power_iteration(A: PETSc.Mat, iterations: int) -> float:
    """Estimate the largest eigenvalue of the SPD matrix A by the power method.

    Only the assembled matrix is used (any elastic operator, no material assumption). The start vector
    depends only on the global index (x_j = 1.5 + sin(j)), so the estimate is the same for any number of
    ranks.
    """
    x, y = A.createVecs()
    lo, hi = x.getOwnershipRange()
    x.array[:] = 1.5 + np.sin(np.arange(lo, hi, dtype=np.float64))
    x.scale(1.0 / x.norm())
    estimate = 0.0
    for _ in range(iterations):
        A.mult(x, y)
        estimate = y.norm()
        y.scale(1.0 / estimate)
        x, y = y, x
    x.destroy()
    y.destroy()
    return float(estimate)
