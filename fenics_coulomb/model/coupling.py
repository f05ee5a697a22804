"""The coupling of the bodies: everything in which one elastic body differs from two, behind one interface.

The change of variables u = M z between the physical displacement u and the solver's unknown z, the contact nodes
it brings, and what follows from it. :class:`ContactModel <fenics_coulomb.model.contact_model.ContactModel>`
holds one coupling, built once (:meth:`Coupling.build`), and asks it, without knowing which one it holds, for

* the contact boundary and the default obstacles (:meth:`Coupling.boundary`), the stiffness the solver sees and
  the contact map (:meth:`Coupling.build`: A, or Ã = Mᵀ A_free M with the pairs' slave nodes merged with the
  obstacles' contact nodes), the lifted load (:meth:`Coupling.assemble_load`);
* the gaps of its own contact nodes at a placement (:meth:`Coupling.place`), the geometry of a configuration
  X + u (:meth:`Coupling.configure`, :meth:`Coupling.pair_in`, :meth:`Coupling.stencil_change`);
* the maps :meth:`Coupling.physical` (u = M z) and :meth:`Coupling.relative` (z = M⁻¹ u), the near-nullspace,
  the energy's matrix;
* the outputs of its kind: the master forces, the free slave nodes' penetration, the forces per pair, the point
  fields and summary entries (empty for one body), the nodes' contact areas and groups.

:class:`IdentityCoupling` is one body (or bodies touching rigid obstacles only): M = I, no pair. The pairs'
coupling, M = I + Φ, is :class:`fenics_coulomb.model.pairs.coupling.PairCoupling`.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.contact_map import ContactMap
from fenics_coulomb.model.mesh_checks import first_interior_facet
from fenics_coulomb.model.nullspace import (HELD_BODY_SHIFT, FreeMotions, free_rigid_motions, held_by_stiffness,
                                             rigid_body_modes, shift_diagonal)
from fenics_coulomb.model.obstacle_checks import check_not_overlapping
from fenics_coulomb.model.obstacles import DEFAULT_PLANE, Obstacle
from fenics_coulomb.model.reproducible import assemble_matrix
from fenics_coulomb.model.rigid_approach import free_motion_balance, loads_the_free_motions, rigid_approach

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel, Friction
    from fenics_coulomb.model.pairs import Pairing
    from fenics_coulomb.scd.records import SolveResult

__all__ = ["Coupling", "IdentityCoupling", "StencilChange"]

logger = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
Boundary = tuple[dolfinx.mesh.MeshTags, Sequence[int]]


@dataclass
class StencilChange:
    """How the coupling's own contact nodes change from the model's geometry to that of X + u (finite sliding;
    :func:`fenics_coulomb.model.sliding.geometry_change`). Empty for one body.

    Attributes:
        moved: Per contact node of the model: it lost its partner or changed its stencil support, and counts.
        delta: Per contact node of the model: Δ_j of a node that kept its partner (0 elsewhere).
        gained_at: The current positions of the new candidates that penetrate, shape (k, 3).
        gained_blocks: Their local DOF blocks.
        old_nodes, new_nodes: The global DOF blocks of the nodes before and after (the digest of the geometry).
        old_rows, new_rows: Their stencil supports (the digest of the geometry).
        pairing: The pairing of X + u (None for one body).
    """

    moved: npt.NDArray[np.bool_]
    delta: Array
    gained_at: Array
    gained_blocks: npt.NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, np.int32))
    old_nodes: list[npt.NDArray[np.int64]] = field(default_factory=list)
    new_nodes: list[npt.NDArray[np.int64]] = field(default_factory=list)
    old_rows: list[npt.NDArray[np.int64]] = field(default_factory=list)
    new_rows: list[npt.NDArray[np.int64]] = field(default_factory=list)
    pairing: Pairing | None = None


def boundary_facets(msh: dolfinx.mesh.Mesh, facet_tags: dolfinx.mesh.MeshTags, markers: Sequence[int]
                    ) -> tuple[bool, str]:
    """(whether every facet the markers tag that this rank owns lies on the mesh's boundary, the message naming an
    interior one): an interior facet's vertices would be contact nodes inside the body."""
    facets = np.hstack([facet_tags.find(m) for m in markers]) if markers else np.zeros(0, np.int32)
    mid = first_interior_facet(msh, facets)
    if mid is None:
        return True, ""
    at = ", ".join(f"{c:.6g}" for c in mid)
    return False, (f"contact: markers {list(markers)} tag an interior facet (midpoint ({at})): the contact boundary "
                   "must lie on the mesh's boundary")


class Coupling:
    """The interface (see the module docstring)."""

    #: The pairing of the contact pairs (None for one body).
    pairing: Pairing | None = None
    #: The number of elastic bodies the coupling knows, and the body of every local DOF block (None: one body).
    num_bodies: int = 1
    body_of_block: npt.NDArray[np.int64] | None = None
    #: The stiffness without boundary conditions (None for one body).
    A_free: PETSc.Mat | None = None
    #: Whether the coupling's own geometry depends on the configuration (finite sliding re-pairs it).
    follows_configuration: bool = False
    #: The nodes of geometry cycles (:meth:`tie`) as (sorted GLOBAL DOF blocks, widths), the same on every rank:
    #: the width within which their geometric decisions are made (None: round-off).
    ties: tuple[npt.NDArray[np.int64], Array] | None = None
    _energy_diagonal: Array | None = None

    # -- construction ------------------------------------------------------------------------------------
    def boundary(self, model: ContactModel, contact: Boundary | None, obstacles: Sequence[Obstacle]
                 ) -> tuple[Any, list[int], Boundary | None]:
        """The facet tags and markers of the contact boundary (nodal areas, figures) and the boundary of the
        obstacles' contact nodes, from the model's ``contact`` argument (pure checks; the same on every rank)."""
        raise NotImplementedError

    def default_obstacles(self) -> list[Obstacle]:
        """The obstacles of a model given none."""
        raise NotImplementedError

    def build(self, model: ContactModel, contact: Boundary | None, friction: Friction) -> None:
        """Set the model's stiffness ``A`` (Dirichlet rows scaled), ``load``, ``contact`` (the contact map) and
        ``friction`` (per node or a number), ``contact`` being the obstacles' contact boundary (collective)."""
        raise NotImplementedError

    def stiffness(self, model: ContactModel, prefix: str) -> PETSc.Mat:
        """The assembled stiffness in the solver's unknown with the Dirichlet rows and columns set to the identity
        (collective; the model scales them afterwards)."""
        raise NotImplementedError

    def assemble_load(self, model: ContactModel) -> None:
        """Assemble l̃ into ``model.load`` from the current coefficients and Dirichlet values (collective)."""
        raise NotImplementedError

    # -- geometry ----------------------------------------------------------------------------------------
    def paired_mask(self, size: int) -> npt.NDArray[np.bool_]:
        """Which of the model's ``size`` contact nodes are the coupling's own (pairs' slave nodes; the others
        belong to rigid obstacles)."""
        return np.zeros(size, dtype=bool)

    def place(self, model: ContactModel) -> None:
        """Set the gaps of the coupling's own contact nodes in ``model.contact`` (linearized about the model's
        configuration; collective)."""

    def pair_in(self, model: ContactModel, u: npt.ArrayLike | None, resolution: float = 0.0) -> Pairing | None:
        """The pairing of X + u (None: the reference configuration) known to ``resolution`` (the configuration's
        own displacement error), or None for one body (collective)."""
        return None

    def configure(self, model: ContactModel, u: npt.ArrayLike | None, pairing: Pairing | None,
                  resolution: float = 0.0) -> bool:
        """Rebuild the coupling's geometry in X + u (``pairing`` when known, else paired to ``resolution``);
        whether A and the contact nodes changed (collective)."""
        return False

    def tie(self, model: ContactModel, blocks: npt.NDArray[np.int32], width: Array) -> bool:
        """Decide the geometry of the nodes ``blocks`` (local, owned) within ``width`` from the next pairing on: a
        node-to-surface node in a cycle across a master edge takes the edge's tied facets' mean normal, and any node
        left unpaired within the widest tie of its closest point is paired; every dual-mortar facet counts as
        covered up to a border strip that wide (:mod:`fenics_coulomb.model.geometry_cycles`). Added to the nodes tied
        before; whether any pair can and any node was not tied yet (collective)."""
        return False

    def cycle_cure(self) -> str:
        """The clause a geometry cycle's failure adds: what settles it under this coupling ("" when nothing
        specific)."""
        return ""

    def stencil_change(self, model: ContactModel, u: Array, z: Array, previous: Array | None, tolerance: float,
                       pressed: npt.NDArray[np.bool_], resolution: float = 0.0) -> StencilChange:
        """How the coupling's contact nodes change in X + u, paired to ``resolution`` (collective; see
        :class:`StencilChange`)."""
        size = model.contact.size
        return StencilChange(np.zeros(size, dtype=bool), np.zeros(size), np.zeros((0, 3)))

    # -- the change of variables ---------------------------------------------------------------------------
    def physical(self, z: Array) -> Array:
        """u = M z on the owned DOFs (collective)."""
        raise NotImplementedError

    def relative(self, u: Array) -> Array:
        """z = M⁻¹ u on the owned DOFs (collective)."""
        raise NotImplementedError

    def variables(self) -> PETSc.Mat | None:
        """M of u = M z at the current geometry (None: M = I, one body)."""
        return None

    def physical_stiffness(self, model: ContactModel) -> PETSc.Mat | None:
        """The stiffness of the bodies in the physical displacement u with the supports' rows and columns of the
        solver's unknown (s I), independent of the geometry: Ã ≈ Mᵀ B M (None for one body, where Ã = A; built once,
        owned by the coupling; collective)."""
        return None

    def gamg_stiffness(self, model: ContactModel) -> PETSc.Mat:
        """The matrix GAMG on the stiffness builds its hierarchy from: the solver's stiffness (owned by the model or
        the coupling; collective)."""
        return model.A

    def near_nullspace(self, V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
        """The rigid-body modes in the solver's unknown, for GAMG (the caller destroys it)."""
        raise NotImplementedError

    def energy_matrix(self, model: ContactModel) -> PETSc.Mat:
        """The matrix K of the elastic energy ½ uᵀ K u of the physical displacement."""
        return model.A

    def node_stiffness(self, model: ContactModel) -> Array:
        """Each contact node's stiffness: the mean diagonal of :meth:`energy_matrix` over its components no support
        holds (the owned contact nodes; no collective call after the first)."""
        if self._energy_diagonal is None:  # the energy's matrix is assembled once: its diagonal too
            diagonal = self.energy_matrix(model).getDiagonal()
            try:
                self._energy_diagonal = diagonal.getArray(readonly=True).copy()
            finally:
                diagonal.destroy()
        values = self._energy_diagonal[model.contact.local_dofs]
        held = model.contact.held if model.contact.held is not None else np.zeros(values.shape, dtype=bool)
        free = np.where(held, 0.0, 1.0)
        return np.sum(values * free, axis=1) / np.maximum(np.sum(free, axis=1), 1.0)

    def partner_sizes(self, sizes: Array) -> Array:
        """Small sliding's unit of a slide per contact node, ``sizes`` (the obstacles') with the coupling's own
        nodes' partner facet diameters set."""
        return sizes

    # -- outputs -----------------------------------------------------------------------------------------
    def master_forces(self, contact_force: Array, local_dofs: npt.NDArray[np.int32]) -> Array | None:
        """The reaction on the master nodes (owned DOFs), or None without master bodies (collective)."""
        return None

    def initial_master_force(self, size: int) -> Array | None:
        """The master forces of the unloaded state, on ``size`` owned DOFs (None without master bodies)."""
        return None

    def finish(self, model: ContactModel, result: SolveResult) -> None:
        """Make ``result`` physical: u = M z, the master forces, the free slave nodes' penetration (collective)."""

    def lost_support(self, model: ContactModel, closed: npt.NDArray[np.bool_] | None,
                     lifted_only: bool = False) -> str | None:
        """What a solve says about the bodies held by contact alone (their supports leave a rigid motion free): each
        such body, its holding contact and how many of its contact nodes are closed in the last iterate
        (``closed``: the contact nodes' mask; None: no iterate) — none closed: the loads lift it off and that motion
        is free. ``lifted_only``: only the bodies with no closed node (a converged solve's check). None when no body
        is so held (collective)."""
        return None

    def holds_by_contact(self) -> bool:
        """Whether some body has rigid motions that its supports leave free and contact alone holds."""
        return False

    def free_balance(self, model: ContactModel, contact_force: Array) -> float:
        """How far the contact forces are from balancing the loads along the motions the supports leave free
        (:func:`~fenics_coulomb.model.rigid_approach.free_motion_balance`; collective; 0 where none is free)."""
        return 0.0

    def approach(self, model: ContactModel, start: Array | None = None) -> Array | None:
        """The rigid motion that brings a body held by contact alone from ``start`` (default ũ = 0) onto its obstacles
        along its free rigid motions (owned DOF values; :mod:`fenics_coulomb.model.rigid_approach`), or None
        (collective)."""
        return None

    def free_slave_penetrations(self, model: ContactModel, u: Array, tol: float = 1e-8) -> int:
        """The number of free slave nodes penetrating their master surface (collective; 0 for one body)."""
        return 0

    def shared_nodes(self) -> int:
        """The contact nodes on both a pair's slave surface and the obstacles' contact boundary (0 for one body)."""
        return 0

    def shared_depth(self, model: ContactModel, u: Array) -> float:
        """The deepest penetration, in X + u (``u`` physical), of the constraint a contact node on both a pair's slave
        surface and the obstacles' contact boundary was not given (collective; 0 for one body)."""
        return 0.0

    def free_slave_depth(self, model: ContactModel, u: Array) -> float:
        """The deepest penetration of a free slave node, max(−g, 0) over all ranks (collective; 0 for one body)."""
        return 0.0

    def master_depth(self, model: ContactModel, u: Array) -> tuple[float, Array | None, float]:
        """The deepest master node inside its pair's slave body in X + u (``u`` physical) beyond the facetting's
        allowance, where it is, and the largest such depth over the slave facet's size
        (:func:`fenics_coulomb.model.pairs.master_nodes.master_excess`; collective; (0, None, 0) for one body)."""
        return 0.0, None, 0.0

    def uncovered_depth(self, model: ContactModel, u: Array) -> tuple[float, Array | None]:
        """The deepest slave node that no part of its master surface lies beneath inside the master body in X + u
        (``u`` physical), and where it is (:func:`fenics_coulomb.model.pairs.uncovered.uncovered_depth`; collective;
        (0, None) for one body)."""
        return 0.0, None

    def contact_areas(self, areas: Array) -> Array:
        """The contact nodes' areas with the coupling's own (mortar D_j) where its method gives them."""
        return areas

    def contact_groups(self, obstacle_index: npt.NDArray[np.int64], num_obstacles: int) -> npt.NDArray[np.int64]:
        """The group of every contact node: its obstacle's index, or ``num_obstacles`` + its pair's index."""
        return np.array(obstacle_index, dtype=np.int64).reshape(-1)

    def balance_sum(self, model: ContactModel, residual: Array, contact_force: Array,
                    clamped_blocks: npt.NDArray[np.int32]) -> Array:
        """This rank's share of the global balance: what the supports and the contact forces take from the load
        (``residual``: K u − l̃⁰ without boundary conditions, per local block; ``contact_force`` per contact node)."""
        raise NotImplementedError

    def pair_forces(self, model: ContactModel, result: SolveResult) -> list[dict[str, Any]]:
        """Per contact pair, the forces on its slave and master bodies (collective; empty for one body)."""
        return []

    def output_fields(self, model: ContactModel, result: SolveResult, S: dolfinx.fem.FunctionSpace,
                      to_scalar: npt.NDArray[np.int32]) -> tuple[dolfinx.fem.Function, ...]:
        """The point fields of the coupling's kind (the body id, the master reaction; none for one body)."""
        return ()

    def summary_entries(self, model: ContactModel, result: SolveResult, per_pair: list[dict[str, Any]]
                        ) -> dict[str, Any]:
        """summary.json's entries of the coupling's kind (``contact_pairs``, with ``per_pair``'s contact statistics;
        none for one body)."""
        return {}

    def destroy(self) -> None:
        """Destroy the PETSc objects the coupling owns (collective)."""


class IdentityCoupling(Coupling):
    """One body (M = I): A with the Dirichlet rows and columns of the identity, l̃ by DOLFINx's lifting, the contact
    nodes of the contact boundary against the obstacles. A body whose supports leave rigid motions free (held by
    contact alone) gives GAMG A with its diagonal raised by HELD_BODY_SHIFT (:meth:`gamg_stiffness`)."""

    def __init__(self) -> None:
        #: The number of rigid motions the supports leave free and those motions (known after :meth:`build`).
        self.free_motions = 0
        self.motions: FreeMotions | None = None
        self._gamg_stiffness: PETSc.Mat | None = None

    def boundary(self, model: ContactModel, contact: Boundary | None, obstacles: Sequence[Obstacle]
                 ) -> tuple[Any, list[int], Boundary | None]:
        if contact is None:
            raise InputError("contact: give the facet tags and the markers of the contact boundary")
        facet_tags, markers = contact
        markers = [int(m) for m in markers]
        # a marker no facet carries makes no contact node at all: a typo, not a body without contact
        comm = model.comm
        counts = comm.allreduce(np.array([facet_tags.find(m).size for m in markers], dtype=np.int64), op=MPI.SUM)
        missing = [m for m, c in zip(markers, counts, strict=True) if c == 0]
        values = sorted(set().union(*comm.allgather({int(v) for v in np.unique(facet_tags.values)}))) \
            if missing else []  # every rank's values (missing is global: all ranks gather or none)
        check_all(comm, not missing, f"contact: marker {missing[0] if missing else 0} is carried by no facet of "
                  f"the facet tags (their values: {values})")
        check_all(comm, *boundary_facets(model.V.mesh, facet_tags, markers))
        return facet_tags, markers, contact

    def default_obstacles(self) -> list[Obstacle]:
        return [DEFAULT_PLANE]

    def build(self, model: ContactModel, contact: Boundary | None, friction: Friction) -> None:
        # stiffness with the Dirichlet rows/columns replaced by a scaled identity
        model.A = self.stiffness(model, model.prefix)
        model.dirichlet_diagonal = model.scale_dirichlet_rows(model.dirichlet_rows)
        # load vector l̃ and the contact nodes (no clamped node; held components tangential to the contact,
        # :mod:`fenics_coulomb.model.frames`)
        model.load = model.A.createVecRight()
        model.load.setOptionsPrefix(f"{model.prefix}load_")
        model.assemble_load()
        model.contact = ContactMap.create(model.V, model.facet_tags, model.markers, model.not_contact(),
                                          model.obstacles, held=model.held)
        check_not_overlapping(model.obstacles, model.contact.coordinates, comm=model.comm)
        model.friction = model.friction_at_nodes(friction)
        body = np.zeros(model.V.dofmap.index_map.size_local + model.V.dofmap.index_map.num_ghosts, dtype=np.int64)
        self.motions = held_by_stiffness(model.A, model.V, free_rigid_motions(model.V, body, 1, model.dirichlet_rows),
                                         model.dirichlet_diagonal)  # springs in the form hold motions too
        self.free_motions = int(self.motions.free.sum())
        if self.free_motions and model.comm.rank == 0:
            logger.info("%d rigid motion(s) left free by the supports are held by contact alone", self.free_motions)

    def stiffness(self, model: ContactModel, prefix: str) -> PETSc.Mat:
        A = assemble_matrix(model.a, bcs=model.bcs)
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

    def holds_by_contact(self) -> bool:
        return bool(self.free_motions)

    def approach(self, model: ContactModel, start: Array | None = None) -> Array | None:
        if not self.free_motions or self.motions is None:
            return None
        motion = rigid_approach(model, self.motions, start)
        if start is None or motion is None:
            return motion
        # from a previous step: only a motion above round-off (a body still on its obstacles stays where it is)
        moved = model.comm.allreduce(float(np.abs(motion).max(initial=0.0)), op=MPI.MAX) > 1e-12 * model.mesh_size
        return motion if moved else None

    def free_balance(self, model: ContactModel, contact_force: Array) -> float:
        return free_motion_balance(model, self.motions, contact_force) if self.motions is not None else 0.0

    def lost_support(self, model: ContactModel, closed: npt.NDArray[np.bool_] | None,
                     lifted_only: bool = False) -> str | None:
        """The body held by contact alone with no contact node closed under a load: nothing holds its free motions
        (a solve that converged there ran off along them: a block pressed onto a plane at gap 0, held sideways
        only, ended 2.3e12 above it with exit 0)."""
        closed_nodes = 0 if closed is None else int(np.count_nonzero(closed))
        if not self.free_motions or self.motions is None or model.comm.allreduce(closed_nodes, op=MPI.SUM):
            return None
        if not loads_the_free_motions(model, self.motions):
            return None  # no load along the free motions (none, or along what the supports hold): nothing to hold
        load = model.total_load()  # collective, on every rank alike
        return (f"the supports leave {self.free_motions} rigid motion(s) of the body free and no contact node is "
                f"closed: nothing holds it against the load's resultant ({', '.join(f'{c:.4g}' for c in load)}), "
                "the loads lift it off its obstacles or the solve ran off along the free motion; support the body, "
                "or load it onto an obstacle")

    def gamg_stiffness(self, model: ContactModel) -> PETSc.Mat:
        """A, or for a body its supports do not hold (A singular: the contact rows hold it in the Newton matrix, GAMG's
        coarsest factorization breaks down on A) a copy of A with the free rows' diagonal raised by HELD_BODY_SHIFT
        (built once)."""
        if not self.free_motions:
            return model.A
        if self._gamg_stiffness is None:
            P = model.A.duplicate(copy=True)
            P.setOptionsPrefix(f"{model.prefix}A_gamg_")
            rows = np.ones(P.getLocalSize()[0], dtype=bool)
            rows[model.dirichlet_rows] = False
            shift_diagonal(P, rows, HELD_BODY_SHIFT)
            self._gamg_stiffness = P
        return self._gamg_stiffness

    def near_nullspace(self, V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
        return rigid_body_modes(V)

    def destroy(self) -> None:
        if self._gamg_stiffness is not None:
            self._gamg_stiffness.destroy()
            self._gamg_stiffness = None

    def balance_sum(self, model: ContactModel, residual: Array, contact_force: Array,
                    clamped_blocks: npt.NDArray[np.int32]) -> Array:
        """The supports' reactions and the contact forces (a contact node with held components: its block of the
        residual already holds its contact force)."""
        cmap = model.contact
        unheld = ~np.isin(cmap.blocks, clamped_blocks) if np.any(cmap.held_components) else slice(None)
        return residual[clamped_blocks].sum(axis=0) + contact_force[unheld].sum(axis=0)
