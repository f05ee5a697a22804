"""The coupling of the bodies: the change of variables u = M z between the physical displacement u and the
solver's unknown z, and everything that follows from it.

:class:`ContactModel <fenics_coulomb.model.contact_model.ContactModel>` holds one coupling and asks it for

* the stiffness the solver sees (:meth:`Coupling.stiffness`: A, or Ã = Mᵀ A_free M) before the Dirichlet rows
  are scaled, and the lifted load (:meth:`Coupling.assemble_load`);
* the maps :meth:`Coupling.physical` (u = M z) and :meth:`Coupling.relative` (z = M⁻¹ u);
* the near-nullspace of the preconditioner (:meth:`Coupling.near_nullspace`);
* the master bodies' reaction to the slave contact forces (:meth:`Coupling.master_forces`).

:class:`IdentityCoupling` is one body (or bodies touching rigid obstacles only): M = I. :class:`PairCoupling`
is two elastic bodies with M = I + Φ, Φ² = 0, Φ_jl the weight of master node l in slave node j's stencil
(:mod:`fenics_coulomb.model.pairs.two_body` derives the reduced problem; today's Φ is node-to-surface,
:mod:`fenics_coulomb.model.pairs.pairing`). Another discretization of the pair (dual mortar: Φ_jl = M_jl / D_j)
plugs in as another Φ: the solver, the frames and friction are unchanged.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.nullspace import rigid_body_modes
from fenics_coulomb.model.pairs.two_body import body_rigid_modes, coupling_matrix

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel
    from fenics_coulomb.model.pairs import Pairing

__all__ = ["Coupling", "IdentityCoupling", "PairCoupling"]

Array = npt.NDArray[np.float64]


class Coupling:
    """The interface (see the module docstring); :attr:`paired` says whether there are master bodies."""

    #: Whether the coupling has slave and master bodies (two elastic bodies in contact).
    paired: bool = False

    def stiffness(self, model: ContactModel, prefix: str) -> PETSc.Mat:
        """The assembled stiffness in the solver's unknown with the Dirichlet rows and columns set to the identity
        (collective; the model scales them afterwards)."""
        raise NotImplementedError

    def assemble_load(self, model: ContactModel) -> None:
        """Assemble l̃ into ``model.load`` from the current coefficients and Dirichlet values (collective)."""
        raise NotImplementedError

    def physical(self, z: Array) -> Array:
        """u = M z on the owned DOFs (collective)."""
        raise NotImplementedError

    def relative(self, u: Array) -> Array:
        """z = M⁻¹ u on the owned DOFs (collective)."""
        raise NotImplementedError

    def master_forces(self, contact_force: Array, local_dofs: npt.NDArray[np.int32]) -> Array | None:
        """The reaction on the master nodes (owned DOFs), or None without master bodies (collective)."""
        raise NotImplementedError

    def near_nullspace(self, V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
        """The rigid-body modes in the solver's unknown, for GAMG (the caller destroys it)."""
        raise NotImplementedError

    def destroy(self) -> None:
        """Destroy the PETSc objects the coupling owns (collective)."""


class IdentityCoupling(Coupling):
    """One body (M = I): A with the Dirichlet rows and columns of the identity, l̃ by DOLFINx's lifting."""

    def stiffness(self, model: ContactModel, prefix: str) -> PETSc.Mat:
        A = dolfinx.fem.petsc.assemble_matrix(model.a, bcs=model.bcs)
        A.assemble()
        A.setOptionsPrefix(f"{prefix}A_")
        return A

    def assemble_load(self, model: ContactModel) -> None:
        """Assemble, lift the Dirichlet values into the right-hand side, add the ghost contributions to their
        owners (reverse scatter), then set the Dirichlet rows to s g (see the model's docstring)."""
        b = dolfinx.fem.petsc.assemble_vector(model.L)
        dolfinx.fem.petsc.apply_lifting(b, [model.a], bcs=[model.bcs])
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        dolfinx.fem.petsc.set_bc(b, model.bcs, alpha=model.dirichlet_diagonal)
        b.copy(model.load)
        b.destroy()

    def physical(self, z: Array) -> Array:
        return np.array(z, dtype=np.float64)

    def relative(self, u: Array) -> Array:
        return np.array(u, dtype=np.float64)

    def master_forces(self, contact_force: Array, local_dofs: npt.NDArray[np.int32]) -> Array | None:
        return None

    def near_nullspace(self, V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
        return rigid_body_modes(V)


class PairCoupling(Coupling):
    """Two elastic bodies: M = I + Φ from the pairing's stencils (PETSc AIJ ``<prefix>coupling_``).

    Args:
        V: The vector space of both bodies.
        pairing: The slave nodes' stencils (blocks, master blocks, weights).
        body_of_block: The body of every local DOF block; ``num_bodies`` their number.
        prefix: Options prefix of the model's objects.
        held: The components a Dirichlet condition holds at each slave node, shape (m, 3) (None: none).
    """

    paired = True

    def __init__(self, V: dolfinx.fem.FunctionSpace, pairing: Pairing, body_of_block: npt.NDArray[np.int64],
                 num_bodies: int, prefix: str, A_free: PETSc.Mat | None = None,
                 held: npt.NDArray[np.bool_] | None = None) -> None:
        self.pairing = pairing
        self.body_of_block = body_of_block
        self.num_bodies = num_bodies
        #: M = I + Φ (Φ's rows of held slave components 0).
        self.M: PETSc.Mat = coupling_matrix(V, pairing.blocks, pairing.master_blocks, pairing.weights, prefix, held)
        #: The stiffness without boundary conditions (both bodies): given (then its owner destroys it) or
        #: assembled by :meth:`stiffness`.
        self.A_free: PETSc.Mat | None = A_free
        self._owns_free = A_free is None

    def stiffness(self, model: ContactModel, prefix: str) -> PETSc.Mat:
        """Ã = Mᵀ A_free M (PtAP) with the Dirichlet rows and columns of the identity."""
        if self.A_free is None:
            self.A_free = dolfinx.fem.petsc.assemble_matrix(model.a)
            self.A_free.assemble()
            self.A_free.setOptionsPrefix(f"{prefix}A_free_")
        A = self.A_free.ptap(self.M)
        A.setOptionsPrefix(f"{prefix}A_")
        r0 = model.V.dofmap.index_map.local_range[0]
        A.zeroRowsColumns((model.dirichlet_rows + 3 * r0).astype(PETSc.IntType), diag=1.0)
        return A

    def assemble_load(self, model: ContactModel) -> None:
        """l̃_z = Mᵀ(l − A_free M x_D) on the free DOFs and s u_D on D (:mod:`fenics_coulomb.model.pairs.two_body`)."""
        assert self.A_free is not None, "stiffness() first"
        l = dolfinx.fem.petsc.assemble_vector(model.L)
        l.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        x_d = model.A.createVecRight()  # M x_D: the Dirichlet values g on D, 0 elsewhere
        x_d.set(0.0)
        x_d.array[model.dirichlet_rows] = model.dirichlet_values
        t, y = self.A_free.createVecs()
        self.M.mult(x_d, t)
        self.A_free.mult(t, y)
        y.scale(-1.0)
        y.axpy(1.0, l)  # y = l − A_free M x_D
        self.M.multTranspose(y, model.load)
        model.load.array[model.dirichlet_rows] = model.dirichlet_diagonal * x_d.array[model.dirichlet_rows]
        for vec in (l, x_d, t, y):
            vec.destroy()

    def physical(self, z: Array) -> Array:
        x, y = self.M.createVecs()
        x.array[:] = z
        self.M.mult(x, y)
        u = y.getArray(readonly=True).copy()
        x.destroy()
        y.destroy()
        return u

    def relative(self, u: Array) -> Array:
        """z = M⁻¹ u = (I − Φ) u = 2u − M u (Φ² = 0)."""
        return 2.0 * np.asarray(u, dtype=np.float64) - self.physical(u)

    def master_forces(self, contact_force: Array, local_dofs: npt.NDArray[np.int32]) -> Array | None:
        """f_j = −Σ_s φ_sj f_s: Mᵀ f − f = Φᵀ f with f on the slave contact DOFs ``local_dofs``, shape (m, 3)."""
        x, y = self.M.createVecs()
        x.set(0.0)
        x.array[local_dofs] = np.asarray(contact_force, dtype=np.float64).reshape(-1, 3)
        self.M.multTranspose(x, y)  # Mᵀ f = f + Φᵀ f
        y.axpy(-1.0, x)
        out = -y.getArray(readonly=True).copy()
        x.destroy()
        y.destroy()
        return out

    def near_nullspace(self, V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
        """(I − Φ) r_b per body b (:func:`fenics_coulomb.model.pairs.two_body.body_rigid_modes`)."""
        return body_rigid_modes(V, self.body_of_block, self.num_bodies, self.M)

    def destroy(self) -> None:
        for obj in (self.M, self.A_free if self._owns_free else None):
            if obj is not None:
                obj.destroy()
        self.A_free = None
