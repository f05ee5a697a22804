"""Partition quality: fenics_coulomb.scenes.partition (recursive coordinate bisection) against PT-Scotch.

    container/run python3 benchmarks/partition.py --lev 8 --parts 2 4 8 16 --out docs/partition

Serial: both partitioners are called on the whole cell dual graph (facet neighbours, as DOLFINx builds
it) with nparts = 2 … 16, on the cuboid at level ``--lev`` and on meshes/roller.msh. Per partition:
the edge cut (dual-graph edges, i.e. interior facets, between parts), the balance max/mean cells per part,
the ghost cells of a shared_facet mesh (summed over parts, and the largest part's), and, for PT-Scotch,
whether a second call in the same process returned the same partition.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import write_table
from dolfinx import cpp as _cpp

from fenics_coulomb.scenes.meshes import read_gmsh
from fenics_coulomb.scenes.partition import recursive_bisection
from fenics_coulomb.scenes.cuboid import HEIGHT, LENGTH, WIDTH, cells_per_direction

ROOT = Path(__file__).resolve().parent.parent


def box_cells(lev: int) -> tuple[np.ndarray, np.ndarray, _cpp.mesh.CellType]:
    """Cells (DOLFINx hexahedron vertex order, create_box's vertex numbering) and vertex coordinates."""
    n0, n1, n2 = cells_per_direction(lev)
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(n0), np.arange(n1), np.arange(n2), indexing="ij"))
    order = np.lexsort((i, j, k))  # create_box orders cells with i fastest
    i, j, k = i[order], j[order], k[order]

    def v(a, b, c):
        return a + (n0 + 1) * (b + (n1 + 1) * c)

    cells = np.stack([v(i, j, k), v(i + 1, j, k), v(i, j + 1, k), v(i + 1, j + 1, k),
                      v(i, j, k + 1), v(i + 1, j, k + 1), v(i, j + 1, k + 1), v(i + 1, j + 1, k + 1)], axis=1)
    gi, gj, gk = np.meshgrid(np.arange(n0 + 1), np.arange(n1 + 1), np.arange(n2 + 1), indexing="ij")
    x = np.zeros(((n0 + 1) * (n1 + 1) * (n2 + 1), 3))
    x[v(gi, gj, gk).ravel()] = np.stack([gi.ravel() * LENGTH / n0, gj.ravel() * WIDTH / n1,
                                         gk.ravel() * HEIGHT / n2], axis=1)
    return cells.astype(np.int64), x, _cpp.mesh.CellType.hexahedron


def gmsh_cells(path: Path) -> tuple[np.ndarray, np.ndarray, _cpp.mesh.CellType]:
    msh, _ = read_gmsh(str(path), MPI.COMM_SELF)
    cells = msh.geometry.input_global_indices[msh.geometry.dofmap]
    x = np.zeros_like(msh.geometry.x)
    x[msh.geometry.input_global_indices] = msh.geometry.x
    return cells.astype(np.int64), x, msh.topology.cell_type


def quality(parts: np.ndarray, graph: _cpp.graph.AdjacencyList_int64, nparts: int) -> dict[str, float]:
    node = np.repeat(np.arange(graph.num_nodes), np.diff(graph.offsets))
    nbr = np.asarray(graph.array)
    cut = parts[node] != parts[nbr]
    counts = np.bincount(parts, minlength=nparts)
    # ghosts of part q: cells not in q with a facet neighbour in q
    ghosts = np.unique(nbr[cut] * nparts + parts[node[cut]])
    ghosts_per_part = np.bincount(ghosts % nparts, minlength=nparts)
    return {"edge_cut": int(cut.sum() // 2), "balance": float(counts.max() / counts.mean()),
            "ghosts_total": int(ghosts_per_part.sum()), "ghosts_max": int(ghosts_per_part.max())}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lev", type=int, default=8)
    parser.add_argument("--parts", type=int, nargs="+", default=[2, 4, 8, 16])
    parser.add_argument("--mesh", type=Path, default=ROOT / "meshes" / "roller.msh")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "partition")
    args = parser.parse_args()
    comm = MPI.COMM_SELF
    rows = []
    for name, (cells, x, cell_type) in ((f"cuboid lev {args.lev}", box_cells(args.lev)),
                                        (args.mesh.name, gmsh_cells(args.mesh))):
        graph = _cpp.mesh.build_dual_graph(comm, [cell_type], [cells.ravel()])
        midpoints = x[cells].mean(axis=1)
        for nparts in args.parts:
            rcb = recursive_bisection(midpoints, nparts)
            scotch = _cpp.graph.partitioner_scotch()
            s1 = np.asarray(scotch(comm, nparts, graph, False).array)
            s2 = np.asarray(scotch(comm, nparts, graph, False).array)
            for label, parts, repeat in (("rcb", rcb, bool(np.array_equal(rcb, recursive_bisection(midpoints,
                                                                                                    nparts)))),
                                         ("pt-scotch", s1, bool(np.array_equal(s1, s2)))):
                rows.append({"mesh": name, "cells": len(cells), "parts": nparts, "partitioner": label,
                             **quality(parts.astype(np.int64), graph, nparts), "repeats": repeat})
                print(rows[-1], flush=True)
    write_table(args.out, "partition-quality",
                "Partition quality: recursive coordinate bisection (fenics_coulomb.scenes.partition) vs PT-Scotch",
                rows, MPI.COMM_WORLD)
    return 0


if __name__ == "__main__":
    sys.exit(main())
