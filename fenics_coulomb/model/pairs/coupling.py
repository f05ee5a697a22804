"""The coupling of two elastic bodies in contact pairs: M = I + Φ from the pairing's stencils
(:mod:`fenics_coulomb.model.pairs.two_body` derives the reduced problem), the pairs' slave nodes merged with the
obstacles' contact nodes into the model's contact map, and the outputs of pairs (the interface:
:class:`fenics_coulomb.model.coupling.Coupling`).

Construction (:meth:`PairCoupling.build`): the bodies and their supports, A_free and the obstacles' contact nodes
once; then the pairing of the reference configuration. A node both a paired slave node and an obstacle contact node
belongs to the one with the smaller signed gap (ties: the pair); obstacle nodes keep z = u (no row of Φ). Finite
sliding pairs again in X + u (:meth:`PairCoupling.configure`) and rebuilds M, Ã, l̃ and the contact map."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.contact_map import ContactMap
from fenics_coulomb.model.dof_values import set_owned_values
from fenics_coulomb.model.coupling import Boundary, Coupling, StencilChange
from fenics_coulomb.model.frames import PAIR_HELD_NORMAL_TOL, held_frames
from fenics_coulomb.model.nullspace import HELD_BODY_SHIFT, shift_diagonal
from fenics_coulomb.model.obstacle_checks import check_not_overlapping
from fenics_coulomb.model.obstacles import Obstacle, closest_obstacle
from fenics_coulomb.model.pairs.forces import balance_sum, pair_forces
from fenics_coulomb.model.pairs.master_nodes import master_excess
from fenics_coulomb.model.pairs.pair import ContactPair, Pairing, merged_contact_map
from fenics_coulomb.model.pairs.pairing import pair_surfaces
from fenics_coulomb.model.pairs.sliding import stencil_change
from fenics_coulomb.model.reproducible import TripleProduct, assemble_matrix, same_pattern
from fenics_coulomb.model.pairs.uncovered import uncovered_depth
from fenics_coulomb.model.pairs.two_body import (body_rigid_modes, check_rigid_support, connected_bodies, lost_support,
                                                 coupling_matrix, linearized_pair_gaps)

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel, Friction
    from fenics_coulomb.scd.records import SolveResult

__all__ = ["PairCoupling"]

logger = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


class PairCoupling(Coupling):
    """Two elastic bodies: M = I + Φ (PETSc AIJ ``<prefix>coupling_``) from the pairing of ``pairs``.

    Args:
        pairs: The contact pairs, in the order given (their facet tags on the model's mesh).
    """

    follows_configuration = True

    def __init__(self, pairs: Sequence[ContactPair]) -> None:
        bad = [q for q in pairs if not isinstance(q, ContactPair)]
        if bad:
            raise InputError(f"contact_pairs: {bad[0]!r} is not a ContactPair")
        self.pairs = list(pairs)
        self.M: PETSc.Mat | None = None
        self.A_free: PETSc.Mat | None = None
        self._physical_stiffness: PETSc.Mat | None = None
        self._paired: npt.NDArray[np.bool_] = np.zeros(0, dtype=bool)
        self._obstacle_map: ContactMap | None = None
        self._obstacle_friction: Array = np.zeros(0)
        self._excluded: npt.NDArray[np.int32] = np.zeros(0, np.int32)
        self._free_coupling: PETSc.Mat | None = None
        self._product = TripleProduct()
        self._given_coupling: PETSc.Mat | None = None
        self.reused = False

    # -- construction ------------------------------------------------------------------------------------
    def boundary(self, model: ContactModel, contact: Boundary | None, obstacles: Sequence[Obstacle]
                 ) -> tuple[Any, list[int], Boundary | None]:
        """The slave surfaces and the obstacles' contact boundary (nodal areas, figures); the obstacles' contact
        nodes from ``contact`` (required with obstacles)."""
        if obstacles and contact is None:
            raise InputError("obstacles with contact pairs: give the contact boundary of the obstacles too "
                             "(contact=(facet_tags, markers))")
        obstacle_contact = contact if obstacles else None
        markers = sorted({int(t) for q in self.pairs for t in np.atleast_1d(q.slave)}
                         | ({int(m) for m in obstacle_contact[1]} if obstacle_contact else set()))
        return self.pairs[0].facet_tags, markers, obstacle_contact

    def default_obstacles(self) -> list[Obstacle]:
        return []

    def build(self, model: ContactModel, contact: Boundary | None, friction: Friction) -> None:
        """The bodies, their supports, A_free and the obstacles' contact nodes once; then the pairing of the
        reference configuration (collective)."""
        V, comm = model.V, model.comm
        #: Never slave contact nodes: clamped, or held at a non-zero value.
        self._excluded = model.not_contact()
        self.body_of_block, self.num_bodies = connected_bodies(V)
        #: The bodies whose supports leave rigid motions free that contact alone holds.
        self.A_free = assemble_matrix(model.a)
        self.A_free.setOptionsPrefix(f"{model.prefix}A_free_")
        self.held_by_contact = check_rigid_support(V, self.body_of_block, self.num_bodies, model.dirichlet_rows,
                                                   self.pairs, stiffness=self.A_free)
        if contact is not None:
            tags, markers = contact
            self._obstacle_map = ContactMap.create(V, tags, [int(m) for m in markers], model.not_contact(),
                                                   model.obstacles, held=model.held)
            check_not_overlapping(model.obstacles, self._obstacle_map.coordinates, comm=comm)
            self._obstacle_friction = np.asarray(model.friction_at_nodes(friction, self._obstacle_map.blocks))
        self._adopt(model, self._merge(model, pair_surfaces(V, self.pairs, self._excluded, held=model.held), None))

    def held_pairing(self, model: ContactModel, pairing: Pairing) -> tuple[Pairing, npt.NDArray[np.bool_]]:
        """The pairing with the frames of its slave nodes with held components (held axes first, the normal projected:
        :func:`~fenics_coulomb.model.frames.held_frames`), without the nodes whose held direction is not orthogonal
        to their normal (logged; collective), and the held components of its nodes, shape (m, 3)."""
        held = model.held[pairing.blocks]
        if not model.comm.allreduce(bool(np.any(held)), op=MPI.LOR):
            return pairing, held
        frames, conflict = held_frames(pairing.frames, held, PAIR_HELD_NORMAL_TOL)
        pairing = dataclasses.replace(pairing, frames=frames)
        count = model.comm.allreduce(int(np.sum(conflict)), op=MPI.SUM)
        if count:
            if model.comm.rank == 0:
                logger.info("%d slave node(s) with a held component not orthogonal to the contact normal are moved "
                            "by their support, not contact nodes", count)
            pairing = pairing.to_free(conflict, model.comm)  # moved by their support: checked as free nodes
            held = held[~conflict]
        return pairing, np.ascontiguousarray(held)

    def _merge(self, model: ContactModel, pairing: Pairing, u: Array | None) -> Pairing:
        """The pairing without the nodes that belong to a rigid obstacle: a node that is both a paired slave node
        and an obstacle contact node belongs to the one with the smaller signed gap g in X + u (``u`` ghosted,
        None: X; ties: the pair; collective): the constraint it meets first, or violates more (not the smaller |g|)."""
        obstacle_map = self._obstacle_map
        if obstacle_map is None:
            return pairing
        x = obstacle_map.coordinates if u is None else obstacle_map.coordinates + u.reshape(-1, 3)[obstacle_map.blocks]
        _, obstacle_gap, _, _ = closest_obstacle(model.obstacles, x)
        both_p = np.isin(pairing.blocks, obstacle_map.blocks)
        where = np.searchsorted(obstacle_map.blocks, pairing.blocks[both_p])
        lose = np.zeros(pairing.blocks.size, dtype=bool)
        lose[np.flatnonzero(both_p)] = obstacle_gap[where] < pairing.gap[both_p]
        given = {"blocks": pairing.blocks[lose], "gap": pairing.gap[lose], "normals": pairing.normals[lose],
                 "master_blocks": pairing.master_blocks[lose], "weights": pairing.weights[lose]}
        merged = pairing.subset(~lose, model.comm)
        return dataclasses.replace(merged, to_obstacles=given,
                                   shared=int(model.comm.allreduce(int(np.sum(both_p)), op=MPI.SUM)))

    def shared_nodes(self) -> int:
        return 0 if self.pairing is None else self.pairing.shared

    def _adopt(self, model: ContactModel, pairing: Pairing) -> None:
        """Make ``pairing`` (of the model's configuration) the model's: the obstacles' contact nodes merged in,
        M = I + Φ, Ã = Mᵀ A_free M with the Dirichlet rows and columns of s I, l̃_z and the contact map
        (collective)."""
        V, comm, prefix = model.V, model.comm, model.prefix
        pairing, pair_held = self.held_pairing(model, pairing)
        obstacle_map = self._obstacle_map
        obstacle_friction = self._obstacle_friction
        if obstacle_map is not None:
            keep = ~np.isin(obstacle_map.blocks, pairing.blocks)
            obstacle_map = obstacle_map.subset(keep, comm)
            obstacle_friction = obstacle_friction[keep]
        if model.configuration is not None:  # the pairing of X + u keeps the nodes' reference coordinates X
            pairing = dataclasses.replace(pairing, coordinates=V.tabulate_dof_coordinates()[pairing.blocks])
        self.pairing = pairing
        M = coupling_matrix(V, pairing.blocks, pairing.master_blocks, pairing.weights, prefix, pair_held)
        #: Whether the last configuration kept M's nonzero pattern on every rank: M's Mat then takes the new
        #: values and Ã is overwritten in place by PtAP's numeric phase (the same bits as a new product; PtAP's
        #: reuse needs the very Mat its product was made from).
        self.reused = self.M is not None and model.A is not None and same_pattern(self.M, M)
        if self.reused:
            assert self.M is not None
            M.copy(self.M, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            M.destroy()
            model.A = self.stiffness(model, prefix, reuse=model.A)
        else:
            if self.M is not None:
                self.M.destroy()
            #: M = I + Φ (Φ's rows of held slave components 0).
            self.M = M
            if model.A is not None:
                model.A.destroy()
            model.A = self.stiffness(model, prefix)
        r0 = V.dofmap.index_map.local_range[0]
        model.dirichlet_diagonal = model.scale_dirichlet_rows(model.dirichlet_rows)
        if model.load is None:
            model.load = model.A.createVecRight()
            model.load.setOptionsPrefix(f"{prefix}load_")
        model.assemble_load()
        model.contact, self._paired, model.friction = merged_contact_map(pairing, pair_held, obstacle_map,
                                                                         obstacle_friction, r0, comm)
        model.p = model.contact.num_global
        for mat in (self._free_coupling, self._given_coupling):
            if mat is not None:
                mat.destroy()
        self._free_coupling = self._given_coupling = None

    def stiffness(self, model: ContactModel, prefix: str, reuse: PETSc.Mat | None = None) -> PETSc.Mat:
        """Ã = Mᵀ A_free M (:class:`~fenics_coulomb.model.reproducible.TripleProduct`) with the Dirichlet rows and
        columns of the identity; ``reuse``: the Ã of M's previous values, overwritten in place (the products'
        numeric phases only, the same bits)."""
        assert self.A_free is not None and self.M is not None, "build() first"
        if reuse is not None:
            A = self._product(self.A_free, self.M, result=reuse)
        else:
            A = self._product(self.A_free, self.M)
            A.setOptionsPrefix(f"{prefix}A_")
        r0 = model.V.dofmap.index_map.local_range[0]
        A.zeroRowsColumns((model.dirichlet_rows + 3 * r0).astype(PETSc.IntType), diag=1.0)
        return A

    def assemble_load(self, model: ContactModel) -> None:
        """l̃_z = Mᵀ(l − A_free M x_D) on the free DOFs and s u_D on D (:mod:`fenics_coulomb.model.pairs.two_body`)."""
        assert self.A_free is not None and self.M is not None and model.A is not None and model.load is not None
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

    # -- geometry ----------------------------------------------------------------------------------------
    def paired_mask(self, size: int) -> npt.NDArray[np.bool_]:
        assert self._paired.size == size, "the mask of another contact map"
        return self._paired.copy()

    def place(self, model: ContactModel) -> None:
        """The paired nodes' gaps: the pairing's, linearized about the configuration in the unknown w = z_s."""
        assert self.pairing is not None
        cmap = model.contact
        gap = self.pairing.gap
        if model.configuration is not None:
            w = self.relative(model.configuration[:3 * model.V.dofmap.index_map.size_local])
            gap = gap - np.einsum("ij,ij->i", cmap.frames[self._paired][:, :, 2], w[cmap.local_dofs[self._paired]])
        cmap.gap[self._paired] = gap

    def pair_in(self, model: ContactModel, u: npt.ArrayLike | None, resolution: float = 0.0) -> Pairing:
        """The pairing of X + u (``u`` the physical displacement of the owned DOFs; None: X), the obstacles' nodes
        merged (collective)."""
        if u is None:
            return self._merge(model, pair_surfaces(model.V, self.pairs, self._excluded, held=model.held), None)
        ug = model.ghosted(u)
        x = model.V.tabulate_dof_coordinates() + ug.reshape(-1, 3)
        return self._merge(model, pair_surfaces(model.V, self.pairs, self._excluded, coordinates=x,
                                                resolution=resolution, held=model.held, ties=self.ties), ug)

    def tie(self, model: ContactModel, blocks: npt.NDArray[np.int32], width: Array) -> bool:
        imap = model.V.dofmap.index_map
        local = imap.local_to_global(np.asarray(blocks, np.int32)).astype(np.int64)
        nodes = np.concatenate(model.comm.allgather(local))
        widths = np.concatenate(model.comm.allgather(np.asarray(width, np.float64)))
        if self.ties is not None:
            if np.all(np.isin(nodes, self.ties[0])):  # no node it has not tied yet: the tie did not settle them
                return False
            nodes, widths = np.concatenate([self.ties[0], nodes]), np.concatenate([self.ties[1], widths])
        unique, inverse = np.unique(nodes, return_inverse=True)
        widest = np.zeros(unique.size)
        np.maximum.at(widest, inverse, widths)
        self.ties = (unique, widest)
        return True

    def cycle_cure(self) -> str:
        if not any(q.method == "node-to-surface" for q in self.pairs):
            return ""
        return (": node-to-surface's constraint normal jumps where a slave node's closest point crosses a master edge "
                "with a kink (a slave node over a crease of the deformed master); method = 'mortar' (averaged slave "
                "normals) or a finer master there")

    def configure(self, model: ContactModel, u: npt.ArrayLike | None, pairing: Pairing | None,
                  resolution: float = 0.0) -> bool:
        self._adopt(model, pairing if pairing is not None else self.pair_in(model, u, resolution))
        return True

    def stencil_change(self, model: ContactModel, u: Array, z: Array, previous: Array | None, tolerance: float,
                       pressed: npt.NDArray[np.bool_], resolution: float = 0.0) -> StencilChange:
        assert self.pairing is not None
        pairing, held = self.held_pairing(model, self.pair_in(model, u, resolution))  # as configure would make it
        return stencil_change(model, self.pairing, pairing, held, self._paired, u, z, previous, tolerance, pressed)

    # -- the change of variables ---------------------------------------------------------------------------
    def variables(self) -> PETSc.Mat | None:
        return self.M

    def physical_stiffness(self, model: ContactModel) -> PETSc.Mat:
        """B: A_free with the Dirichlet rows and columns of s I. It couples no body to another, so the rigid modes
        of the whole mesh are those of every body, and it does not change with the pairing (Ã = Mᵀ B M wherever no
        master DOF of a stencil is supported). A body held by contact alone leaves B singular (the Newton matrix
        holds its free motions through the contact rows, which B does not have): its diagonal is raised by
        HELD_BODY_SHIFT of itself, which GAMG's coarsest factorization needs."""
        assert self.A_free is not None and self.body_of_block is not None, "build() first"
        if self._physical_stiffness is None:
            B = self.A_free.duplicate(copy=True)
            B.setOptionsPrefix(f"{model.prefix}B_")
            r0 = model.V.dofmap.index_map.local_range[0]
            B.zeroRowsColumns((model.dirichlet_rows + 3 * r0).astype(PETSc.IntType), diag=model.dirichlet_diagonal)
            held = [h.body for h in self.held_by_contact]
            if held:  # the same list on every rank
                n = model.V.dofmap.index_map.size_local
                rows = np.repeat(np.isin(self.body_of_block[:n], held), 3)
                rows[model.dirichlet_rows] = False
                shift_diagonal(B, rows, HELD_BODY_SHIFT)
            self._physical_stiffness = B
        return self._physical_stiffness

    def physical(self, z: Array) -> Array:
        assert self.M is not None
        x, y = self.M.createVecs()
        x.array[:] = z
        self.M.mult(x, y)
        u = y.getArray(readonly=True).copy()
        for vec in (x, y):
            vec.destroy()
        return u

    def relative(self, u: Array) -> Array:
        """z = M⁻¹ u = (I − Φ) u = 2u − M u (Φ² = 0)."""
        return 2.0 * np.asarray(u, dtype=np.float64) - self.physical(u)

    def near_nullspace(self, V: dolfinx.fem.FunctionSpace) -> PETSc.NullSpace:
        """(I − Φ) r_b per body b (:func:`fenics_coulomb.model.pairs.two_body.body_rigid_modes`)."""
        assert self.body_of_block is not None and self.M is not None
        return body_rigid_modes(V, self.body_of_block, self.num_bodies, self.M)

    def energy_matrix(self, model: ContactModel) -> PETSc.Mat:
        """A_free: the energy of both bodies, invariant under their rigid motions."""
        assert self.A_free is not None
        return self.A_free

    # -- outputs -----------------------------------------------------------------------------------------
    def master_forces(self, contact_force: Array, local_dofs: npt.NDArray[np.int32]) -> Array:
        """f_j = −Σ_s φ_sj f_s: Mᵀ f − f = Φᵀ f with f on the slave contact DOFs ``local_dofs``, shape (m, 3)."""
        assert self.M is not None
        x, y = self.M.createVecs()
        x.set(0.0)
        x.array[local_dofs] = np.asarray(contact_force, dtype=np.float64).reshape(-1, 3)
        self.M.multTranspose(x, y)  # Mᵀ f = f + Φᵀ f
        y.axpy(-1.0, x)
        out = -y.getArray(readonly=True).copy()
        for vec in (x, y):
            vec.destroy()
        return out

    def initial_master_force(self, size: int) -> Array:
        return np.zeros(size)

    def finish(self, model: ContactModel, result: SolveResult) -> None:
        """u = M z (z kept as ``relative_displacement``), the master forces, and a warning for free slave nodes
        that penetrate (collective)."""
        result.relative_displacement = result.displacement
        result.displacement = self.physical(result.displacement)
        result.master_force = self.master_forces(result.contact_force, model.contact.local_dofs)
        penetrating, depth = self._free_penetration(model, result.displacement)
        result.free_penetration = {}
        if penetrating:
            result.free_penetration = {"nodes": penetrating, "depth": depth}
            if model.comm.rank == 0:
                logger.warning("%d free slave node(s) (beyond the search distance, with a Dirichlet component, or "
                               "a mortar node not fully covered by the master surface) penetrate the master "
                               "surface, by up to %.3g: enlarge the pairs' search_distance, and make the smaller "
                               "surface the slave (mortar drops the slave nodes whose facets reach past the "
                               "master's border)", penetrating, depth)

    def _free_gaps(self, model: ContactModel, u: Array) -> Array:
        """The linearized gaps g + n·(u_s − Σ_j φ_j u_j) of the owned free slave nodes (over a master surface, but
        not contact nodes: beyond the search distance, with a Dirichlet component, or a mortar node not fully
        covered), ``u`` physical (collective)."""
        assert self.pairing is not None
        if self._free_coupling is None:
            free = self.pairing.free
            self._free_coupling = coupling_matrix(model.V, free["blocks"], free["master_blocks"], free["weights"],
                                                  f"{model.prefix}free_")
        return linearized_pair_gaps(model.configuration, self.pairing.free, self._free_coupling, u)

    def _given_gaps(self, model: ContactModel, u: Array) -> Array:
        """The linearized pair gaps of the owned slave nodes the merge gave to an obstacle (collective)."""
        assert self.pairing is not None
        given = self.pairing.to_obstacles
        if self._given_coupling is None:
            self._given_coupling = coupling_matrix(model.V, given["blocks"], given["master_blocks"],
                                                   given["weights"], f"{model.prefix}given_")
        return linearized_pair_gaps(model.configuration, given, self._given_coupling, u)

    def holds_by_contact(self) -> bool:
        return bool(self.held_by_contact)

    def lost_support(self, model: ContactModel, closed: npt.NDArray[np.bool_] | None,
                     lifted_only: bool = False) -> str | None:
        if not self.held_by_contact or self.pairing is None:
            return None
        mine = None if closed is None else np.asarray(closed, dtype=bool)[self._paired]
        return lost_support(model.comm, self.held_by_contact, self.pairs, self.pairing.pair_index, mine, lifted_only)

    def _free_penetration(self, model: ContactModel, u: Array, tol: float = 1e-8) -> tuple[int, float]:
        """(the number of free slave nodes whose gap is below −tol × the mesh size, the deepest penetration
        max(−g, 0)), both over all ranks, from one evaluation of the gaps (collective)."""
        gap = self._free_gaps(model, u)
        count = int(model.comm.allreduce(int(np.sum(gap < -tol * model.mesh_size)), op=MPI.SUM))
        return count, float(model.comm.allreduce(float(np.max(-gap, initial=0.0)), op=MPI.MAX))

    def free_slave_penetrations(self, model: ContactModel, u: Array, tol: float = 1e-8) -> int:
        return self._free_penetration(model, u, tol)[0]

    def free_slave_depth(self, model: ContactModel, u: Array) -> float:
        return self._free_penetration(model, u)[1]

    def shared_depth(self, model: ContactModel, u: Array) -> float:
        """A node on a pair's slave surface and on the obstacles' contact boundary meets one constraint, the one with
        the smaller gap (:meth:`_merge`): the deepest penetration max(−g, 0) in X + u (``u`` physical) of the other
        one — a node the pair took into an obstacle, or a node an obstacle took into the pair's master surface (its
        linearized pair gap; collective; 0 without such nodes)."""
        obstacle_map = self._obstacle_map
        if obstacle_map is None or self.pairing is None or not self.pairing.shared:
            return 0.0
        taken = np.isin(obstacle_map.blocks, self.pairing.blocks)
        ug = model.ghosted(u).reshape(-1, 3)
        x = obstacle_map.coordinates[taken] + ug[obstacle_map.blocks[taken]]
        _, gap, _, _ = closest_obstacle(model.obstacles, x)
        depth = max(float(np.max(-gap, initial=0.0)), float(np.max(-self._given_gaps(model, u), initial=0.0)))
        return float(model.comm.allreduce(depth, op=MPI.MAX))

    def master_depth(self, model: ContactModel, u: Array) -> tuple[float, Array | None, float]:
        assert self.pairing is not None and self.body_of_block is not None
        nodes = [self.pairing.blocks[self.pairing.pair_index == i] for i in range(len(self.pairs))]
        return master_excess(model.V, list(self.pairs), model.V.tabulate_dof_coordinates()
                             + model.ghosted(u).reshape(-1, 3), nodes, self.body_of_block)

    def uncovered_depth(self, model: ContactModel, u: Array) -> tuple[float, Array | None]:
        assert self.pairing is not None and self.body_of_block is not None
        x = model.V.tabulate_dof_coordinates() + model.ghosted(u).reshape(-1, 3)
        return uncovered_depth(model.V, self.pairs, self.pairing, x, self.body_of_block, self._excluded, model.held)

    def partner_sizes(self, sizes: Array) -> Array:
        assert self.pairing is not None
        sizes[self._paired] = self.pairing.partner_size  # the pairing's nodes, in the same ascending block order
        return sizes

    def contact_areas(self, areas: Array) -> Array:
        """D_j on a dual mortar pair's slave nodes (the pressure there is f_j·n_j / D_j)."""
        assert self.pairing is not None
        mortar = np.isfinite(self.pairing.area)  # the pairing's order, as partner_sizes
        areas[np.flatnonzero(self._paired)[mortar]] = self.pairing.area[mortar]
        return areas

    def contact_groups(self, obstacle_index: npt.NDArray[np.int64], num_obstacles: int) -> npt.NDArray[np.int64]:
        assert self.pairing is not None
        group = np.array(obstacle_index, dtype=np.int64).reshape(-1)
        if self._paired.any():
            group[self._paired] = num_obstacles + np.asarray(self.pairing.pair_index, dtype=np.int64)
        return group

    def balance_sum(self, model: ContactModel, residual: Array, contact_force: Array,
                    clamped_blocks: npt.NDArray[np.int32]) -> Array:
        """:func:`~fenics_coulomb.model.pairs.forces.balance_sum` with the master forces of ``contact_force``."""
        master = self.master_forces(contact_force, model.contact.local_dofs)
        return balance_sum(model, residual, contact_force, master, clamped_blocks)

    def pair_forces(self, model: ContactModel, result: SolveResult) -> list[dict[str, Any]]:
        return pair_forces(model, result, self.pairs)

    def output_fields(self, model: ContactModel, result: SolveResult, S: dolfinx.fem.FunctionSpace,
                      to_scalar: npt.NDArray[np.int32]) -> tuple[dolfinx.fem.Function, ...]:
        """``body`` (1, 2, …: the body of every node) and ``master_reaction`` (the reaction on the master nodes)."""
        fields: tuple[dolfinx.fem.Function, ...] = ()
        if self.num_bodies > 1:
            body = dolfinx.fem.Function(S, name="body")
            body.x.array[to_scalar] = np.asarray(self.body_of_block, dtype=np.float64) + 1.0
            body.x.scatter_forward()
            fields = (body,)
        reaction = dolfinx.fem.Function(model.V, name="master_reaction")
        if result.master_force is not None:
            set_owned_values(reaction, result.master_force)
        return (*fields, reaction)

    def summary_entries(self, model: ContactModel, result: SolveResult, per_pair: list[dict[str, Any]]
                        ) -> dict[str, Any]:
        """``contact_pairs``: the pair forces (:func:`~fenics_coulomb.model.pairs.forces.pair_forces`), statistics."""
        return {"contact_pairs": [{**forces, **{k: v for k, v in stats.items() if k != "name"}}
                                  for forces, stats in zip(pair_forces(model, result), per_pair, strict=False)]}

    def destroy(self) -> None:
        for obj in (self.M, self.A_free, self._free_coupling, self._given_coupling, self._physical_stiffness):
            if obj is not None:
                obj.destroy()
        self.M = self.A_free = self._free_coupling = self._given_coupling = self._physical_stiffness = None
        self._product.destroy()
