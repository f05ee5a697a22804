"""The contact-node extractor: contact facets' DOFs as per-node 3-blocks, each node with its obstacle frame.

Each contact node belongs to the rigid obstacle (:mod:`fenics_coulomb.model.obstacles`) with the smallest signed
distance g of its reference position; that obstacle gives the node's outward normal n and its frame
R = (t₁, t₂, n) (columns), so its local components are Rᵀu = (t₁·u, t₂·u, n·u). For the default plane
x3 = 0 the frame is the identity (tangential u1, u2; normal u3; gap = height). A contact node is a vertex of
the contact boundary not all of whose components carry a Dirichlet condition; every node is owned by exactly
one rank, which holds its block of three DOFs in its owned part of the PETSc vectors.

A node whose Dirichlet conditions hold one or two components (a symmetry plane or a roller through the contact
zone) stays a contact node when each held direction is orthogonal to its normal: its frame puts the held
directions first and its contact law acts on the others (:func:`~fenics_coulomb.model.frames.held_frames`, whose
module docstring derives it). A node with all three components held, or with a held direction along its normal
(|n·e_h| > HELD_NORMAL_TOL in the reference placement: its support moves it along the normal), or held at a
non-zero value (the support drives it along the contact, a friction the law does not model), is no contact node
(logged); a later placement that turns a contact node's normal off its held directions, or makes it slip along
one, is an InputError naming the node.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import check_all
from fenics_coulomb.model.frames import HELD_NORMAL_TOL, held_frames, local_held
from fenics_coulomb.model.obstacles import DEFAULT_PLANE, Obstacle, closest_obstacle

__all__ = ["boundary_blocks", "held_blocks", "hold", "ContactMap"]

logger = logging.getLogger(__name__)


def held_blocks(V: dolfinx.fem.FunctionSpace, dirichlet: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Which Cartesian components of every local DOF block (owned and ghost) the Dirichlet DOFs hold.

    Args:
        V: Vector P1 function space (block size 3).
        dirichlet: Local unrolled DOF indices (owned and ghost) that carry a Dirichlet condition.

    Returns:
        Shape (blocks, 3).
    """
    imap = V.dofmap.index_map
    held = np.zeros(3 * (imap.size_local + imap.num_ghosts), dtype=bool)
    held[np.asarray(dirichlet, dtype=np.int64)] = True
    return held.reshape(-1, 3)


def _log_supported(conflict: npt.NDArray[np.bool_], held: npt.NDArray[np.bool_], frames: npt.NDArray[np.float64],
                   coordinates: npt.NDArray[np.float64], comm: MPI.Comm) -> None:
    """Log on rank 0 how many contact-boundary nodes a support holds along their normal (no contact nodes) and
    where the first is (collective)."""
    count = comm.allreduce(int(np.sum(conflict)), op=MPI.SUM)
    if not count:
        return
    first = coordinates[np.flatnonzero(conflict)[0]].tolist() if np.any(conflict) else None
    where = next(w for w in comm.allgather(first) if w is not None)
    if comm.rank == 0:
        logger.info("%d contact-boundary node(s) with a held component not orthogonal to the contact normal (the "
                    "first at (%s)) are moved by their support, not contact nodes", count,
                    ", ".join(f"{c:.6g}" for c in where))


def hold(frames: npt.NDArray[np.float64], held: npt.NDArray[np.bool_], coordinates: npt.NDArray[np.float64],
         comm: MPI.Comm) -> npt.NDArray[np.float64]:
    """The frames of contact nodes with held components (:func:`~fenics_coulomb.model.frames.held_frames`) at a new
    placement of the obstacles or configuration; InputError on every rank (collective) naming the first node, on
    any rank, whose held direction is no longer orthogonal to its normal (an obstacle moved or turned off a
    symmetry plane: the model's symmetry does not hold)."""
    if not comm.allreduce(bool(np.any(held)), op=MPI.LOR):
        return frames
    out, conflict = held_frames(frames, held)
    message = ""
    if np.any(conflict):
        i = int(np.flatnonzero(conflict)[0])
        n = frames[i, :, 2]
        axes = ", ".join(f"x{k + 1}" for k in np.flatnonzero(held[i]))
        where = "(" + ", ".join(f"{c:.6g}" for c in coordinates[i]) + ")"
        message = (f"contact node at {where}: a Dirichlet condition holds its {axes} component(s), but its contact "
                   f"normal is now ({', '.join(f'{c:.4g}' for c in n)}), not orthogonal to them (|n·e| > "
                   f"{HELD_NORMAL_TOL:g}): a symmetry plane or roller through the contact needs the obstacle's "
                   "motion to keep the symmetry")
    messages = comm.allgather(message)
    first = next((m for m in messages if m), "")
    check_all(comm, not first, first)
    return out


def boundary_blocks(
    V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags, tags: list[int]
) -> npt.NDArray[np.int32]:
    """Local DOF-block indices (owned and ghost) on the facets carrying any of ``tags``."""
    fdim = V.mesh.topology.dim - 1
    facets = np.hstack([facet_tags.find(t) for t in tags]).astype(np.int32) if tags else np.zeros(0, np.int32)
    return np.unique(dolfinx.fem.locate_dofs_topological(V, fdim, facets))


@dataclass
class ContactMap:
    """Owned contact nodes of a vector P1 space.

    Attributes:
        blocks: Local (owned) DOF-block index of each contact node, ascending, shape (m,).
        local_dofs: Local DOF indices (owned numbering) of the node blocks, shape (m, 3).
        global_dofs: Global DOF (PETSc row) indices, shape (m, 3).
        coordinates: Reference coordinates of the nodes, shape (m, 3).
        gap: Signed distance g of each node from its obstacle (> 0 outside), shape (m,).
        frames: Frame R = (t₁, t₂, n) (columns) of each node, shape (m, 3, 3).
        obstacle_index: Index of each node's obstacle in the problem's list, shape (m,).
        num_global: Number of contact nodes on all ranks (p).
        held: Which Cartesian components a Dirichlet condition holds at each node, shape (m, 3) (None: none).
    """

    blocks: npt.NDArray[np.int32]
    local_dofs: npt.NDArray[np.int32]
    global_dofs: npt.NDArray[np.int64]
    coordinates: npt.NDArray[np.float64]
    gap: npt.NDArray[np.float64]
    frames: npt.NDArray[np.float64]
    obstacle_index: npt.NDArray[np.intp]
    num_global: int
    held: npt.NDArray[np.bool_] | None = None

    @property
    def held_components(self) -> npt.NDArray[np.bool_]:
        """Which Cartesian components a Dirichlet condition holds at each node, shape (m, 3)."""
        return np.zeros((self.size, 3), dtype=bool) if self.held is None else self.held

    @property
    def held_local(self) -> npt.NDArray[np.bool_]:
        """The held LOCAL components (t₁, t₂, n) of each node (the first tangents), shape (m, 3)."""
        return local_held(self.held_components)

    @property
    def normals(self) -> npt.NDArray[np.float64]:
        """Outward unit normal n of each node's obstacle, shape (m, 3)."""
        return np.ascontiguousarray(self.frames[:, :, 2])

    def subset(self, keep: npt.NDArray[np.bool_], comm: MPI.Comm) -> ContactMap:
        """The map of the nodes ``keep`` selects (collective: the global count)."""
        return ContactMap(blocks=self.blocks[keep], local_dofs=self.local_dofs[keep],
                          global_dofs=self.global_dofs[keep], coordinates=self.coordinates[keep], gap=self.gap[keep],
                          frames=self.frames[keep], obstacle_index=self.obstacle_index[keep],
                          num_global=comm.allreduce(int(np.sum(keep)), op=MPI.SUM),
                          held=None if self.held is None else self.held[keep])

    @property
    def size(self) -> int:
        """Number of contact nodes owned by this rank."""
        return int(self.blocks.size)

    @classmethod
    def create(
        cls,
        V: dolfinx.fem.FunctionSpace,
        facet_tags: dolfinx.mesh.MeshTags,
        contact_tags: list[int],
        excluded: npt.NDArray[np.int32],
        obstacles: list[Obstacle] | None = None,
        held: npt.NDArray[np.bool_] | None = None,
    ) -> ContactMap:
        """Extract the contact nodes of ``V`` on the facets with ``contact_tags``, minus excluded nodes.

        Args:
            V: Vector P1 function space (block size 3).
            facet_tags: Boundary markers of the mesh.
            contact_tags: Tags of the contact boundary.
            excluded: Local DOF-block indices that are never contact nodes (clamped nodes).
            obstacles: The rigid obstacles (placed at their displacements; default: the plane x3 = 0).
            held: Which Cartesian components a Dirichlet condition holds at every local DOF block, shape
                (blocks, 3) (:func:`held_blocks`; None: none). Nodes with held components get the frames of
                :func:`hold` (collective; an InputError for a held direction along the normal).
        """
        bs = V.dofmap.index_map_bs
        if bs != 3:
            raise ValueError(f"contact needs a 3D vector space (block size 3), got block size {bs}")
        imap = V.dofmap.index_map
        candidates = boundary_blocks(V, facet_tags, contact_tags)
        blocks = np.setdiff1d(candidates, excluded)
        blocks = blocks[blocks < imap.size_local].astype(np.int32)
        offsets = np.arange(3, dtype=np.int32)
        local_dofs = (bs * blocks[:, None] + offsets).astype(np.int32)
        global_blocks = blocks.astype(np.int64) + imap.local_range[0]
        global_dofs = bs * global_blocks[:, None] + offsets.astype(np.int64)
        coordinates = V.tabulate_dof_coordinates()[blocks]
        index, gap, _, frames = closest_obstacle(obstacles or [DEFAULT_PLANE], coordinates.reshape(-1, 3))
        node_held = None
        if held is not None:
            node_held = np.ascontiguousarray(held[blocks])
            frames, conflict = held_frames(frames, node_held)
            _log_supported(conflict, node_held, frames, coordinates, V.mesh.comm)
            keep = ~conflict
            blocks, local_dofs, global_dofs, coordinates = blocks[keep], local_dofs[keep], global_dofs[keep], \
                coordinates[keep]
            index, gap, frames, node_held = index[keep], gap[keep], frames[keep], node_held[keep]
        num_global = V.mesh.comm.allreduce(int(blocks.size), op=MPI.SUM)
        return cls(
            blocks=blocks,
            local_dofs=local_dofs,
            global_dofs=global_dofs,
            coordinates=np.ascontiguousarray(coordinates),
            gap=np.ascontiguousarray(gap),
            frames=np.ascontiguousarray(frames),
            obstacle_index=index,
            num_global=num_global,
            held=node_held,
        )
