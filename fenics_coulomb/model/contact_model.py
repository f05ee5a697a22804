r"""The discrete contact model of Section 6 built from a user's forms: stiffness, loads and the shift.

Given a bilinear form a (any linear-elastic operator on a vector P1/Q1 space), a linear form L, Dirichlet
conditions, the rigid obstacles and the contact boundary, this assembles the stiffness matrix A, the load
vector l̃, the shift d (dⁱ = Rᵢ sⁱ = gᵢ n − TᵀT δ at contact node i with frame Rᵢ = (t₁, t₂, n), gap gᵢ and
its obstacle's displacement δ; for the default plane (0, 0, αᵢ), αᵢ the height; 0 elsewhere) and
l = l̃ + A d. Why the per-node frames change nothing else: see :mod:`fenics_coulomb.model.obstacles`.

**The shifted load.** The physical displacement ũ solves Definition 6.1. In the shifted unknown u = ũ + d
the problem is the generalized equation (6.3) 0 ∈ A u − l + Q(u), where, substituting ũ = u − d into
½ ũᵀAũ − ⟨l̃, ũ⟩,

    ½ (u − d)ᵀA(u − d) − ⟨l̃, u − d⟩ = ½ uᵀAu − ⟨l̃ + A d, u⟩ + const,

so the shifted load is **l = l̃ + A d** (the paper prints l̃ − A d, a sign slip; with it the residual
A u − l would differ from the physical A ũ − l̃ by 2 A d). Check: A u − l = A ũ + A d − l̃ − A d = A ũ − l̃.

**Dirichlet conditions (lifting).** Split the DOFs into free ones F and prescribed ones D with ũ_D = g
(any values, any single components). The free rows of the physical problem read
K_FF ũ_F + K_FD g − l̃⁰_F + Q_F(ũ) ∋ 0 with the unconstrained stiffness K and load l̃⁰. Eliminating ũ_D:

    A = [[K_FF, 0], [0, s I]],   l̃ = [l̃⁰_F − K_FD g, s g],

so A ũ = l̃ holds in the D rows exactly when ũ_D = g, and the F rows are the physical ones. DOLFINx's
``apply_lifting`` forms l̃⁰ − K_{:,D} g and ``set_bc`` with α = s writes s g into the D rows. The D rows and
columns of A are those of an identity scaled to s = the mean diagonal of the free rows (so that the
spectrum used for γ and the preconditioners is not polluted). The D rows belong to the non-contact block R
of (6.4): contact nodes exclude clamped nodes and have no shift along a held component
(:mod:`fenics_coulomb.model.frames`, "Contact nodes with held components"), so d_D = 0 and (A d)_D = 0.

**One body or two.** The model holds a coupling (:mod:`fenics_coulomb.model.coupling`) that owns every difference
between them: one construction path (:meth:`Coupling.build <fenics_coulomb.model.coupling.Coupling.build>` sets A,
l̃, the contact map and the friction) and one placement path (the obstacles' nodes here, the coupling's own nodes by
:meth:`Coupling.place <fenics_coulomb.model.coupling.Coupling.place>`). With ``contact_pairs`` it is
:class:`~fenics_coulomb.model.pairs.coupling.PairCoupling` (:mod:`fenics_coulomb.model.pairs.two_body`): A is Ã = Mᵀ
A_free M with the same Dirichlet treatment, l̃ = Mᵀ(l − A_free M x_D), the contact nodes are the paired slave nodes
with the pairing's frames and gaps merged with the obstacles' nodes, and the unknown is z (w on the slave nodes);
:meth:`ContactModel.physical` maps it back to u = M z.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import TypeAlias

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.arguments import as_list, check_sliding, function_space, stiffness_rows, validate_arguments
from fenics_coulomb.model.contact_map import ContactMap, held_blocks, hold
from fenics_coulomb.model.coupling import Coupling, IdentityCoupling
from fenics_coulomb.model.forces import block_to_scalar_dofs, boundary_areas
from fenics_coulomb.model.frames import local_shift, to_global
from fenics_coulomb.model.frozen import FrozenInputs
from fenics_coulomb.model.mesh_checks import check_mesh
from fenics_coulomb.model.obstacles import Obstacle, check_obstacle_names
from fenics_coulomb.model.placement import ObstaclePlacement, previous_placements
from fenics_coulomb.model.pairs import ContactPair, Pairing
from fenics_coulomb.model.pairs.coupling import PairCoupling
from fenics_coulomb.settings import COMMAND_PREFIX

__all__ = ["Friction", "ContactModel"]

logger = logging.getLogger(__name__)

Friction: TypeAlias = float | dolfinx.fem.Function

class ContactModel:
    """The algebraic contact problem (A, l̃, d, l, Q) of Section 6, with PETSc storage.

    Owns the stiffness matrix ``A`` (options prefix ``<prefix>A_``) and the vectors ``load`` (l̃), ``shift``
    (d) and ``rhs`` (l = l̃ + A d). Call :meth:`destroy` when done (the PETSc objects are collective).

    Args:
        a: Bilinear UFL form of linear elasticity on a vector P1/Q1 space.
        L: Linear UFL form (tractions, body forces), or None for no load.
        bcs: Dirichlet conditions (any values; single components allowed).
        contact: Facet tags and the markers of the contact boundary.
        friction: Coulomb coefficient F: a number or a scalar field (interpolated at the contact nodes).
        obstacles: The rigid obstacles (default: the plane x3 = 0); each contact node belongs to the one with
            the smallest gap. An obstacle overlapping the body at its scene position is an InputError; one
            whose displacement δ makes it overlap is an indentation.
        prefix: Options prefix of the problem's PETSc objects.
        form_compiler_options: FFCx options.
        jit_options: JIT options.
    """

    def __init__(
        self,
        a: ufl.Form,
        L: ufl.Form | None,
        bcs: Sequence[dolfinx.fem.DirichletBC],
        contact: tuple[dolfinx.mesh.MeshTags, Sequence[int]] | None,
        friction: Friction,
        obstacles: Sequence[Obstacle] | Obstacle | None = None,
        prefix: str = COMMAND_PREFIX,
        form_compiler_options: dict | None = None,
        jit_options: dict | None = None,
        contact_pairs: Sequence[ContactPair] | None = None,
        sliding: str = "finite",
    ) -> None:
        check_sliding(sliding)
        V = function_space(a)
        msh = V.mesh
        comm = msh.comm
        pairs = as_list(contact_pairs, "contact_pairs", ContactPair)
        obstacles = as_list(obstacles, "obstacles", Obstacle)
        validate_arguments(V, L, bcs, contact, friction, pairs)
        check_mesh(msh)
        self.V = V
        self.comm = comm
        self.bcs = list(bcs)
        #: The contact pairs (two bodies), in the order given.
        self.pairs = pairs
        #: Everything in which one body differs from two: the identity for one body,
        #: :class:`~fenics_coulomb.model.pairs.coupling.PairCoupling` (u = M z) for contact pairs.
        self.coupling: Coupling = PairCoupling(pairs) if pairs else IdentityCoupling()
        #: The PETSc options prefix of every object the model creates.
        self.prefix = prefix
        #: "finite" (the contact geometry follows the deformation, :meth:`configure`) or "small" (reference).
        self.sliding = sliding
        #: The configuration the contact geometry is evaluated in: the physical displacement u of every local
        #: DOF (owned and ghost; None: the reference configuration X).
        self.configuration: npt.NDArray[np.float64] | None = None
        self._ghosted: dolfinx.fem.Function | None = None
        # the contact boundary (nodal areas, figures) and the boundary of the obstacles' contact nodes
        facet_tags, markers, obstacle_contact = self.coupling.boundary(self, contact, obstacles)
        self.facet_tags = facet_tags
        self.markers = [int(m) for m in markers]
        self.obstacles: list[Obstacle] = obstacles if obstacles else self.coupling.default_obstacles()
        # Validate everything before the first collective call: all ranks hold the same values.
        bad_obstacles = [o for o in self.obstacles if not isinstance(o, Obstacle)]
        if bad_obstacles:
            raise InputError(f"obstacles: {bad_obstacles[0]!r} is not a Plane, Sphere or Cylinder")
        check_obstacle_names(self.obstacles, reserved=[q.name if (q.name or "").startswith("pair ") else
                                                       f"pair {q.name or k + 1}" for k, q in enumerate(pairs)])
        if L is None:
            v = a.arguments()[0]
            L = ufl.inner(dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType)), v) * ufl.dx
        self.a_ufl, self.L_ufl = a, L
        self.frozen = FrozenInputs(a, friction)  # read once: a changed value is refused at the next solve
        self.a = dolfinx.fem.form(a, form_compiler_options=form_compiler_options, jit_options=jit_options)
        self.L = dolfinx.fem.form(L, form_compiler_options=form_compiler_options, jit_options=jit_options)

        # Dirichlet DOFs (local, unrolled; owned and ghost) and the nodes they touch.
        size_local = V.dofmap.index_map.size_local
        dofs = [bc.dof_indices()[0] for bc in self.bcs]
        dirichlet = np.unique(np.concatenate(dofs)).astype(np.int32) if dofs else np.zeros(0, np.int32)
        owned = dirichlet[dirichlet < 3 * size_local]
        num_dirichlet = comm.allreduce(int(owned.size), op=MPI.SUM)

        self.mesh_size = comm.allreduce(float(np.abs(msh.geometry.x).max(initial=0.0)), op=MPI.MAX)
        self.dirichlet_rows = owned
        #: Which Cartesian components a Dirichlet condition holds at every local DOF block, shape (blocks, 3).
        self.held = held_blocks(V, dirichlet)
        #: The local DOF blocks with all three components held (never contact nodes).
        self._clamped = np.flatnonzero(self.held.all(axis=1)).astype(np.int32)
        # l̃ and A: assembled by the coupling's build just below (None until then: destroy() after a failed build)
        self.load: PETSc.Vec = None
        self.A: PETSc.Mat = None
        #: The contact map, the friction (per contact node, or one number), the Dirichlet rows' diagonal s.
        self.contact: ContactMap
        self.friction: float | npt.NDArray[np.float64]
        self.dirichlet_diagonal: float
        # the stiffness, the load, the contact map and the friction per node: the coupling's (collective)
        self.coupling.build(self, obstacle_contact, friction)
        #: The obstacles' side of every placement: its checks, the contact nodes' closest obstacles.
        self.placement = ObstaclePlacement(msh, self.obstacles, self.mesh_size)
        self.shift = self.A.createVecRight()
        self.shift.setOptionsPrefix(f"{prefix}shift_")
        self.rhs = self.A.createVecRight()
        self.rhs.setOptionsPrefix(f"{prefix}rhs_")
        self.place(self.obstacles)

        imap = V.dofmap.index_map
        self.num_dofs_global = imap.size_global * 3
        self.num_clamped_global = num_dirichlet
        #: n of the paper: unknowns after removing the Dirichlet DOFs.
        self.n = self.num_dofs_global - num_dirichlet
        self.p = self.contact.num_global  # p of the paper: the number of contact nodes

    def not_contact(self) -> npt.NDArray[np.int32]:
        """The local DOF blocks that are never contact nodes of an obstacle: clamped (three held components) or held
        at a non-zero value in some component (driven along the contact by their support; the values as
        :meth:`assemble_load` read them)."""
        values = np.zeros(self.held.size)
        values[self.dirichlet_rows] = self._prescribed_values()
        driven = np.flatnonzero(np.any(values.reshape(-1, 3) != 0.0, axis=1))
        return np.union1d(self._clamped, driven).astype(np.int32)

    def _held_slip(self, offset: npt.NDArray[np.float64]) -> None:
        """InputError on every rank (collective) naming the first contact node that slips along a held component:
        held value g_h minus the tangential offset o_h (:mod:`fenics_coulomb.model.frames`)."""
        cmap = self.contact
        if cmap.held is None or not self.comm.allreduce(bool(np.any(cmap.held)), op=MPI.LOR):
            return
        values = np.zeros(3 * self.V.dofmap.index_map.size_local)
        values[self.dirichlet_rows] = self.dirichlet_values
        slip = np.where(cmap.held, values[cmap.local_dofs] - offset, 0.0)
        bad = np.flatnonzero(np.any(np.abs(slip) > 1e-12 * max(self.mesh_size, np.finfo(float).tiny), axis=1))
        message = ""
        if bad.size:
            i = int(bad[0])
            where = "(" + ", ".join(f"{c:.6g}" for c in cmap.coordinates[i]) + ")"
            message = (f"contact node at {where}: its support holds component(s) "
                       f"{', '.join(f'x{k + 1}' for k in np.flatnonzero(cmap.held[i]))} while it slips along them by "
                       f"({', '.join(f'{c:.4g}' for c in slip[i])}) against its obstacle (a support moving it along "
                       "the contact, or an obstacle moved along a symmetry plane's normal): the friction of that slip "
                       "is not modelled; leave the node out of the support")
        first = next((m for m in self.comm.allgather(message) if m), "")
        check_all(self.comm, not first, first)

    # -- the configuration (finite sliding) --------------------------------------------------------
    def elastic_energy(self, u: npt.NDArray[np.float64]) -> float:
        """½ uᵀ K u of the physical displacement of the owned DOFs (K: A_free for contact pairs, else A; the same on
        every rank; collective). Invariant under rigid motions of the bodies (pairs) and independent of the mesh's
        numbering and partition up to round-off."""
        K = self.coupling.energy_matrix(self)
        x, y = K.createVecs()
        x.array[:] = np.asarray(u, dtype=np.float64)[:x.getLocalSize()]
        K.mult(x, y)
        energy = 0.5 * x.dot(y)
        x.destroy()
        y.destroy()
        return float(energy)

    @property
    def scalar_space(self) -> dolfinx.fem.FunctionSpace:
        """The scalar P1 space on the mesh (the nodal output fields, the lumped areas), created once."""
        if getattr(self, "_scalar_space", None) is None:
            self._scalar_space = dolfinx.fem.functionspace(self.V.mesh, ("Lagrange", 1))
        return self._scalar_space

    @property
    def boundary_areas(self) -> npt.NDArray[np.float64]:
        """∫ φᵢ ds over the contact boundary (the facets of :attr:`markers`) at each local DOF block, owned blocks
        (0 at ghosts; :func:`~fenics_coulomb.model.forces.boundary_areas`), assembled once: the mesh, its tags and
        the markers never change in a model's life (collective the first time)."""
        if getattr(self, "_boundary_areas", None) is None:
            self._boundary_areas = boundary_areas(self.V, self.scalar_space, self.facet_tags, list(self.markers))
        return self._boundary_areas

    def node_size(self) -> npt.NDArray[np.float64]:
        """The largest diameter of the cells at each local DOF block (owned and ghost), computed once."""
        if getattr(self, "_node_size", None) is None:
            msh = self.V.mesh
            tdim = msh.topology.dim
            imap = msh.topology.index_map(tdim)
            cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
            h = msh.h(tdim, cells)
            size = np.zeros(self.V.dofmap.index_map.size_local + self.V.dofmap.index_map.num_ghosts)
            dofs = self.V.dofmap.list
            np.maximum.at(size, dofs.ravel(), np.repeat(h, dofs.shape[1]))
            self._node_size = size
        return self._node_size

    def ghosted(self, u: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """The owned DOF values ``u`` with their ghosts (collective)."""
        if self._ghosted is None:
            self._ghosted = dolfinx.fem.Function(self.V)
        f = self._ghosted
        n = 3 * self.V.dofmap.index_map.size_local
        f.x.array[:n] = np.asarray(u, dtype=np.float64).reshape(-1)[:n]
        f.x.scatter_forward()
        return np.array(f.x.array, dtype=np.float64)

    def pair_in(self, u: npt.ArrayLike | None, resolution: float = 0.0) -> Pairing | None:
        """The pairing of the configuration X + u (``u`` the physical displacement of the owned DOFs; None:
        the reference configuration) known to ``resolution`` (its own displacement error, a length), or None
        without contact pairs (collective)."""
        return self.coupling.pair_in(self, u, resolution)

    def configure(self, u: npt.ArrayLike | None, pairing: Pairing | None = None, resolution: float = 0.0) -> bool:
        """Evaluate the contact geometry in the configuration X + u from now on (finite sliding; collective).

        The obstacles' gaps, normals and frames follow at the next :meth:`place`; contact pairs are paired again
        in X + u (``pairing``, if already computed by :meth:`pair_in` for the same ``u``) and M, Ã, l̃ and the
        contact map rebuilt.

        Args:
            u: The physical displacement of the owned DOFs; None for the reference configuration.
            pairing: The pairing of X + u, when known.
            resolution: The displacement error of ``u`` (a length; 0: exact): the pairing's and the ties' own.

        Returns:
            Whether Ã and the contact nodes were rebuilt (contact pairs): a solver built on the old ones must be
            rebuilt.
        """
        self.configuration = None if u is None else self.ghosted(u)
        self.placement.resolution = 0.0 if u is None else resolution  # the obstacles' ties, at the next place
        return self.coupling.configure(self, u, pairing, resolution)

    def near_nullspace(self) -> PETSc.NullSpace:
        """The near-nullspace for GAMG: the rigid modes of V, or (I − Φ) r_b per body for two bodies."""
        return self.coupling.near_nullspace(self.V)

    def variables(self) -> PETSc.Mat | None:
        """M of the physical displacement u = M z in the solver's unknown z at the current geometry (None: u = z,
        one body)."""
        return self.coupling.variables()

    def physical_stiffness(self) -> PETSc.Mat | None:
        """The bodies' stiffness B in u with the supports of the unknown, Ã ≈ Mᵀ B M, the same for every geometry
        (None for one body; owned by the model; collective the first time)."""
        return self.coupling.physical_stiffness(self)

    def gamg_stiffness(self) -> PETSc.Mat:
        """The matrix GAMG on the stiffness builds its hierarchy from: A, or a copy of it made non-singular for a
        body held by contact alone (owned by the coupling; collective the first time)."""
        return self.coupling.gamg_stiffness(self)

    @property
    def A_free(self) -> PETSc.Mat | None:
        """Two bodies: the stiffness without boundary conditions (None for one body)."""
        return self.coupling.A_free

    @property
    def pairing(self) -> Pairing | None:
        """The pairing of the contact pairs (None for one body)."""
        return self.coupling.pairing

    @property
    def num_bodies(self) -> int:
        """The number of elastic bodies the coupling knows (1 for one body)."""
        return self.coupling.num_bodies

    @property
    def body_of_block(self) -> npt.NDArray[np.int64] | None:
        """The body of every local DOF block (None for one body)."""
        return self.coupling.body_of_block

    def physical(self, z: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """u = M z on the owned DOFs (the identity for one body; collective for two)."""
        return self.coupling.physical(z)

    def free_slave_penetrations(self, u: npt.NDArray[np.float64], tol: float = 1e-8) -> int:
        """The number of free slave nodes (over a master surface, but not contact nodes) whose linearized gap is
        below −tol × the mesh size, on all ranks (collective; 0 for one body)."""
        return self.coupling.free_slave_penetrations(self, u, tol)

    def relative(self, u: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """z = M⁻¹ u = (I − Φ) u = 2u − M u on the owned DOFs (the identity for one body; collective for two)."""
        return self.coupling.relative(u)

    def master_forces(self, contact_force: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The reaction on the master nodes, f_j = −Σ_s φ_sj f_s, on the owned DOFs (collective; two bodies).

        Args:
            contact_force: Cartesian force on each owned slave contact node, shape (m, 3).
        """
        forces = self.coupling.master_forces(contact_force, self.contact.local_dofs)
        assert forces is not None, "master forces exist for contact pairs only"
        return forces

    def assemble_load(self) -> None:
        """(Re-)assemble l̃ from the current values of L's coefficients and of the Dirichlet values (collective).

        Assemble, lift the Dirichlet values into the right-hand side, add the ghost contributions to their
        owners (reverse scatter), then set the Dirichlet rows to s g (see the module docstring). Call
        :meth:`place` afterwards to update l = l̃ + A d. InputError if the stiffness or friction changed.
        """
        self.frozen.check(self.comm)
        self.dirichlet_values = self._prescribed_values()
        self.coupling.assemble_load(self)

    def _prescribed_values(self) -> npt.NDArray[np.float64]:
        """The Dirichlet values g of the owned Dirichlet rows, as the boundary conditions set them (bit for bit)."""
        g = dolfinx.fem.Function(self.V)
        g.x.array[:] = 0.0
        for bc in self.bcs:
            bc.set(g.x.array)
        return np.array(g.x.array[self.dirichlet_rows], dtype=np.float64)

    def place(
        self,
        obstacles: Sequence[Obstacle],
        previous_displacement: npt.NDArray[np.float64] | None = None,
        previous_obstacle_displacements: npt.ArrayLike | Sequence[Obstacle] | None = None,
    ) -> None:
        """Place the obstacles at their displacements and set the shift d and l = l̃ + A d (collective).

        The frames, gaps and obstacle of every contact node are those of the placed obstacles. The local shift
        is sⁱ = (−T o, g) with the tangential offset o = ũ_{k−1} + δ_k − δ_{k−1} of a load path's step k
        (:mod:`fenics_coulomb.scenes.path` semantics: the slip is the increment T(ũ_k − ũ_{k−1}) − T(δ_k − δ_{k−1}));
        without a previous step o = δ_k, the static problem.

        Args:
            obstacles: The obstacles (the same kinds and geometry as at construction; only their displacements
                may differ).
            previous_displacement: ũ_{k−1} at the owned contact nodes, Cartesian, shape (m, 3); None for 0.
            previous_obstacle_displacements: δ_{k−1} per obstacle, shape (number of obstacles, 3); None for 0.
        """
        obstacles = list(obstacles)
        self.placement.check_motion(obstacles, previous_obstacle_displacements,
                                    None if self.configuration is None else (self.V, self.configuration))
        if len(obstacles) != len(self.obstacles) or any(
                o._at_rest() != p._at_rest() for o, p in zip(obstacles, self.obstacles)):
            raise InputError("obstacles: a placement may only change the obstacles' displacements and rotations")
        self.obstacles = obstacles
        if hasattr(self, "dirichlet_values"):  # the supports' values as assemble_load read them
            self.placement.check_supported(obstacles, self.V, self.facet_tags, self.markers, self.held,
                                           self.dirichlet_rows, self.dirichlet_values)
        previous_obstacles = previous_placements(obstacles, previous_obstacle_displacements)
        previous_deltas: npt.ArrayLike | None
        if isinstance(previous_obstacle_displacements, Sequence) and len(previous_obstacle_displacements) and \
                all(isinstance(o, Obstacle) for o in previous_obstacle_displacements):
            previous_deltas = [o.displacement for o in previous_obstacle_displacements
                               if isinstance(o, Obstacle)]
        else:
            previous_deltas = previous_obstacle_displacements  # type: ignore[assignment]
        cmap = self.contact
        rigid = np.flatnonzero(~self.coupling.paired_mask(cmap.size))
        offset: npt.NDArray[np.float64] = np.zeros((cmap.size, 3))
        #: Cartesian displacement δ of each contact node's obstacle, shape (m, 3).
        self.obstacle_displacement = np.zeros((cmap.size, 3))
        self.placement.place(cmap, rigid, obstacles, self.configuration, previous_displacement, previous_obstacles,
                             previous_deltas, offset, self.obstacle_displacement)
        if cmap.held is not None:  # held components tangential to the contact (collective)
            cmap.frames[rigid] = hold(cmap.frames[rigid], cmap.held[rigid], cmap.coordinates[rigid], self.comm)
        self.coupling.place(self)  # the coupling's own nodes' gaps (contact pairs)
        if previous_displacement is not None:
            offset = offset + np.asarray(previous_displacement, dtype=np.float64).reshape(-1, 3)
        if cmap.held is not None:  # no offset along a held direction: d_D = 0 (:mod:`fenics_coulomb.model.frames`)
            self._held_slip(offset)
            offset = np.where(cmap.held, 0.0, offset)
        #: The tangential offset o of every contact node (the slip is T(ũ − o)), shape (m, 3).
        self.offset = offset
        #: The constant part sⁱ = (−T o, g) of the local block vⁱ = Rᵢᵀũⁱ + sⁱ, shape (m, 3).
        self.local_shift = local_shift(cmap.frames, cmap.gap, offset)
        self.shift.set(0.0)
        self.shift.array[cmap.local_dofs] = to_global(cmap.frames, self.local_shift)
        # l = l̃ + A d (see the module docstring for the derivation).
        self.A.mult(self.shift, self.rhs)
        self.rhs.axpy(1.0, self.load)

    def closest(self, obstacles: Sequence[Obstacle], x: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.intp],
                npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The closest obstacle of the points ``x`` (:meth:`ObstaclePlacement.closest`, remembered)."""
        return self.placement.closest(obstacles, x)

    def friction_at_nodes(self, friction: Friction, blocks: npt.NDArray[np.int32] | None = None
                                   ) -> float | npt.NDArray[np.float64]:
        """F as a number, or its values at the owned contact nodes (``blocks``, default the contact map's) for a
        field (validated on all ranks)."""
        if not isinstance(friction, dolfinx.fem.Function):
            return float(friction) if blocks is None else np.full(np.size(blocks), float(friction))
        S = self.scalar_space
        values = dolfinx.fem.Function(S)
        values.interpolate(friction)
        to_scalar = block_to_scalar_dofs(self.V, S)
        F = np.ascontiguousarray(values.x.array[to_scalar[self.contact.blocks if blocks is None else blocks]],
                                 dtype=np.float64)
        bad = ~(np.isfinite(F) & (F >= 0.0))
        check_all(self.comm, not np.any(bad), f"friction field value {F[bad][0] if np.any(bad) else 0.0!r} at "
                  "a contact node: must be finite and >= 0")
        return F

    def scale_dirichlet_rows(self, rows: npt.NDArray[np.int32]) -> float:
        """Set the Dirichlet rows' diagonal to the mean diagonal of the free rows (scale-free γ and PCs)."""
        diag = self.A.getDiagonal()
        values = diag.array
        free = np.ones(values.size, dtype=bool)
        free[rows] = False
        check_all(self.comm, *stiffness_rows(self.V, values, free))
        total = self.comm.allreduce(float(np.sum(values[free])), op=MPI.SUM)
        count = self.comm.allreduce(int(np.sum(free)), op=MPI.SUM)
        scale = total / max(count, 1)
        values[rows] = scale
        self.A.setDiagonal(diag, addv=PETSc.InsertMode.INSERT_VALUES)
        self.A.assemble()
        diag.destroy()
        return scale

    def owned_load(self) -> npt.NDArray[np.float64]:
        """L assembled without boundary conditions, completed on the owners, shape (owned nodes, 3) (collective)."""
        b = dolfinx.fem.petsc.assemble_vector(self.L)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        owned = b.getArray(readonly=True).reshape(-1, 3).copy()
        b.destroy()
        return owned

    def total_load(self, owned: npt.NDArray[np.float64] | None = None) -> npt.NDArray[np.float64]:
        """Resultant of the applied load L (the same on all ranks): L applied to the three unit translations, which
        the P1/Q1 basis sums to. ``owned``: :meth:`owned_load` when the caller has it (collective)."""
        return np.asarray(self.comm.allreduce((self.owned_load() if owned is None else owned).sum(axis=0), op=MPI.SUM))

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        for obj in (self.A, self.load, self.shift, self.rhs):
            if obj is not None:
                obj.destroy()
        self.coupling.destroy()
