"""Two disjoint blocks in ONE DOLFINx mesh: a lower block and a smaller upper block resting on it (issue 18).

The lower block is [0, Lx] × [0, Ly] × [−H, 0] with nx × ny × nz cells; the upper block is
[x0, x0 + ax] × [y0, y0 + ay] × [gap, gap + h] with its own (non-matching) resolution. Both are structured
grids of hexahedra (Q1) or of tetrahedra (each hexahedron split into the 6 tetrahedra around its main
diagonal, as ``dolfinx.mesh.create_box`` does), merged into one mesh with ``dolfinx.mesh.create_mesh``; the
two bodies share no vertex, so they are disconnected parts of one function space.

``lower_top`` bends the lower block's top: a function (x, y) ↦ Δz moves every lower vertex by
Δz(x, y)·(z + H)/H (the bottom stays flat), so e.g. Δz = c·x·y makes each Q1 top facet a non-planar bilinear
patch (exactly the hyperbolic paraboloid z = c·x·y).

Tags (``BODIES``, ``TAGS``)::

    cell tags   1 "lower", 2 "upper"
    facet tags  1 "lower_top"   2 "upper_bottom"   3 "lower_bottom"   4 "upper_top"
                5 "lower_sides" 6 "upper_sides"

The facets are tagged from the UNDEFORMED grid (so ``lower_top`` also holds for a bent top). The default
partitioner is the deterministic recursive coordinate bisection of :mod:`fenics_coulomb.scenes.partition`; pass
e.g. :func:`body_partitioner` to put each body on its own rank (a master facet on another rank than its
slave nodes).

Run inside the environment to write an XDMF file:
``container/run python3 meshes/two_blocks.py --cell hexahedron --out out/two_blocks.xdmf``.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from mpi4py import MPI

import basix.ufl
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.scenes.partition import create_partitioner

BODIES = {"lower": 1, "upper": 2}
TAGS = {"lower_top": 1, "upper_bottom": 2, "lower_bottom": 3, "upper_top": 4, "lower_sides": 5, "upper_sides": 6}

#: The 6 tetrahedra of a hexahedron (local vertices numbered x + 2y + 4z) around its diagonal 0–7.
_KUHN = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]])


@dataclass
class TwoBlocks:
    """The mesh with its tags.

    Attributes:
        mesh: The mesh of both bodies.
        cell_tags: ``BODIES`` values per cell.
        facet_tags: ``TAGS`` values on the exterior facets.
    """

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags
    facet_tags: dolfinx.mesh.MeshTags


def _grid(origin: npt.ArrayLike, size: npt.ArrayLike, n: Sequence[int],
          cell_type: str) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Vertices and cells (DOLFINx vertex order) of a structured box grid."""
    nx, ny, nz = (int(v) for v in n)
    axes = [np.linspace(o, o + s, k + 1) for o, s, k in zip(origin, size, (nx, ny, nz), strict=True)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    base = (i + (nx + 1) * (j + (ny + 1) * k)).ravel()
    shift = np.array([0, 1, nx + 1, nx + 2])
    layer = (nx + 1) * (ny + 1)
    hexes = base[:, None] + np.concatenate([shift, shift + layer])[None, :]
    if cell_type == "hexahedron":
        return points, hexes
    return points, hexes[:, _KUHN].reshape(-1, 4)


def body_partitioner(num_lower: int, vertices_per_cell: int) -> Callable:
    """A partitioner (for 2 ranks or more) putting the first body's cells on rank 0 and the others on rank 1.

    Args:
        num_lower: Number of cells of the first body (they come first in the input order of :func:`boxes_mesh`).
        vertices_per_cell: 8 (hexahedra) or 4 (tetrahedra).
    """
    from dolfinx import cpp

    def partition(comm: MPI.Comm, nparts: int, cell_types: list, cells: list) -> cpp.graph.AdjacencyList_int32:
        count = np.asarray(cells[0]).size // vertices_per_cell
        offsets = comm.scan(count) - count
        index = offsets + np.arange(count)
        dest = np.where(index < num_lower, 0, min(1, nparts - 1)).astype(np.int32)
        return cpp.graph.AdjacencyList_int32(dest)

    return partition


def boxes_mesh(comm: MPI.Comm, boxes: Sequence[tuple[Sequence[float], Sequence[float], Sequence[int]]],
               cell_type: str = "hexahedron", partitioner: Callable | str | None = None,
               ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none
               ) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """Disjoint structured boxes in one mesh, cell tags 1, 2, ... per box (in the order given).

    Args:
        comm: Communicator of the mesh (collective).
        boxes: (origin, size, cells per direction) of each box.
        cell_type: "hexahedron" (Q1) or "tetrahedron" (P1).
        partitioner: A DOLFINx cell partitioner, "bodies" (box 1 on rank 0, the others on rank 1, see
            :func:`body_partitioner`) or None (deterministic recursive coordinate bisection).
        ghost_mode: Ghosting of the default partitioner (``shared_facet``: a layer of ghost cells).
    """
    if cell_type not in ("hexahedron", "tetrahedron"):
        raise ValueError(f"cell_type {cell_type!r}: choose 'hexahedron' or 'tetrahedron'")
    grids = [_grid(origin, size, n, cell_type) for origin, size, n in boxes]
    first = np.cumsum([0] + [g[0].shape[0] for g in grids])
    ends = np.cumsum([g[1].shape[0] for g in grids])
    nv = grids[0][1].shape[1]
    if comm.rank == 0:
        x = np.concatenate([g[0] for g in grids])
        cells = np.concatenate([g[1] + f for g, f in zip(grids, first, strict=False)])
    else:
        x, cells = np.zeros((0, 3)), np.zeros((0, nv), dtype=np.int64)
    if partitioner is None:
        partitioner = create_partitioner(comm, x, ghost_mode)
    elif partitioner == "bodies":
        partitioner = body_partitioner(int(ends[0]), nv)
    domain = ufl.Mesh(basix.ufl.element("Lagrange", cell_type, 1, shape=(3,)))
    msh = dolfinx.mesh.create_mesh(comm, cells, x, domain, partitioner=partitioner)
    cmap = msh.topology.index_map(3)
    num_cells = cmap.size_local + cmap.num_ghosts
    body = (np.searchsorted(ends, msh.topology.original_cell_index[:num_cells], side="right") + 1).astype(np.int32)
    return msh, dolfinx.mesh.meshtags(msh, 3, np.arange(num_cells, dtype=np.int32), body)


def two_blocks(comm: MPI.Comm = MPI.COMM_WORLD, *, lower: Sequence[float] = (1.0, 1.0, 0.5),
               n_lower: Sequence[int] = (4, 4, 2), upper_origin: Sequence[float] = (0.25, 0.25),
               upper: Sequence[float] = (0.5, 0.5, 0.25), n_upper: Sequence[int] = (3, 3, 2), gap: float = 0.0,
               cell_type: str = "hexahedron", lower_top: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
               partitioner: Callable | str | None = None,
               ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.none) -> TwoBlocks:
    """The lower block [0, Lx]×[0, Ly]×[−H, 0] and the upper block [x0, x0+ax]×[y0, y0+ay]×[gap, gap+h].

    Args:
        comm: Communicator of the mesh (collective).
        lower: (Lx, Ly, H).
        n_lower: Cells of the lower block per direction.
        upper_origin: (x0, y0) of the upper block.
        upper: (ax, ay, h).
        n_upper: Cells of the upper block per direction.
        gap: Height of the upper block's bottom above the lower block's top (0: resting on it).
        cell_type: "hexahedron" (Q1) or "tetrahedron" (P1).
        lower_top: Optional Δz(x, y) bending the lower block's top (see the module docstring).
        partitioner: A DOLFINx cell partitioner, "bodies" (:func:`body_partitioner`) or None (deterministic
            recursive coordinate bisection).
        ghost_mode: Ghosting of the default partitioner.

    Returns:
        The mesh with cell tags (``BODIES``) and facet tags (``TAGS``).
    """
    Lx, Ly, H = (float(v) for v in lower)
    boxes = [((0.0, 0.0, -H), (Lx, Ly, H), n_lower), ((upper_origin[0], upper_origin[1], gap), upper, n_upper)]
    msh, cell_tags = boxes_mesh(comm, boxes, cell_type, partitioner, ghost_mode)
    body = cell_tags.values

    tdim, fdim = 3, 2
    msh.topology.create_connectivity(fdim, tdim)
    facets = dolfinx.mesh.exterior_facet_indices(msh.topology)
    f2c = msh.topology.connectivity(fdim, tdim)
    owner = f2c.array[f2c.offsets[facets]]  # an exterior facet has one cell
    on_lower = body[owner] == BODIES["lower"]
    mid = dolfinx.mesh.compute_midpoints(msh, fdim, facets)
    tol = 1e-10 * max(Lx, Ly, H, *upper)
    h = float(upper[2])
    values = np.zeros(facets.size, dtype=np.int32)
    z = mid[:, 2]
    values[on_lower] = np.where(np.abs(z[on_lower]) < tol, TAGS["lower_top"],
                                np.where(np.abs(z[on_lower] + H) < tol, TAGS["lower_bottom"], TAGS["lower_sides"]))
    up = ~on_lower
    values[up] = np.where(np.abs(z[up] - gap) < tol, TAGS["upper_bottom"],
                          np.where(np.abs(z[up] - gap - h) < tol, TAGS["upper_top"], TAGS["upper_sides"]))
    order = np.argsort(facets)
    facet_tags = dolfinx.mesh.meshtags(msh, fdim, facets[order], values[order])

    if lower_top is not None:  # bend the lower block's top (the tags above are those of the flat grid)
        dofs = np.unique(msh.geometry.dofmap[cell_tags.find(BODIES["lower"])])
        X = msh.geometry.x
        X[dofs, 2] += lower_top(X[dofs, 0], X[dofs, 1]) * (X[dofs, 2] + H) / H
    return TwoBlocks(msh, cell_tags, facet_tags)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cell", default="hexahedron", choices=["hexahedron", "tetrahedron"])
    parser.add_argument("--gap", type=float, default=0.0)
    parser.add_argument("--out", default="two_blocks.xdmf")
    args = parser.parse_args()
    blocks = two_blocks(MPI.COMM_WORLD, gap=args.gap, cell_type=args.cell)
    import dolfinx.io

    with dolfinx.io.XDMFFile(MPI.COMM_WORLD, args.out, "w") as f:
        blocks.mesh.topology.create_connectivity(2, 3)
        f.write_mesh(blocks.mesh)
        f.write_meshtags(blocks.cell_tags, blocks.mesh.geometry)
        f.write_meshtags(blocks.facet_tags, blocks.mesh.geometry)
