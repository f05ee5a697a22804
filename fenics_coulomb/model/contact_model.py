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

**Two bodies (contact pairs).** With ``contact_pairs`` the model is that of :mod:`fenics_coulomb.model.pairs.two_body`:
A is Ã = Mᵀ A_free M with the same Dirichlet treatment, l̃ = Mᵀ(l − A_free M x_D), the contact nodes are the
paired slave nodes with the pairing's frames and gaps, and the unknown is z (w on the slave nodes);
:meth:`ContactModel.physical` maps it back to u = M z.

Size: about 600 lines, a sixth of them the derivations above (shifted load, lifting, two bodies); the rest is
the one concept of an assembled contact model with its validation. The coupling of two bodies lives in
:mod:`fenics_coulomb.model.coupling`.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.contact_map import ContactMap, held_blocks, hold
from fenics_coulomb.model.coupling import Coupling, IdentityCoupling, PairCoupling
from fenics_coulomb.model.frames import PAIR_HELD_NORMAL_TOL, held_frames, local_shift, to_global
from fenics_coulomb.model.mesh_checks import BodyLocator, check_mesh
from fenics_coulomb.model.obstacles import DEFAULT_PLANE, Obstacle, check_not_overlapping, closest_obstacle, core_path
from fenics_coulomb.model.pairs import ContactPair, Pairing, pair_surfaces
from fenics_coulomb.model.pairs.two_body import check_rigid_support, connected_bodies, coupling_matrix
from fenics_coulomb.settings import COMMAND_PREFIX

__all__ = ["SLIDING", "validate_friction", "validate_arguments", "function_space", "ContactModel"]

logger = logging.getLogger(__name__)

Friction = float | dolfinx.fem.Function

#: The sliding models: "finite" evaluates the contact geometry in the deformed configuration X + u
#: (:meth:`ContactModel.configure`), "small" once in the reference configuration X.
SLIDING = ("finite", "small")


def validate_friction(friction: float) -> None:
    """Raise InputError unless 0 <= F < inf."""
    if isinstance(friction, bool) or not isinstance(friction, int | float) or not (
            np.isfinite(friction) and friction >= 0.0):
        raise InputError(f"friction coefficient F = {friction!r}: must be finite and >= 0")


def _cpp(obj: object) -> object:
    """The C++ object behind a DOLFINx Python wrapper (itself if it is one): identity comparisons of meshes."""
    return getattr(obj, "_cpp_object", obj)


def _same_mesh(mesh: object, msh: dolfinx.mesh.Mesh) -> bool:
    return _cpp(mesh) is _cpp(msh)


def validate_arguments(V: dolfinx.fem.FunctionSpace, L: ufl.Form | None, bcs: Sequence[object],
                       contact: object, friction: object) -> None:
    """InputError naming the argument of :class:`ContactModel` that does not belong to V's mesh or has the wrong
    kind (pure: the same on every rank, before any collective call). A friction Function on another mesh used to
    end in a segmentation fault; facet tags of another mesh, cell tags, a boundary condition of another space were
    accepted and built a wrong model."""
    msh = V.mesh
    fdim = msh.topology.dim - 1
    if L is not None:
        if not isinstance(L, ufl.Form) or len(L.arguments()) != 1:
            raise InputError(f"L: {type(L).__name__} is not a linear UFL form (or None)")
        test = L.arguments()[0].ufl_function_space()
        if not _same_mesh(getattr(test, "mesh", None), msh):
            raise InputError("L: its test function lives on another mesh than the bilinear form's")
    for i, bc in enumerate(bcs):
        if not isinstance(bc, dolfinx.fem.DirichletBC):
            raise InputError(f"bcs[{i}]: {type(bc).__name__} is not a dolfinx.fem.DirichletBC")
        space = bc.function_space
        if not _same_mesh(space.mesh, msh) or space.dofmap.index_map_bs != V.dofmap.index_map_bs or \
                space.dofmap.index_map.size_global != V.dofmap.index_map.size_global:
            raise InputError(f"bcs[{i}]: a boundary condition of another function space (give it V or V.sub(i) of "
                             "the bilinear form's space, not a collapsed or foreign space)")
    if contact is not None:
        if not (isinstance(contact, tuple | list) and len(contact) == 2):
            raise InputError(f"contact = {type(contact).__name__}: give (facet_tags, markers)")
        tags, markers = contact
        if not isinstance(tags, dolfinx.mesh.MeshTags):
            raise InputError(f"contact: {type(tags).__name__} is not dolfinx MeshTags of facets")
        if tags.dim != fdim:
            raise InputError(f"contact: mesh tags of dimension {tags.dim} (cells or edges?): the contact boundary "
                             f"needs facet tags (dimension {fdim})")
        if _cpp(tags.topology) is not _cpp(msh.topology):
            raise InputError("contact: the facet tags belong to another mesh than the bilinear form's")
        values = list(markers) if isinstance(markers, list | tuple | np.ndarray) else [markers]
        if any(isinstance(m, bool) or not isinstance(m, int | np.integer) for m in values):
            raise InputError(f"contact: markers {markers!r} must be a list of integer tag values (empty: no contact "
                             "boundary)")
    if isinstance(friction, dolfinx.fem.Function):
        if not _same_mesh(friction.function_space.mesh, msh):
            raise InputError("friction: the friction Function lives on another mesh than the bilinear form's")
        if friction.function_space.dofmap.index_map_bs * friction.function_space.dofmap.bs != 1 and \
                friction.ufl_shape != ():
            raise InputError("friction: the friction Function must be scalar")


def function_space(a: ufl.Form) -> dolfinx.fem.FunctionSpace:
    """The trial space of ``a``; raise InputError unless it is a 3D vector P1/Q1 space."""
    if not isinstance(a, ufl.Form) or len(a.arguments()) != 2:
        raise InputError(f"a: {type(a).__name__} is not a bilinear UFL form")
    V = a.arguments()[-1].ufl_function_space()
    if not isinstance(V, dolfinx.fem.FunctionSpace):
        raise InputError("the bilinear form must be defined on a dolfinx.fem.FunctionSpace")
    topology = V.mesh.topology
    vertices = dolfinx.cpp.mesh.cell_num_vertices(topology.cell_type)
    if V.dofmap.index_map_bs != 3 or V.mesh.geometry.dim != 3 or V.dofmap.dof_layout.num_dofs != vertices:
        raise InputError(f"the contact solver needs a 3D vector P1/Q1 space (block size 3, one node per vertex); "
                         f"got block size {V.dofmap.index_map_bs} with {V.dofmap.dof_layout.num_dofs} nodes "
                         f"per {topology.cell_type.name}")
    return V



def _previous_placements(obstacles: Sequence[Obstacle], previous: npt.ArrayLike | Sequence[Obstacle] | None
                         ) -> list[Obstacle] | None:
    """The previous placements of the obstacles when a rotation is involved (now or then), else None (the
    translation-only offsets δ_k − δ_{k−1} apply, bit for bit): ``previous`` is None (the scene position), the
    previous δ per obstacle (no rotation then), or the previous obstacles themselves."""
    if previous is not None and len(previous) and isinstance(previous[0], Obstacle):
        before = list(previous)  # type: ignore[arg-type]
    elif previous is None:
        before = [o.at_scene_position().rotated(None) for o in obstacles]
    else:
        deltas = np.asarray(previous, dtype=np.float64).reshape(-1, 3)
        before = [o.moved(d).rotated(None) for o, d in zip(obstacles, deltas, strict=True)]
    rotating = any(getattr(o, "rotation", None) is not None for o in [*obstacles, *before])
    return before if rotating else None



def _same_placements(a: tuple, b: tuple) -> bool:
    """Whether two (obstacles, previous placements) keys of :meth:`ContactModel.check_motion` are the same
    placements: the same obstacle objects (placed obstacles are immutable; a move makes new ones) and the same
    previous obstacles or displacements."""
    def same(x: Any, y: Any) -> bool:
        if x is None or y is None or isinstance(x, bytes) or isinstance(y, bytes):
            return x == y
        return len(x) == len(y) and all(p is q for p, q in zip(x, y))
    return same(a[0], b[0]) and same(a[1], b[1])

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
        obstacles: Sequence[Obstacle] | None = None,
        prefix: str = COMMAND_PREFIX,
        form_compiler_options: dict | None = None,
        jit_options: dict | None = None,
        contact_pairs: Sequence[ContactPair] | None = None,
        sliding: str = "finite",
    ) -> None:
        if sliding not in SLIDING:
            raise InputError(f"sliding = {sliding!r}: must be one of {list(SLIDING)}")
        V = function_space(a)
        msh = V.mesh
        comm = msh.comm
        validate_arguments(V, L, bcs, contact, friction)
        check_mesh(msh)
        self.V = V
        self.comm = comm
        self.bcs = list(bcs)
        pairs = list(contact_pairs or [])
        #: The contact pairs (two bodies), in the order given.
        self.pairs = pairs
        #: Two bodies: the pairing (None for one body).
        self.pairing: Pairing | None = None
        #: u = M z: the identity for one body, :class:`~fenics_coulomb.model.coupling.PairCoupling` for two.
        self.coupling: Coupling = IdentityCoupling()
        self._free_coupling: PETSc.Mat | None = None
        #: The PETSc options prefix of every object the model creates.
        self.prefix = prefix
        #: "finite" (the contact geometry follows the deformation, :meth:`configure`) or "small" (reference).
        self.sliding = sliding
        #: The configuration the contact geometry is evaluated in: the physical displacement u of every local
        #: DOF (owned and ghost; None: the reference configuration X).
        self.configuration: npt.NDArray[np.float64] | None = None
        self._closest_cache: tuple | None = None  # (obstacles, points, closest_obstacle's result)
        self._motion_checked: tuple | None = None  # the placements check_motion passed last
        self._material_cache: tuple | None = None  # (obstacle, points, its closest points)
        self._A_free: PETSc.Mat | None = None
        self._ghosted: dolfinx.fem.Function | None = None
        obstacle_contact = None
        if pairs:
            bad = [q for q in pairs if not isinstance(q, ContactPair)]
            if bad:
                raise InputError(f"contact_pairs: {bad[0]!r} is not a ContactPair")
            if obstacles and contact is None:
                raise InputError("obstacles with contact pairs: give the contact boundary of the obstacles too "
                                 "(contact=(facet_tags, markers))")
            obstacle_contact = contact if obstacles else None
            # the slave surfaces (and the obstacles' contact boundary) are the contact boundary (nodal areas of
            # the tractions, figures)
            facet_tags = pairs[0].facet_tags
            markers = sorted({int(t) for q in pairs for t in np.atleast_1d(q.slave)}
                             | ({int(m) for m in obstacle_contact[1]} if obstacle_contact else set()))
        elif contact is None:
            raise InputError("contact: give the facet tags and the markers of the contact boundary")
        else:
            facet_tags, markers = contact
        self.facet_tags = facet_tags
        self.markers = [int(m) for m in markers]
        if not pairs:  # a marker no facet carries makes no contact node at all: a typo, not a body without contact
            counts = comm.allreduce(np.array([facet_tags.find(m).size for m in self.markers], dtype=np.int64),
                                    op=MPI.SUM)
            missing = [m for m, c in zip(self.markers, counts, strict=True) if c == 0]
            values = sorted(set().union(*comm.allgather({int(v) for v in np.unique(facet_tags.values)}))) \
                if missing else []  # every rank's values (missing is global: all ranks gather or none)
            check_all(comm, not missing, f"contact: marker {missing[0] if missing else 0} is carried by no facet of "
                      f"the facet tags (their values: {values})")
        if isinstance(obstacles, Obstacle):
            obstacles = [obstacles]
        self.obstacles: list[Obstacle] = list(obstacles) if obstacles else ([] if pairs else [DEFAULT_PLANE])
        # Validate everything before the first collective call: all ranks hold the same values.
        bad_obstacles = [o for o in self.obstacles if not isinstance(o, Obstacle)]
        if bad_obstacles:
            raise InputError(f"obstacles: {bad_obstacles[0]!r} is not a Plane, Sphere or Cylinder")
        if not isinstance(friction, dolfinx.fem.Function):
            validate_friction(friction)
        if L is None:
            v = a.arguments()[0]
            L = ufl.inner(dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType)), v) * ufl.dx
        self.a_ufl = a
        self.L_ufl = L
        self.a = dolfinx.fem.form(a, form_compiler_options=form_compiler_options, jit_options=jit_options)
        self.L = dolfinx.fem.form(L, form_compiler_options=form_compiler_options, jit_options=jit_options)

        # Dirichlet DOFs (local, unrolled; owned and ghost) and the nodes they touch.
        size_local = V.dofmap.index_map.size_local
        dofs = [bc.dof_indices()[0] for bc in self.bcs]
        dirichlet = np.unique(np.concatenate(dofs)).astype(np.int32) if dofs else np.zeros(0, np.int32)
        owned = dirichlet[dirichlet < 3 * size_local]
        num_dirichlet = comm.allreduce(int(owned.size), op=MPI.SUM)

        self._size = comm.allreduce(float(np.abs(msh.geometry.x).max(initial=0.0)), op=MPI.MAX)
        self.dirichlet_rows = owned
        #: Which Cartesian components a Dirichlet condition holds at every local DOF block, shape (blocks, 3).
        self._held = held_blocks(V, dirichlet)
        #: The local DOF blocks with all three components held (never contact nodes).
        self._clamped = np.flatnonzero(self._held.all(axis=1)).astype(np.int32)
        self.load = None
        if pairs:
            self._create_two_body(pairs, dirichlet, prefix, obstacle_contact, friction)
        else:
            # Stiffness with the Dirichlet rows/columns replaced by a scaled identity.
            self.A = self.coupling.stiffness(self, prefix)
            self.dirichlet_diagonal = self._scale_dirichlet_rows(owned)
            # Load vector l̃ (see the module docstring) and the contact nodes (no clamped node; held components
            # tangential to the contact, :mod:`fenics_coulomb.model.frames`)
            self.load = self.A.createVecRight()
            self.load.setOptionsPrefix(f"{prefix}load_")
            self.assemble_load()
            self.contact = ContactMap.create(V, facet_tags, self.markers, self._not_contact(), self.obstacles,
                                             held=self._held)
            check_not_overlapping(self.obstacles, self.contact.coordinates, comm=comm)
            self.friction = self._friction_at_contact_nodes(friction)
        #: Where the body is: rejects obstacles buried in it or moved through it (:meth:`check_motion`).
        self._locator = BodyLocator(msh) if any(o.core(np.zeros(3), np.ones(3), 2).size
                                                for o in self.obstacles) else None
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
        #: p of the paper: number of contact nodes.
        self.p = self.contact.num_global

    def _create_two_body(self, pairs: list[ContactPair], dirichlet: npt.NDArray[np.int32], prefix: str,
                         obstacle_contact: tuple[dolfinx.mesh.MeshTags, Sequence[int]] | None = None,
                         friction: Friction = 0.0) -> None:
        """The bodies, their supports, A_free and the obstacles' contact nodes once; then the pairing of the
        reference configuration (:meth:`_pair`; collective)."""
        V, comm = self.V, self.comm
        #: Never slave contact nodes: clamped, or held at a non-zero value (:meth:`_not_contact`).
        self._excluded = self._not_contact()
        #: Body of every local DOF block (connected components of the mesh) and their number.
        self.body_of_block, self.num_bodies = connected_bodies(V)
        check_rigid_support(V, self.body_of_block, self.num_bodies, self.dirichlet_rows)
        self._A_free = dolfinx.fem.petsc.assemble_matrix(self.a)
        self._A_free.assemble()
        self._A_free.setOptionsPrefix(f"{prefix}A_free_")
        self._obstacle_map: ContactMap | None = None
        if obstacle_contact is not None:
            tags, markers = obstacle_contact
            self._obstacle_map = ContactMap.create(V, tags, [int(m) for m in markers], self._not_contact(),
                                                   self.obstacles, held=self._held)
            check_not_overlapping(self.obstacles, self._obstacle_map.coordinates, comm=comm)
            self._obstacle_friction = self._friction_at_contact_nodes(friction, self._obstacle_map.blocks)
        self._pair(self._merge(pair_surfaces(V, pairs, self._excluded), None))

    def _not_contact(self) -> npt.NDArray[np.int32]:
        """The local DOF blocks that are never contact nodes of an obstacle: clamped (three held components) or held
        at a non-zero value in some component (driven along the contact by their support; the values as
        :meth:`assemble_load` read them)."""
        values = np.zeros(self._held.size)
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
        bad = np.flatnonzero(np.any(np.abs(slip) > 1e-12 * max(self._size, np.finfo(float).tiny), axis=1))
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

    def held_pairing(self, pairing: Pairing) -> tuple[Pairing, npt.NDArray[np.bool_]]:
        """The pairing with the frames of its slave nodes with held components (held axes first, the normal
        projected: :func:`~fenics_coulomb.model.frames.held_frames` with the pairs' tolerance), without the nodes
        whose held direction is not orthogonal to their normal (logged; collective), and the held components of
        its nodes, shape (m, 3)."""
        held = self._held[pairing.blocks]
        if not self.comm.allreduce(bool(np.any(held)), op=MPI.LOR):
            return pairing, held
        frames, conflict = held_frames(pairing.frames, held, PAIR_HELD_NORMAL_TOL)
        pairing = dataclasses.replace(pairing, frames=frames)
        count = self.comm.allreduce(int(np.sum(conflict)), op=MPI.SUM)
        if count:
            if self.comm.rank == 0:
                logger.info("%d slave node(s) with a held component not orthogonal to the contact normal are moved "
                            "by their support, not contact nodes", count)
            pairing = pairing.subset(~conflict, self.comm)
            held = held[~conflict]
        return pairing, np.ascontiguousarray(held)

    def _merge(self, pairing: Pairing, u: npt.NDArray[np.float64] | None) -> Pairing:
        """The pairing without the nodes that belong to a rigid obstacle: a node that is both a paired slave node
        and an obstacle contact node belongs to the one with the smaller |g| in X + u (``u`` ghosted, None: X;
        ties: the pair; collective)."""
        obstacle_map = self._obstacle_map
        if obstacle_map is None:
            return pairing
        x = obstacle_map.coordinates if u is None else obstacle_map.coordinates + u.reshape(-1, 3)[obstacle_map.blocks]
        _, obstacle_gap, _, _ = closest_obstacle(self.obstacles, x)
        both_p = np.isin(pairing.blocks, obstacle_map.blocks)
        where = np.searchsorted(obstacle_map.blocks, pairing.blocks[both_p])
        lose = np.zeros(pairing.blocks.size, dtype=bool)
        lose[np.flatnonzero(both_p)] = np.abs(obstacle_gap[where]) < np.abs(pairing.gap[both_p])
        return pairing.subset(~lose, self.comm)

    def _pair(self, pairing: Pairing) -> None:
        """Make ``pairing`` (of the current configuration) the model's: the obstacles' contact nodes merged in (a
        node that is both a paired slave node and an obstacle contact node belongs to the one with the smaller
        |g|, ties: the pair; obstacle nodes keep z = u, no row of Φ), M = I + Φ, Ã = Mᵀ A_free M with the
        Dirichlet rows and columns of s I (:mod:`fenics_coulomb.model.pairs.two_body` derives it), l̃_z and the
        contact map (collective)."""
        V, comm, prefix = self.V, self.comm, self.prefix
        pairing, pair_held = self.held_pairing(pairing)
        obstacle_map = self._obstacle_map
        if obstacle_map is not None:
            keep = ~np.isin(obstacle_map.blocks, pairing.blocks)
            obstacle_map = obstacle_map.subset(keep, comm)
            obstacle_friction = self._obstacle_friction[keep]
        if self.configuration is not None:  # the pairing of X + u keeps the nodes' reference coordinates X
            pairing = dataclasses.replace(pairing, coordinates=V.tabulate_dof_coordinates()[pairing.blocks])
        self.pairing = pairing
        self.coupling.destroy()
        self.coupling = PairCoupling(V, pairing, self.body_of_block, self.num_bodies, prefix, self._A_free,
                                     pair_held)
        if getattr(self, "A", None) is not None:
            self.A.destroy()
        self.A = self.coupling.stiffness(self, prefix)
        r0 = V.dofmap.index_map.local_range[0]
        self.dirichlet_diagonal = self._scale_dirichlet_rows(self.dirichlet_rows)
        if self.load is None:
            self.load = self.A.createVecRight()
            self.load.setOptionsPrefix(f"{prefix}load_")
        self.assemble_load()
        blocks = pairing.blocks
        coordinates = pairing.coordinates
        gap, frames = pairing.gap, pairing.frames
        index = -1 - pairing.pair_index  # pairs: −1 − pair index; obstacles: their index
        paired = np.ones(blocks.size, dtype=bool)
        held = pair_held
        node_friction = pairing.friction
        if obstacle_map is not None:
            blocks = np.concatenate([blocks, obstacle_map.blocks])
            coordinates = np.concatenate([coordinates, obstacle_map.coordinates])
            gap = np.concatenate([gap, obstacle_map.gap])
            frames = np.concatenate([frames, obstacle_map.frames])
            index = np.concatenate([index, obstacle_map.obstacle_index])
            held = np.concatenate([held, obstacle_map.held_components])
            paired = np.concatenate([paired, np.zeros(obstacle_map.size, dtype=bool)])
            node_friction = np.concatenate([node_friction, obstacle_friction])
        order = np.argsort(blocks, kind="stable")
        blocks = blocks[order].astype(np.int32)
        offsets = np.arange(3, dtype=np.int32)
        self.contact = ContactMap(
            blocks=blocks, local_dofs=(3 * blocks[:, None] + offsets).astype(np.int32),
            global_dofs=3 * (blocks.astype(np.int64)[:, None] + r0) + offsets.astype(np.int64),
            coordinates=np.ascontiguousarray(coordinates[order]), gap=np.ascontiguousarray(gap[order]),
            frames=np.ascontiguousarray(frames[order]), obstacle_index=index[order],
            num_global=comm.allreduce(int(blocks.size), op=MPI.SUM), held=np.ascontiguousarray(held[order]))
        #: Which contact nodes are paired slave nodes (the others belong to rigid obstacles).
        self.paired = paired[order]
        self.friction = np.ascontiguousarray(np.asarray(node_friction, dtype=np.float64)[order])
        self.p = self.contact.num_global
        if self._free_coupling is not None:
            self._free_coupling.destroy()
            self._free_coupling = None

    # -- the configuration (finite sliding) --------------------------------------------------------
    def _at_blocks(self, blocks: npt.NDArray[np.int32]) -> npt.NDArray[np.float64]:
        """The configuration's displacement at local DOF blocks, shape (m, 3) (0 in the reference one)."""
        if self.configuration is None:
            return np.zeros((np.size(blocks), 3))
        return self.configuration.reshape(-1, 3)[blocks]

    def elastic_energy(self, u: npt.NDArray[np.float64]) -> float:
        """½ uᵀ K u of the physical displacement of the owned DOFs (K: A_free for contact pairs, else A; the same on
        every rank; collective). Invariant under rigid motions of the bodies (pairs) and independent of the mesh's
        numbering and partition up to round-off."""
        K = self._A_free if self._A_free is not None else self.A
        x, y = K.createVecs()
        x.array[:] = np.asarray(u, dtype=np.float64)[:x.getLocalSize()]
        K.mult(x, y)
        energy = 0.5 * x.dot(y)
        x.destroy()
        y.destroy()
        return float(energy)

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

    def pair_in(self, u: npt.ArrayLike | None) -> Pairing | None:
        """The pairing of the configuration X + u (``u`` the physical displacement of the owned DOFs; None:
        the reference configuration), or None without contact pairs (collective)."""
        if self.pairing is None:
            return None
        if u is None:
            return self._merge(pair_surfaces(self.V, self.pairs, self._excluded), None)
        ug = self.ghosted(u)
        x = self.V.tabulate_dof_coordinates() + ug.reshape(-1, 3)
        return self._merge(pair_surfaces(self.V, self.pairs, self._excluded, coordinates=x), ug)

    def configure(self, u: npt.ArrayLike | None, pairing: Pairing | None = None) -> bool:
        """Evaluate the contact geometry in the configuration X + u from now on (finite sliding; collective).

        The obstacles' gaps, normals and frames follow at the next :meth:`place`; contact pairs are paired again
        in X + u (``pairing``, if already computed by :meth:`pair_in` for the same ``u``) and M, Ã, l̃ and the
        contact map rebuilt.

        Args:
            u: The physical displacement of the owned DOFs; None for the reference configuration.
            pairing: The pairing of X + u, when known.

        Returns:
            Whether Ã and the contact nodes were rebuilt (contact pairs): a solver built on the old ones must be
            rebuilt.
        """
        self.configuration = None if u is None else self.ghosted(u)
        if self.pairing is None:
            return False
        self._pair(pairing if pairing is not None else self.pair_in(u))
        return True

    def near_nullspace(self) -> PETSc.NullSpace:
        """The near-nullspace for GAMG: the rigid modes of V, or (I − Φ) r_b per body for two bodies."""
        return self.coupling.near_nullspace(self.V)

    @property
    def A_free(self) -> PETSc.Mat | None:
        """Two bodies: the stiffness without boundary conditions (None for one body)."""
        return getattr(self.coupling, "A_free", None)

    def physical(self, z: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """u = M z on the owned DOFs (the identity for one body; collective for two)."""
        return self.coupling.physical(z)

    def _free_gaps(self, u: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The linearized gaps g + n·(u_s − Σ_j φ_j u_j) of the owned free slave nodes (over a master surface, but
        not contact nodes: beyond the search distance, with a Dirichlet component, or a mortar node not fully
        covered), ``u`` physical (collective; empty for one body)."""
        if self.pairing is None:
            return np.zeros(0)
        free = self.pairing.free
        if self._free_coupling is None:
            self._free_coupling = coupling_matrix(self.V, free["blocks"], free["master_blocks"], free["weights"],
                                                  f"{self.prefix}free_")
        x, y = self._free_coupling.createVecs()

        def w_of(v: npt.ArrayLike) -> npt.NDArray[np.float64]:
            x.array[:] = np.asarray(v, dtype=np.float64)[:x.getLocalSize()]
            self._free_coupling.mult(x, y)  # (I + Φ_free) v
            return (2.0 * x.getArray(readonly=True) - y.getArray(readonly=True)).reshape(-1, 3)[free["blocks"]]

        w = w_of(u)
        if self.configuration is not None:  # free["gap"] is g(X + u_c): linearized about the configuration
            w = w - w_of(self.configuration)
        x.destroy()
        y.destroy()
        return free["gap"] + np.einsum("ij,ij->i", free["normals"], w)

    def free_slave_penetrations(self, u: npt.NDArray[np.float64], tol: float = 1e-8) -> int:
        """The number of free slave nodes (:meth:`_free_gaps`) whose gap is below −tol × the mesh size, on all
        ranks (collective; 0 for one body)."""
        if self.pairing is None:
            return 0
        gap = self._free_gaps(u)
        return int(self.comm.allreduce(int(np.sum(gap < -tol * self._size)), op=MPI.SUM))

    def free_slave_depth(self, u: npt.NDArray[np.float64]) -> float:
        """The deepest penetration of a free slave node into its master surface, max(−g, 0) over all ranks
        (collective; 0 for one body)."""
        if self.pairing is None:
            return 0.0
        gap = self._free_gaps(u)
        return float(self.comm.allreduce(float(np.max(-gap, initial=0.0)), op=MPI.MAX))

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
        :meth:`place` afterwards to update l = l̃ + A d.
        """
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
        previous_obstacle_displacements: npt.ArrayLike | None = None,
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
        self.check_motion(obstacles, previous_obstacle_displacements)
        if len(obstacles) != len(self.obstacles) or any(
                o._at_rest() != p._at_rest() for o, p in zip(obstacles, self.obstacles)):
            raise InputError("obstacles: a placement may only change the obstacles' displacements and rotations")
        self.obstacles = obstacles
        previous_obstacles = _previous_placements(obstacles, previous_obstacle_displacements)
        if previous_obstacle_displacements is not None and len(previous_obstacle_displacements) and \
                isinstance(previous_obstacle_displacements[0], Obstacle):
            previous_obstacle_displacements = [o.displacement for o in previous_obstacle_displacements]
        cmap = self.contact
        finite = self.configuration is not None
        paired = self.paired if self.pairing is not None else np.zeros(cmap.size, dtype=bool)
        rigid = np.flatnonzero(~paired)
        offset = np.zeros((cmap.size, 3))
        self.obstacle_displacement = np.zeros((cmap.size, 3))
        if rigid.size:
            X = cmap.coordinates[rigid]
            u = self._at_blocks(cmap.blocks[rigid])
            index, gap, _, frames = self.closest(obstacles, X + u if finite else X)
            # round-off below the surface (e.g. from mesh generators) counts as touching
            gap[(gap < 0.0) & (gap > -1e-12 * self._size)] = 0.0
            if finite:  # linearized about the configuration: g(X + u_c) + n·(u − u_c)
                gap = gap - np.einsum("ij,ij->i", frames[:, :, 2], u)
                for j, obstacle in enumerate(obstacles):
                    mine = index == j
                    if obstacle.affine and np.any(mine):  # g(X + u_c) − n·u_c = g(X) exactly, frames constant
                        g0, _, frames[mine] = obstacle.evaluate(X[mine])
                        gap[mine] = np.where((g0 < 0.0) & (g0 > -1e-12 * self._size), 0.0, g0)
            cmap.obstacle_index[rigid], cmap.gap[rigid], cmap.frames[rigid] = index, gap, frames
            delta = np.array([o.displacement for o in obstacles], dtype=np.float64).reshape(-1, 3)
            #: Cartesian displacement δ of each contact node's obstacle, shape (m, 3).
            self.obstacle_displacement[rigid] = delta[index]
            offset[rigid] = delta[index]
            if previous_obstacles is not None:  # a rotation: each node's material point of its obstacle
                x = X if not (finite and previous_displacement is not None) else \
                    X + np.asarray(previous_displacement, dtype=np.float64).reshape(-1, 3)[rigid]
                moved = np.zeros((rigid.size, 3))
                for j, (now, before) in enumerate(zip(obstacles, previous_obstacles, strict=True)):
                    mine = index == j
                    if np.any(mine):
                        moved[mine] = now.motion(before, self.material_point(before, x[mine]))
                offset[rigid] = moved
            elif previous_obstacle_displacements is not None:
                previous = np.asarray(previous_obstacle_displacements, dtype=np.float64).reshape(-1, 3)
                offset[rigid] -= previous[index]
        if cmap.held is not None:  # held components tangential to the contact (collective)
            cmap.frames[rigid] = hold(cmap.frames[rigid], cmap.held[rigid], cmap.coordinates[rigid], self.comm)
        if self.pairing is not None:
            # the paired nodes' gaps: the pairing's, linearized about the configuration in the unknown w = z_s
            gap = self.pairing.gap
            if finite:
                w = self.coupling.relative(self.configuration[:3 * self.V.dofmap.index_map.size_local])
                gap = gap - np.einsum("ij,ij->i", cmap.frames[paired][:, :, 2], w[cmap.local_dofs[paired]])
            cmap.gap[paired] = gap
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

    def closest(self, obstacles: Sequence[Obstacle], x: npt.NDArray[np.float64]
                ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.float64], npt.NDArray[np.float64],
                           npt.NDArray[np.float64]]:
        """:func:`~fenics_coulomb.model.obstacles.closest_obstacle` of the points ``x``, remembered for the last
        obstacles and points: the geometry check of finite sliding and the next placement ask for the same points
        (copies returned)."""
        cached = self._closest_cache
        if cached is not None and len(cached[0]) == len(obstacles) and all(
                a is b for a, b in zip(cached[0], obstacles)) and np.array_equal(cached[1], x):
            result = cached[2]
        else:
            result = closest_obstacle(obstacles, x)
            self._closest_cache = (list(obstacles), np.array(x, copy=True), result)
        return tuple(np.array(r, copy=True) for r in result)  # type: ignore[return-value]

    def material_point(self, obstacle: Obstacle, x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """``obstacle.closest_point(x)``, remembered for the last obstacle and points: a rotating obstacle's
        material point beneath a node at the previous step is the same at every geometry update of a step."""
        cached = self._material_cache
        if cached is not None and cached[0] is obstacle and np.array_equal(cached[1], x):
            return np.array(cached[2], copy=True)
        point = obstacle.closest_point(x)
        self._material_cache = (obstacle, np.array(x, copy=True), np.array(point, copy=True))
        return point

    def check_motion(self, obstacles: Sequence[Obstacle],
                     previous_displacements: npt.ArrayLike | Sequence[Obstacle] | None) -> None:
        """InputError on every rank (collective) for obstacles whose placement the contact nodes cannot see:

        * at the first placement, an obstacle at its scene position with the whole body inside it (a plane or an
          open surface whose solid side is the body's side; :func:`~fenics_coulomb.model.obstacles.check_solid_side`);
        * an obstacle whose core (a sphere's centre, a cylinder's axis, the deepest part of a closed surface) lies
          inside the body at its placement, or passes through the body on its rigid motion — translation and
          rotation (:func:`~fenics_coulomb.model.obstacles.core_path`) — from the previous placement
          (``previous_displacements``: the previous obstacles, their δ, or None for the scene position): a buried
          obstacle, or one moved or turned across the body within one step, which the contact nodes, all on one
          side, would not see.
        """
        from fenics_coulomb.model.obstacles import check_solid_side, rotation_text

        if getattr(self, "_scene_obstacles", None) is None:
            self._scene_obstacles = [o.moved(np.zeros(3)) for o in obstacles]
            check_solid_side(obstacles, self.V.mesh.geometry.x, self.comm, self._size)
        if self._locator is None:
            return
        # the check depends on the placements only (the body's reference mesh): once per placement, not again at
        # every geometry update of finite sliding
        if previous_displacements is None or (len(previous_displacements) and  # type: ignore[arg-type]
                                              isinstance(previous_displacements[0], Obstacle)):  # type: ignore[index]
            previous_key: Any = None if previous_displacements is None else tuple(previous_displacements)  # type: ignore[arg-type]
        else:
            previous_key = np.asarray(previous_displacements, dtype=np.float64).tobytes()
        key = (tuple(obstacles), previous_key)
        if self._motion_checked is not None and _same_placements(self._motion_checked, key):
            return
        loc = self._locator
        if previous_displacements is None:
            before = list(self._scene_obstacles)
        elif len(previous_displacements) and isinstance(previous_displacements[0], Obstacle):
            before = list(previous_displacements)  # type: ignore[arg-type]
        else:
            deltas = np.asarray(previous_displacements, dtype=np.float64).reshape(-1, 3)
            before = [o.moved(d).rotated(None) for o, d in zip(obstacles, deltas, strict=True)]
        for k, (obstacle, previous) in enumerate(zip(obstacles, before, strict=True)):
            points, t = core_path(previous, obstacle, loc.lo, loc.hi, 0.5 * loc.spacing)
            if not points.size:
                continue
            hit = loc.first_inside(points)
            if hit < 0:
                continue
            core = {"sphere": "centre", "cylinder": "axis"}.get(obstacle.kind, "deepest part")
            where = "(" + ", ".join(f"{c:.6g}" for c in points[hit]) + ")"
            moved = previous.displacement != obstacle.displacement or \
                getattr(previous, "rotation", None) != getattr(obstacle, "rotation", None)
            if moved and t[hit] < 1.0:
                turned = "" if getattr(previous, "rotation", None) == getattr(obstacle, "rotation", None) else \
                    f" and from rotation {rotation_text(previous)} to {rotation_text(obstacle)}"
                what = (f"its {core} would pass through the body at {where} on its way from displacement "
                        f"{list(previous.displacement)} to {list(obstacle.displacement)}{turned}: move it around "
                        "the body, not through it, or in smaller steps")
            else:
                what = (f"its {core} lies inside the body at {where} (displacement {list(obstacle.displacement)}): "
                        "an obstacle buried in the body, or indenting it too deep")
            raise InputError(f"obstacle {k + 1} ({obstacle.label}): {what}")
        self._motion_checked = key

    def _friction_at_contact_nodes(self, friction: Friction, blocks: npt.NDArray[np.int32] | None = None
                                   ) -> float | npt.NDArray[np.float64]:
        """F as a number, or its values at the owned contact nodes (``blocks``, default the contact map's) for a
        field (validated on all ranks)."""
        if not isinstance(friction, dolfinx.fem.Function):
            return float(friction) if blocks is None else np.full(np.size(blocks), float(friction))
        S = dolfinx.fem.functionspace(self.V.mesh, ("Lagrange", 1))
        values = dolfinx.fem.Function(S)
        values.interpolate(friction)
        cell_blocks = self.V.dofmap.list.ravel()
        scalars = S.dofmap.list.ravel()
        to_scalar = np.full(self.V.dofmap.index_map.size_local + self.V.dofmap.index_map.num_ghosts, -1, np.int32)
        to_scalar[cell_blocks] = scalars
        F = np.ascontiguousarray(values.x.array[to_scalar[self.contact.blocks if blocks is None else blocks]],
                                 dtype=np.float64)
        bad = ~(np.isfinite(F) & (F >= 0.0))
        check_all(self.comm, not np.any(bad), f"friction field value {F[bad][0] if np.any(bad) else 0.0!r} at "
                  "a contact node: must be finite and >= 0")
        return F

    def _scale_dirichlet_rows(self, rows: npt.NDArray[np.int32]) -> float:
        """Set the Dirichlet rows' diagonal to the mean diagonal of the free rows (scale-free γ and PCs)."""
        diag = self.A.getDiagonal()
        values = diag.array
        free = np.ones(values.size, dtype=bool)
        free[rows] = False
        total = self.comm.allreduce(float(np.sum(values[free])), op=MPI.SUM)
        count = self.comm.allreduce(int(np.sum(free)), op=MPI.SUM)
        scale = total / max(count, 1)
        values[rows] = scale
        self.A.setDiagonal(diag, addv=PETSc.InsertMode.INSERT_VALUES)
        self.A.assemble()
        diag.destroy()
        return scale

    def total_load(self) -> npt.NDArray[np.float64]:
        """Resultant of the applied load L (a 3-vector, the same on all ranks): L applied to the three unit
        translations, which the P1/Q1 basis sums to (partition of unity)."""
        b = dolfinx.fem.petsc.assemble_vector(self.L)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        local = b.getArray(readonly=True).reshape(-1, 3).sum(axis=0)
        b.destroy()
        return np.asarray(self.comm.allreduce(local, op=MPI.SUM))

    def destroy(self) -> None:
        """Destroy the PETSc objects (collective)."""
        for obj in (self.A, self.load, self.shift, self.rhs, self._free_coupling):
            if obj is not None:
                obj.destroy()
        self.coupling.destroy()
        if self._A_free is not None:
            self._A_free.destroy()
            self._A_free = None
