r"""GAMG for contact pairs, set up in the physical displacement: P⁻¹ = M⁻¹ B⁻¹ M⁻ᵀ.

Two bodies are solved in the unknown z with u = M z (M = I + Φ: a slave contact DOF holds its displacement
relative to the master point beneath it, :mod:`fenics_coulomb.model.pairs.two_body`), and the Newton matrix's
stiffness is Ã = Mᵀ A_free M with the supports' rows and columns of s I. Let B be A_free with the same supports:
then Ã = Mᵀ B M wherever no master DOF of a stencil is supported, and

    Ã⁻¹ = M⁻¹ B⁻¹ M⁻ᵀ,     M⁻¹ = I − Φ = 2I − M

(Φ maps master DOFs to slave DOFs, and no contact node is a vertex of a master facet a contact node uses — the
pairing checks it —, so Φ² = 0; slave contact nodes are never supported, :mod:`fenics_coulomb.model.pairs.two_body`).

So GAMG on B, applied between the two changes of variables, preconditions Ã as well as GAMG preconditions a
single elastic body, and two properties of B make it the better matrix to coarsen:

* **B couples no body to another.** Its near-nullspace is the six rigid modes of the whole mesh, which restricted
  to any aggregate (aggregates cannot straddle bodies: B's graph does not connect them) are the rigid modes of that
  body. GAMG on Ã needs the twelve modes (I − Φ) r_b of the two bodies (its graph does connect them through Φ), so
  every aggregate carries twelve coarse DOFs, six of them Householder completions of zero columns: coarse
  operators four times as dense, and a set-up that dominated the pair's solve.
* **B does not change with the geometry.** Finite sliding re-pairs the surfaces at every geometry update, and
  with them M and Ã; B, and GAMG's hierarchy on it, are set up once for the whole solve or load path. Only M,
  read from the model at each application, follows the pairing.

A body held by contact alone leaves B singular (the Newton matrix holds its free motions through the contact rows,
which B does not have); the coupling raises B's diagonal on such a body by ``HELD_BODY_SHIFT`` of itself
(:mod:`fenics_coulomb.model.pairs.coupling`): GAMG's coarsest factorization broke down without it.

Measured (2026-11-26, benchmarks/sliding_cost.py's robustness case "two-bodies", 19 500 unknowns, tetrahedra, the
defaults, 1 rank): small sliding 7 Newton / 78 Krylov iterations in 1.9 s with GAMG on Ã, 8 / 48 in 0.5 s with this
preconditioner; finite sliding 8 / 105 in 4.1 s (two GAMG set-ups, 1.07 s each) against 9 / 49 in 1.3 s. On
2 ranks 1.06 → 0.28 s and 2.3 → 0.87 s. The six global modes on Ã itself ((I − Φ) r): 113 Krylov iterations, 0.87 s.
"""

from __future__ import annotations

from collections.abc import Callable

import dolfinx
from petsc4py import PETSc

from fenics_coulomb.model.nullspace import rigid_body_modes

__all__ = ["PhysicalGAMG"]


class PhysicalGAMG:
    """The context of a petsc4py ``python`` PC applying M⁻¹ GAMG(B) M⁻ᵀ (module docstring).

    Args:
        B: The bodies' stiffness in the physical displacement (not changed; the caller owns it).
        variables: Returns the current M of u = M z (read at each application: the pairing may change).
        V: The displacement space (its rigid modes are GAMG's near-nullspace).
        prefix: The options prefix of the GAMG preconditioner (the solver's: the user's GAMG options apply).
    """

    def __init__(self, B: PETSc.Mat, variables: Callable[[], PETSc.Mat], V: dolfinx.fem.FunctionSpace,
                 prefix: str) -> None:
        self._variables = variables
        self.nullspace = rigid_body_modes(V)
        B.setNearNullSpace(self.nullspace)
        #: GAMG on B, set up at its first application and never again.
        self.gamg = PETSc.PC().create(V.mesh.comm)
        self.gamg.setOptionsPrefix(prefix)
        self.gamg.setType("gamg")
        self.gamg.setOperators(B, B)
        self._t, self._s = B.createVecs()

    def set_from_options(self) -> None:
        """Read the GAMG options from PETSc's database (call inside the solver's options scope)."""
        self.gamg.setFromOptions()

    def setUp(self, pc: PETSc.PC) -> None:  # noqa: N802 (petsc4py's name)
        """Nothing to do: GAMG on B is set up once, at its first application."""

    def apply(self, pc: PETSc.PC, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = M⁻¹ GAMG(B) M⁻ᵀ x, with M⁻¹ v = 2v − M v."""
        M = self._variables()
        M.multTranspose(x, self._t)
        self._t.aypx(-1.0, x)  # x − Mᵀx
        self._t.axpy(1.0, x)  # 2x − Mᵀx = M⁻ᵀ x
        self.gamg.apply(self._t, self._s)
        M.mult(self._s, y)
        y.aypx(-1.0, self._s)  # s − M s
        y.axpy(1.0, self._s)  # 2s − M s = M⁻¹ s

    def destroy(self, pc: PETSc.PC | None = None) -> None:
        """Destroy GAMG, its near-nullspace and the work vectors (collective). Called by PETSc with the ``pc`` it
        is destroying, it does nothing: the context outlives a KSP made anew (its owner, the solver, destroys it)."""
        if pc is not None:
            return
        for obj in (self.gamg, self.nullspace, self._t, self._s):
            obj.destroy()
