"""TEMPORARY stub (not committed): flat matching interfaces only."""
from __future__ import annotations
from dataclasses import dataclass
from collections.abc import Sequence
from mpi4py import MPI
import dolfinx, numpy as np
from fenics_coulomb.obstacles import frames_from_normals

@dataclass(frozen=True)
class ContactPair:
    facet_tags: object
    slave: int
    master: int
    friction: float = 0.0
    search_distance: float | None = None
    name: str | None = None

@dataclass
class Pairing:
    blocks: np.ndarray; coordinates: np.ndarray; closest: np.ndarray; gap: np.ndarray; frames: np.ndarray
    master_blocks: np.ndarray; weights: np.ndarray; pair_index: np.ndarray; friction: np.ndarray; num_global: int

def pair_surfaces(V, pairs, excluded):
    comm = V.mesh.comm
    pair = pairs[0]
    imap = V.dofmap.index_map
    x = V.tabulate_dof_coordinates()
    fdim = 2
    def blocks_of(tag):
        f = pair.facet_tags.find(tag)
        return np.unique(dolfinx.fem.locate_dofs_topological(V, fdim, f))
    s = blocks_of(pair.slave); s = np.setdiff1d(s, excluded); s = s[s < imap.size_local].astype(np.int32)
    m = blocks_of(pair.master); m = m[m < imap.size_local]
    gm = imap.local_to_global(m.astype(np.int32))
    allx = np.concatenate(comm.allgather(x[m])); allg = np.concatenate(comm.allgather(gm))
    xs = x[s]
    d = np.linalg.norm(xs[:, None, :2] - allx[None, :, :2], axis=2)
    j = np.argmin(d, axis=1)
    ok = d[np.arange(len(s)), j] < 1e-9
    s, j, xs = s[ok], j[ok], xs[ok]
    n = np.tile([0.0, 0.0, 1.0], (len(s), 1))
    mb = np.full((len(s), 4), -1, np.int64); mb[:, 0] = allg[j]
    w = np.zeros((len(s), 4)); w[:, 0] = 1.0
    return Pairing(s, xs, allx[j], xs[:, 2] - allx[j, 2], frames_from_normals(n), mb, w,
                   np.zeros(len(s), np.intp), np.full(len(s), pair.friction), comm.allreduce(len(s)))
