"""The contact-node extractor: contact facets' DOFs as per-node 3-blocks, each node with its obstacle frame.

Each contact node belongs to the rigid obstacle (:mod:`fenics_coulomb.model.obstacles`) with the smallest signed
distance g of its reference position; that obstacle gives the node's outward normal n and its frame
R = (t₁, t₂, n) (columns), so its local components are Rᵀu = (t₁·u, t₂·u, n·u). For the default plane
x3 = 0 the frame is the identity (tangential u1, u2; normal u3; gap = height). A contact node is a vertex of
the contact boundary none of whose components carries a Dirichlet condition; every node is owned by exactly
one rank, which holds its block of three DOFs in its owned part of the PETSc vectors.
"""

from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.obstacles import DEFAULT_PLANE, Obstacle, closest_obstacle

__all__ = ["boundary_blocks", "ContactMap"]


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
    """

    blocks: npt.NDArray[np.int32]
    local_dofs: npt.NDArray[np.int32]
    global_dofs: npt.NDArray[np.int64]
    coordinates: npt.NDArray[np.float64]
    gap: npt.NDArray[np.float64]
    frames: npt.NDArray[np.float64]
    obstacle_index: npt.NDArray[np.intp]
    num_global: int

    @property
    def normals(self) -> npt.NDArray[np.float64]:
        """Outward unit normal n of each node's obstacle, shape (m, 3)."""
        return np.ascontiguousarray(self.frames[:, :, 2])

    def subset(self, keep: npt.NDArray[np.bool_], comm: MPI.Comm) -> ContactMap:
        """The map of the nodes ``keep`` selects (collective: the global count)."""
        return ContactMap(blocks=self.blocks[keep], local_dofs=self.local_dofs[keep],
                          global_dofs=self.global_dofs[keep], coordinates=self.coordinates[keep], gap=self.gap[keep],
                          frames=self.frames[keep], obstacle_index=self.obstacle_index[keep],
                          num_global=comm.allreduce(int(np.sum(keep)), op=MPI.SUM))

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
    ) -> ContactMap:
        """Extract the contact nodes of ``V`` on the facets with ``contact_tags``, minus excluded nodes.

        Args:
            V: Vector P1 function space (block size 3).
            facet_tags: Boundary markers of the mesh.
            contact_tags: Tags of the contact boundary.
            excluded: Local DOF-block indices that are never contact nodes (nodes with a Dirichlet condition
                on any component).
            obstacles: The rigid obstacles (placed at their displacements; default: the plane x3 = 0).
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
        num_global = V.mesh.comm.allreduce(int(blocks.size), op=MPI.SUM)
        index, gap, _, frames = closest_obstacle(obstacles or [DEFAULT_PLANE], coordinates.reshape(-1, 3))
        return cls(
            blocks=blocks,
            local_dofs=local_dofs,
            global_dofs=global_dofs,
            coordinates=np.ascontiguousarray(coordinates),
            gap=np.ascontiguousarray(gap),
            frames=np.ascontiguousarray(frames),
            obstacle_index=index,
            num_global=num_global,
        )
