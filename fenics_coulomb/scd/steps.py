r"""The two Newton steps of Section 5 as strategies: variant 4a (S*Q, system (5.4)) and 4b (SQ).

Both overwrite the contact rows of the Newton matrix M (a copy of A) by Bⁱ Aⁱ + Cⁱ and differ in the
blocks, the right-hand side, whether M or Mᵀ is solved, and how Δu is read off the solution:

(4a) with rge(Y*, X*) ∈ S*Q(d̂, z) (blocks W*ⁱ, U*ⁱ on contact nodes, I and 0 elsewhere), system (5.4)
         (Y*ᵀ A + X*ᵀ) Δu = −(Y*ᵀ ŷ₁ + X*ᵀ ŷ₂);
(4b) with rge(X, Y) ∈ SQ(d̂, z) (blocks Xⁱ, Yⁱ; I and 0 elsewhere)
         (A X + Y) p = A ŷ₂ − ŷ₁,   Δu = X p − ŷ₂,
     solved as the transposed system of Xᵀ A + Yᵀ, which has the row structure of (5.4), for the
     correction q = p − ŷ₂ (so that the inexact solve errs relative to Δu, not to p).

Units: Q̃ maps displacements to forces. The blocks are taken for Q̃/γ (forces measured in units of
γ·length, so the sliding bases' s + t/γ and the rows' A·Δu + γ·U*ᵀΔu are consistent), and the rows are
multiplied by γ. This selects the same Newton iterate as the paper's bases (exact solves) but makes the
inexact GMRES solves independent of the units of E and the loads.

Per-node γ: every formula above is node-wise, so a contact node i may carry its own γᵢ (the driver's
``node_gamma``; off the contact nodes γ acts only through ŷ₁ = γ e = r, which the right-hand sides use as r).
Why the method stays the paper's: see :mod:`fenics_coulomb.scd.node_gamma`.
"""

from __future__ import annotations

from typing import Protocol

from petsc4py import PETSc

import numpy as np
import numpy.typing as npt

from fenics_coulomb.scd.derivatives import s_blocks, sstar_blocks

__all__ = ["NewtonOperators", "NewtonStep", "SStarStep", "SStep", "STEPS"]

Array = npt.NDArray[np.float64]
Friction = float | Array


class NewtonOperators(Protocol):
    """What a step needs from the driver: γ, the contact DOFs, A, the Newton matrix and work vectors."""

    gamma: float
    node_gamma: Array
    cdofs: npt.NDArray[np.int32]
    A: PETSc.Mat
    M: PETSc.Mat
    b: PETSc.Vec
    w: PETSc.Vec
    Adu: PETSc.Vec


class NewtonStep(Protocol):
    """A variant of the Newton step (see the module docstring)."""

    name: str

    def rows(self, v: Array, z: Array, sets: npt.NDArray[np.int8], friction: Friction,
             gamma: float | Array) -> tuple[Array, Array]:
        """The blocks (Bⁱ, Cⁱ) of the new contact rows Bⁱ Aⁱ + Cⁱ (γ a number or one per node)."""

    def right_hand_side(self, ops: NewtonOperators, e: Array, left: Array, right: Array) -> None:
        """Fill ``ops.b``."""

    def linear_solve(self, ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """Solve the Newton system (or its transpose)."""

    def direction(self, x: Array, e: Array, left: Array, cdofs: npt.NDArray[np.int32]) -> Array:
        """Δu from the linear solve's solution ``x``."""


class _Rows:
    """The new contact rows from a pair of node blocks of Q̃/γ (see the module docstring for the units)."""

    @staticmethod
    def blocks(v: Array, z: Array, sets: npt.NDArray[np.int8], friction: Friction) -> tuple[Array, Array]:
        raise NotImplementedError

    def rows(self, v: Array, z: Array, sets: npt.NDArray[np.int8], friction: Friction,
             gamma: float | Array) -> tuple[Array, Array]:
        g = np.broadcast_to(np.asarray(gamma, dtype=np.float64), z.shape[:1])
        first, second = self.blocks(v, z / g[:, None], sets, friction)
        return np.swapaxes(first, 1, 2), g[:, None, None] * np.swapaxes(second, 1, 2)


class SStarStep(_Rows):
    """Variant 4a: the adjoint blocks (W*, U*) ∈ S*Q̃, system (5.4) solved for Δu directly."""

    name = "4a"
    blocks = staticmethod(sstar_blocks)

    def right_hand_side(self, ops: NewtonOperators, e: Array, left: Array, right: Array) -> None:
        gamma, cd = ops.node_gamma[:, None], ops.cdofs
        b = -ops.gamma * e
        b[cd] = -gamma * (np.einsum("iab,ib->ia", left, e[cd]) + np.einsum("iab,ib->ia", right, e[cd]) / gamma)
        ops.b.array[:] = b

    def linear_solve(self, ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> None:
        ksp.solve(b, x)

    def direction(self, x: Array, e: Array, left: Array, cdofs: npt.NDArray[np.int32]) -> Array:
        return x


class SStep(_Rows):
    """Variant 4b: the blocks (X, Y) ∈ SQ̃, the transposed system solved for q = p − ŷ₂."""

    name = "4b"
    blocks = staticmethod(s_blocks)

    def right_hand_side(self, ops: NewtonOperators, e: Array, left: Array, right: Array) -> None:
        # (A X + Y) p = A ŷ₂ − ŷ₁ with ŷ₂ = e, ŷ₁ = γ e. Near the solution Δu = X p − e is much smaller than
        # p ≈ e, so an inexact p would swamp Δu: solve for q = p − e instead, with
        # (A X + Y) q = A e − γ e − (A X + Y) e, whose size is that of Δu (and tol then means the same as in 4a).
        ops.w.array[:] = e
        ops.A.mult(ops.w, ops.b)
        ops.b.axpy(-ops.gamma, ops.w)
        if np.any(ops.node_gamma != ops.gamma):  # Γ e: γᵢ on the contact nodes
            ops.b.array[ops.cdofs] -= (ops.node_gamma - ops.gamma)[:, None] * e[ops.cdofs]
        ops.M.multTranspose(ops.w, ops.Adu)
        ops.b.axpy(-1.0, ops.Adu)

    def linear_solve(self, ksp: PETSc.KSP, b: PETSc.Vec, x: PETSc.Vec) -> None:
        ksp.solveTranspose(b, x)

    def direction(self, x: Array, e: Array, left: Array, cdofs: npt.NDArray[np.int32]) -> Array:
        p = x + e
        du = p - e
        du[cdofs] = np.einsum("iba,ib->ia", left, p[cdofs]) - e[cdofs]  # Xⁱ p = (leftⁱ)ᵀ p
        return du


STEPS: dict[str, type[SStarStep] | type[SStep]] = {"4a": SStarStep, "4b": SStep}
