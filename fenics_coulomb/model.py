r"""The discrete contact model of Section 6: stiffness, loads and the shifted generalized equation.

With the stiffness matrix A, the load vector l̃ and the shift d (dⁱ = (0, 0, αᵢ) at contact node i, 0
elsewhere), the physical displacement ũ solves Definition 6.1. In the shifted unknown u = ũ + d the
problem is the generalized equation (6.3)

    0 ∈ A u − l + Q(u),

where, substituting ũ = u − d into ½ ũᵀAũ − ⟨l̃, ũ⟩,

    ½ (u − d)ᵀA(u − d) − ⟨l̃, u − d⟩ = ½ uᵀAu − ⟨l̃ + A d, u⟩ + const,

so the shifted load is **l = l̃ + A d** (the paper prints l̃ − A d, a sign slip; with it the residual
A u − l would differ from the physical A ũ − l̃ by 2 A d). Check: A u − l = A ũ + A d − l̃ − A d = A ũ − l̃.

Dirichlet DOFs are kept in the system as identity-like rows (scaled to the stiffness's diagonal, so the
spectrum used for γ is not polluted) with zero load; they belong to the non-contact block R of (6.4).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.contact import ContactMap
from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.scene import Body

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Material:
    """Isotropic linear elasticity (units: GPa)."""

    young: float = 70.0
    poisson: float = 0.334

    def validate(self) -> None:
        """Raise InputError for non-physical values (E must be > 0 and finite, ν in (−1, 0.5))."""
        if not (np.isfinite(self.young) and self.young > 0.0):
            raise InputError(f"Young's modulus E = {self.young!r} GPa: must be finite and > 0")
        if not (np.isfinite(self.poisson) and -1.0 < self.poisson < 0.5):
            raise InputError(f"Poisson ratio nu = {self.poisson!r}: must lie in (-1, 0.5)")

    @property
    def lame(self) -> tuple[float, float]:
        """Lamé parameters (μ, λ)."""
        E, nu = self.young, self.poisson
        return E / (2.0 * (1.0 + nu)), E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))


def validate_friction(friction: float) -> None:
    """Raise InputError unless 0 <= F < inf."""
    if not (np.isfinite(friction) and friction >= 0.0):
        raise InputError(f"friction coefficient F = {friction!r}: must be finite and >= 0")


def validate_tractions(tractions: dict[str, tuple[float, float, float]], body: Body) -> None:
    """Raise InputError for unknown boundaries or non-finite traction vectors."""
    for name, value in tractions.items():
        body.tag(name)
        vec = np.asarray(value, dtype=np.float64)
        if vec.shape != (3,) or not np.all(np.isfinite(vec)):
            raise InputError(f"traction on {name!r} = {value!r}: must be 3 finite numbers (GPa)")


def epsilon(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Small-strain tensor."""
    return ufl.sym(ufl.grad(u))


def sigma(
    u: ufl.core.expr.Expr, mu: float | ufl.core.expr.Expr, lmbda: float | ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """Cauchy stress of isotropic linear elasticity (the Lamé operator in weak form)."""
    return 2.0 * mu * epsilon(u) + lmbda * ufl.tr(epsilon(u)) * ufl.Identity(len(u))


def rigid_body_modes(V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
    """The six rigid-body modes of V as an orthonormal PETSc near-nullspace (for GAMG)."""
    imap = V.dofmap.index_map
    bs = V.dofmap.index_map_bs
    length = imap.size_local * bs
    basis = [dolfinx.la.vector(imap, bs=bs, dtype=PETSc.ScalarType) for _ in range(6)]
    b = [np.asarray(v.array) for v in basis]
    dofs = [V.sub(i).dofmap.list.flatten() for i in range(3)]
    for i in range(3):
        b[i][dofs[i]] = 1.0
    x = V.tabulate_dof_coordinates()
    dofs_block = V.dofmap.list.flatten()
    x0, x1, x2 = x[dofs_block, 0], x[dofs_block, 1], x[dofs_block, 2]
    b[3][dofs[0]] = -x1
    b[3][dofs[1]] = x0
    b[4][dofs[0]] = x2
    b[4][dofs[2]] = -x0
    b[5][dofs[2]] = x1
    b[5][dofs[1]] = -x2
    dolfinx.la.orthonormalize(basis)
    vecs = [PETSc.Vec().createWithArray(v[:length], bsize=bs, comm=V.mesh.comm) for v in b]
    return PETSc.NullSpace().create(vectors=vecs)


class ContactModel:
    """The algebraic contact problem (A, l, d, Q) of Section 6 on a body, with PETSc storage.

    Owns the stiffness matrix ``A`` and the vectors ``load`` (l̃), ``shift`` (d) and ``rhs`` (l = l̃ + A d).
    Call :meth:`destroy` when done (the PETSc objects are collective).

    Args:
        body: Mesh with tagged boundaries.
        material: Elastic constants.
        friction: Coulomb coefficient F.
        tractions: Surface tractions (GPa) per boundary name.
        body_force: Volume force density (GPa per length unit).
        jit_options: Options for FFCx just-in-time compilation.
    """

    def __init__(
        self,
        body: Body,
        material: Material,
        friction: float,
        tractions: dict[str, tuple[float, float, float]],
        body_force: tuple[float, float, float] = (0.0, 0.0, 0.0),
        jit_options: dict | None = None,
    ) -> None:
        comm = body.mesh.comm
        # Validate everything before the first collective call: all ranks hold the same values.
        material.validate()
        validate_friction(friction)
        validate_tractions(tractions, body)
        if not np.all(np.isfinite(body_force)):
            raise InputError(f"body force {body_force!r}: must be finite")
        dirichlet_tags = [body.tag(name) for name in body.dirichlet]
        contact_tags = [body.tag(name) for name in body.contact]

        self.body = body
        self.material = material
        self.friction = float(friction)
        self.tractions = {k: tuple(float(c) for c in v) for k, v in tractions.items()}
        self.body_force = tuple(float(c) for c in body_force)
        msh = body.mesh
        V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (msh.geometry.dim,)))
        self.V = V

        # Boundary conditions: clamp the Dirichlet boundaries (u = 0).
        fdim = msh.topology.dim - 1
        clamped_facets = np.hstack([body.facet_tags.find(t) for t in dirichlet_tags]).astype(np.int32)
        clamped = dolfinx.fem.locate_dofs_topological(V, fdim, clamped_facets)
        num_clamped = comm.allreduce(int(np.sum(clamped < V.dofmap.index_map.size_local)), op=MPI.SUM)
        check_all(comm, num_clamped > 0, f"the clamped boundary {body.dirichlet} has no nodes")
        self.bc = dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), clamped, V)

        mu, lmbda = material.lame
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        ds = ufl.Measure("ds", domain=msh, subdomain_data=body.facet_tags)
        self._mu = dolfinx.fem.Constant(msh, PETSc.ScalarType(mu))
        self._lmbda = dolfinx.fem.Constant(msh, PETSc.ScalarType(lmbda))
        f = dolfinx.fem.Constant(msh, np.asarray(body_force, dtype=PETSc.ScalarType))
        L = ufl.inner(f, v) * ufl.dx
        for name, value in self.tractions.items():
            P = dolfinx.fem.Constant(msh, np.asarray(value, dtype=PETSc.ScalarType))
            L = L + ufl.inner(P, v) * ds(body.tag(name))
        # 2×2×2 Gauss points (degree 2), the standard rule for trilinear hexahedra and exact for linear
        # tetrahedra; UFL's estimate for the non-affine hexahedra of Ω(d) would be far more expensive.
        dx = ufl.Measure("dx", domain=msh, metadata={"quadrature_degree": 2})
        self.a_ufl = ufl.inner(sigma(u, self._mu, self._lmbda), epsilon(v)) * dx
        self.L_ufl = L
        self.a = dolfinx.fem.form(self.a_ufl, jit_options=jit_options)
        self.L = dolfinx.fem.form(L, jit_options=jit_options)

        # Stiffness with the clamped rows/columns replaced by a scaled identity.
        self.A = dolfinx.fem.petsc.assemble_matrix(self.a, bcs=[self.bc])
        self.A.assemble()
        self.A.setOptionsPrefix("coulomb_A_")
        self._scale_dirichlet_rows(clamped)

        # Load vector l̃, ghost-aware: assemble the cell/facet contributions, lift the (zero) Dirichlet
        # values into the right-hand side, add the ghost contributions to their owners (reverse
        # scatter), then set the Dirichlet entries.
        b = dolfinx.fem.petsc.assemble_vector(self.L)
        dolfinx.fem.petsc.apply_lifting(b, [self.a], bcs=[[self.bc]])
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        dolfinx.fem.petsc.set_bc(b, [self.bc])
        self.load = self.A.createVecRight()
        b.copy(self.load)
        b.destroy()

        # Contact nodes and the shift d (normal component α at contact nodes).
        self.contact = ContactMap.create(V, body.facet_tags, contact_tags, dirichlet_tags)
        gap = self.contact.gap
        # round-off below the plane (e.g. from mesh generators) counts as touching
        size = comm.allreduce(float(np.abs(msh.geometry.x).max(initial=0.0)), op=MPI.MAX)
        gap[(gap < 0.0) & (gap > -1e-12 * size)] = 0.0
        bad = gap < 0.0
        check_all(
            comm,
            not np.any(bad),
            f"contact node at height {gap[bad][0] if np.any(bad) else 0.0!r} lies inside the obstacle "
            "x3 <= 0 (initial penetration is not supported)",
        )
        self.shift = self.A.createVecRight()
        self.shift.set(0.0)
        self.shift.array[self.contact.local_dofs[:, 2]] = gap
        # l = l̃ + A d (see the module docstring for the derivation).
        self.rhs = self.A.createVecRight()
        self.A.mult(self.shift, self.rhs)
        self.rhs.axpy(1.0, self.load)

        imap = V.dofmap.index_map
        self.num_dofs_global = imap.size_global * 3
        self.num_clamped_global = num_clamped * 3
        #: n of the paper: unknowns after removing the Dirichlet DOFs.
        self.n = self.num_dofs_global - self.num_clamped_global
        #: p of the paper: number of contact nodes.
        self.p = self.contact.num_global

    def _scale_dirichlet_rows(self, clamped_blocks: npt.NDArray[np.int32]) -> None:
        """Set the clamped rows' diagonal to the mean diagonal of the free rows (scale-free γ and PCs)."""
        comm = self.body.mesh.comm
        size_local = self.V.dofmap.index_map.size_local
        blocks = clamped_blocks[clamped_blocks < size_local]
        rows = (3 * blocks[:, None] + np.arange(3)).ravel()
        diag = self.A.getDiagonal()
        values = diag.array
        free = np.ones(values.size, dtype=bool)
        free[rows] = False
        total = comm.allreduce(float(np.sum(values[free])), op=MPI.SUM)
        count = comm.allreduce(int(np.sum(free)), op=MPI.SUM)
        scale = total / max(count, 1)
        values[rows] = scale
        self.A.setDiagonal(diag, addv=PETSc.InsertMode.INSERT_VALUES)
        self.A.assemble()
        diag.destroy()
        self.dirichlet_rows = rows.astype(np.int32)
        self.dirichlet_diagonal = scale

    def total_load(self) -> npt.NDArray[np.float64]:
        """Resultant of the applied tractions and body force (a 3-vector, the same on all ranks)."""
        msh = self.body.mesh
        ds = ufl.Measure("ds", domain=msh, subdomain_data=self.body.facet_tags)
        one = dolfinx.fem.Constant(msh, PETSc.ScalarType(1.0))
        total = np.zeros(3)
        for name, value in self.tractions.items():
            area = dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * ds(self.body.tag(name))))
            total += np.asarray(value) * msh.comm.allreduce(area, op=MPI.SUM)
        volume = msh.comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * ufl.dx)), op=MPI.SUM)
        return total + np.asarray(self.body_force) * volume

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        for obj in (self.A, self.load, self.shift, self.rhs):
            obj.destroy()
