r"""Two elastic bodies in contact, reduced to the one-body problem by a change of variables (Remark 6.2).

The bodies are disconnected parts of one mesh with one vector P1/Q1 space and one stiffness matrix A_free
(assembled WITHOUT Dirichlet rows). A contact pair (:mod:`fenics_coulomb.model.pairs.pairing`) gives each slave contact
node s a stencil of master nodes with weights φ_sj (node-to-surface: the shape functions of the master facet at
the closest point x_m; dual mortar: M_sl / D_s), the gap g, the frame R = (t₁, t₂, n).

**Relative displacement.** w_s = u_s − Σ_j φ_sj u_j. Contact: g + n·w_s ≥ 0, λ ≥ 0, complementarity; Coulomb
friction on the slip T w_s (on a load path T(w_{s,k} − w_{s,k−1})): exactly the one-body conditions of the
contact block of a node, with u_s replaced by w_s.

**Change of variables.** Let Φ be the matrix with the slave-row, master-column 3×3 blocks φ_sj I₃, and

    u = M z,   M = I + Φ,   so   z = u − Φ u:   z_s = u_s − Σ_j φ_sj u_j = w_s  (…provided Φ u has no
                                                         slave entries in its own stencils: Φ² = 0)

Indeed z = M⁻¹ u, and with Φ² = 0, M⁻¹ = I − Φ: (I + Φ)(I − Φ) = I − Φ² = I. z_s = u_s − (Φ u)_s = w_s on slave
nodes; z_i = u_i elsewhere (Φ has only slave rows). Φ² = 0 holds exactly when no contact node is a node of
a master facet used by a contact node (the pairing checks it).

**The reduced GE.** The potential energy ½ uᵀA_free u − ⟨l, u⟩ in z is ½ zᵀ(Mᵀ A_free M)z − ⟨Mᵀ l, z⟩, and the
contact conditions act on the blocks z_s = w_s in their frames: the paper's one-body GE (6.3)

    0 ∈ Ã z − l̃_z + Q(z),   Ã = Mᵀ A_free M (PETSc PtAP),   l̃_z = Mᵀ l,

with Q the contact map of the slave nodes (gaps g, frames R, friction of their pair). The optimality
conditions in u follow by multiplying with M⁻ᵀ: A_free u − l = M⁻ᵀ(−q) where q ∈ Q(z); M⁻ᵀ = I − Φᵀ puts the
force f_s = −q_s on slave node s and −Σ_s φ_sj f_s on master node j (the reaction of the master body).

**Dirichlet conditions on z.** Slave contact nodes are never Dirichlet nodes, and Φ has only slave rows, so
z_D = u_D on the prescribed DOFs D. Eliminating them as in :mod:`fenics_coulomb.model.contact_model` (there for A):

    Ã ← Ã with rows and columns D replaced by s I (s = the mean free diagonal),
    l̃_z = Mᵀ (l − A_free M x_D) on the free DOFs, s u_D on D,

where x_D holds u_D on D and 0 elsewhere: (Ã x_D)_F = (Mᵀ A_free M x_D)_F is the lifting. A_free and M are
kept for this lifting (a load path re-lifts at every step) and for the physical residual.

**Near-nullspace.** The rigid modes r_b of body b (6 per body, zero on the other bodies) are the kernel of
the supportless elastic operator; in z they are M⁻¹ r_b = (I − Φ) r_b: these 6 × (number of bodies) vectors
are the near-nullspace of GAMG on Ã (the linear-solve reference of benchmarks/robustness.py). The solver's
GAMG is set up on the physical stiffness instead, with the six modes of the mesh
(:mod:`fenics_coulomb.scd.physical_preconditioner`). The estimate of γ comes from Ã (the solver's power method on the
model's matrix).

**Outputs.** u = M z. The contact force on slave node s is f_s = −q_s (the solver's contact force), on master
node j the reaction f_j = −Σ_s φ_sj f_s.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.la
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import check_all
from fenics_coulomb.model.nullspace import free_rigid_motions, held_by_stiffness, mean_free_diagonal, rigid_modes_at

if TYPE_CHECKING:
    from fenics_coulomb.model.pairs.pair import ContactPair

__all__ = ["HELD_FRACTION", "HeldByContact", "connected_bodies", "check_rigid_support", "held_fraction", "lost_support",
           "coupling_matrix", "linearized_pair_gaps", "body_rigid_modes"]

logger = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


def connected_bodies(V: dolfinx.fem.FunctionSpace) -> tuple[npt.NDArray[np.int64], int]:
    """The body (connected component of the mesh) of every local DOF block, owned and ghost (collective).

    Components are found on each rank's local cell–block graph, then merged across ranks through the blocks
    a rank shares with another (ghosts take the owner's component) and numbered by their smallest input
    (mesh file) node index, so the numbering does not depend on the partition. Needs P1/Q1 on a first-order
    mesh (one node per vertex), as the contact solver does.

    Returns:
        Body index per local block (owned then ghost), and the number of bodies.
    """
    import scipy.sparse as sp
    import scipy.sparse.csgraph as csgraph  # scipy only where used (fenics_coulomb/__init__.py)

    comm = V.mesh.comm
    imap = V.dofmap.index_map
    nlocal = imap.size_local + imap.num_ghosts
    cells = V.dofmap.list
    ncells, per_cell = cells.shape
    rows = np.repeat(np.arange(ncells), per_cell)
    graph = sp.csr_matrix((np.ones(rows.size), (rows, cells.ravel())), shape=(ncells, nlocal))
    adjacency = (graph.T @ graph).tocsr()
    count, local_label = csgraph.connected_components(adjacency, directed=False)
    offsets = np.cumsum([0, *comm.allgather(int(count))])
    label = local_label.astype(np.int64) + offsets[comm.rank]
    # equivalences: each ghost's component and its owner's component (owners send theirs forward)
    owner_label = dolfinx.la.vector(imap, bs=1, dtype=np.float64)
    owner_label.array[: imap.size_local] = label[: imap.size_local]
    owner_label.scatter_forward()
    ghosts = np.arange(imap.size_local, nlocal)
    pairs = np.column_stack([label[ghosts], owner_label.array[ghosts].astype(np.int64)])
    pairs = np.concatenate(comm.allgather(pairs)).reshape(-1, 2)
    total = int(offsets[-1])
    merged = sp.csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(total, total))
    _, body_of_label = csgraph.connected_components(merged, directed=False)
    body = body_of_label[label]
    # number the bodies by their smallest input (file) node index: independent of the partition
    geometry = V.mesh.geometry
    node_index = np.asarray(geometry.input_global_indices, dtype=np.int64)
    input_index = np.empty(nlocal, dtype=np.int64)
    input_index[cells.ravel()] = node_index[geometry.dofmap.ravel()]
    nb = int(body_of_label.max()) + 1 if total else 0
    first = np.full(nb, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first, body, input_index)
    comm.Allreduce(MPI.IN_PLACE, first, op=MPI.MIN)
    order = np.argsort(np.argsort(first))
    bodies = np.unique(order)
    return order[body].astype(np.int64), int(bodies.size)


def _surface_normals(V: dolfinx.fem.FunctionSpace, body: npt.NDArray[np.int64], facet_tags: dolfinx.mesh.MeshTags,
                     markers: Sequence[int]) -> tuple[npt.NDArray[np.int64], Array, Array]:
    """The body, midpoint and unit normal (either sign) of each local facet of the surface ``markers``."""
    msh = V.mesh
    facets = facet_tags.indices[np.isin(facet_tags.values, np.asarray(markers))].astype(np.int32)
    if facets.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    x = msh.geometry.x[dolfinx.mesh.entities_to_geometry(msh, 2, facets)]
    if x.shape[1] == 4:  # a quadrilateral (DOLFINx vertex order 0 1 / 2 3): the cross product of its diagonals
        normal = np.cross(x[:, 3] - x[:, 0], x[:, 2] - x[:, 1])
    else:
        normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1), np.finfo(float).tiny)[:, None]
    msh.topology.create_connectivity(2, 3)
    f2c = msh.topology.connectivity(2, 3)
    cells = f2c.array[f2c.offsets[facets]]
    return body[V.dofmap.list[cells, 0]], x.mean(axis=1), normal


#: The least normal fraction (:func:`held_fraction`) of a free rigid motion that contact is taken to hold. A
#: translation along a flat contact's normal has 1; a block held in x1, x2 on its top and resting on a flat face
#: rocks about an axis in its top with 0.048 (held: one side presses in); a shaft turning about its axis in a
#: bore of triangles, free in the continuum, has ∝ (h/R)²: 0.036, 0.019, 0.0079, 0.0044, 0.0011 for 6, 8, 12,
#: 16, 32 facets around. So from about 10 facets around such a turn is refused; on coarser facetings the facets'
#: corners do hold it in the discrete model, and it is accepted.
HELD_FRACTION = 0.01


def held_fraction(free: Array, normal_gram: Array, motion_gram: Array) -> float:
    """The smallest fraction vᵀG_c v / vᵀG_r v over the free rigid motions v ∈ span(``free``) (columns: mode
    coefficients): how much of the least-held free motion at the contact facets is along their normals (0 when
    the facets do not move under some free motion, or there are none)."""
    A = free.T @ normal_gram @ free
    B = free.T @ motion_gram @ free
    scale = float(np.trace(B))
    if free.shape[1] == 0:
        return 1.0
    if scale <= 0.0 or np.linalg.eigvalsh(B)[0] <= 1e-12 * scale:
        return 0.0
    L = np.linalg.cholesky(B)
    Li = np.linalg.inv(L)
    return float(np.linalg.eigvalsh(Li @ A @ Li.T)[0])


@dataclass(frozen=True)
class HeldByContact:
    """A body whose supports leave rigid motions free that contact alone holds (:func:`check_rigid_support`).

    Attributes:
        body: The body's index (:func:`connected_bodies`).
        centroid: Its centroid in the reference configuration.
        pairs: The indices of the contact pairs whose contact holds it.
    """

    body: int
    centroid: tuple[float, float, float] | tuple[float, ...]
    pairs: tuple[int, ...]

    def describe(self, labels: Sequence[str]) -> str:
        """The body and its holding pairs in words (``labels``: every pair's label)."""
        where = ", ".join(f"{c:.4g}" for c in self.centroid)
        pairs = ", ".join(labels[i] for i in self.pairs)
        return f"body {self.body} (centroid ({where})) is held by contact alone ({pairs})"

    def describe_lost(self, labels: Sequence[str], closed: int) -> str:
        """Why a solve failed, for this body with ``closed`` contact nodes of its pairs closed in the last iterate."""
        if closed == 0:
            return self.describe(labels) + (": no contact node of it is closed in the last iterate — the loads lift it "
                                            "off, and nothing holds its rigid motion (support it, or load it onto its "
                                            "partner)")
        return self.describe(labels) + (f": {closed} contact node(s) of it closed in the last iterate — if the loads "
                                        "lift it off, nothing holds its rigid motion (support it, or load it onto its "
                                        "partner)")


def lost_support(comm: MPI.Comm, held_by_contact: Sequence[HeldByContact], pairs: Sequence[ContactPair],
                 pair_index: npt.NDArray[np.intp], closed: npt.NDArray[np.bool_] | None,
                 lifted_only: bool = False) -> str | None:
    """Why a solve failed or must not pass, for the bodies held by contact alone: each such body, with how many of
    its pairs' contact nodes are closed (``closed``: the pairing's nodes' mask in the last iterate; None: no iterate);
    ``lifted_only``: only the bodies with none closed (a converged solve's check). None when none is named
    (collective)."""
    labels = [f"{pair.label} {i + 1}" for i, pair in enumerate(pairs)]
    if closed is None:  # no last iterate (e.g. a linear solve that broke down)
        return "; ".join(held.describe(labels) for held in held_by_contact) + (
            ": if the loads lift it off, nothing holds its rigid motion (support it, or load it onto its partner)")
    counts = np.ascontiguousarray(np.bincount(pair_index[closed], minlength=len(pairs)).astype(np.int64)[:len(pairs)])
    comm.Allreduce(MPI.IN_PLACE, counts, op=MPI.SUM)
    lost = [held.describe_lost(labels, int(counts[list(held.pairs)].sum())) for held in held_by_contact
            if not lifted_only or not counts[list(held.pairs)].sum()]
    return "; ".join(lost) or None


def check_rigid_support(V: dolfinx.fem.FunctionSpace, body: npt.NDArray[np.int64], num_bodies: int,
                        dirichlet: npt.NDArray[np.int32], pairs: Sequence[ContactPair] = (),
                        stiffness: PETSc.Mat | None = None) -> list[HeldByContact]:
    """InputError on every rank unless every body's rigid motions are held: by its Dirichlet DOFs or its stiffness
    (springs in the form, given ``stiffness``: the assembled form without Dirichlet rows), or those they leave
    free by contact with a body that its own supports hold. Returns the bodies held by contact alone (the same
    list on every rank).

    The rigid modes r of body b restricted to its prescribed (owned, unrolled) DOFs give the Gram matrix
    G = Σ r_Dᵀ r_D (summed over ranks; coordinates relative to the body's centroid, scaled by its size); its
    null space N (eigenvalues ≤ 1e-10 × its trace) are the motions the supports leave free. Contact holds
    such a motion along the contact normals only: N is held when every free motion moves b's pair surfaces —
    those whose partner surface lies on a fully supported body — along their normals by at least
    :data:`HELD_FRACTION` of its motion there (:func:`held_fraction`, with G_c = Σ (n·r)ᵀ(n·r) and
    G_r = Σ rᵀr over the facets, n the facet normal, r the modes at its midpoint). A fraction, not a
    non-zero: on a faceted curved surface a motion the continuum leaves free (a shaft turning in its bore)
    has a normal part of order (h/R)² (:data:`HELD_FRACTION` gives the numbers), which contact would resist
    only through the facets' corners. A block resting on a clamped slope, pushed along
    one component of one face and on rollers, is held this way (its motion along the slope's normal); a body
    that only contact could hold sideways, or one resting on another floating body, is refused. Unilateral
    contact holds it only while the loads press it on: otherwise the solve fails (exit 3), as without support.
    """
    comm = V.mesh.comm
    motions = free_rigid_motions(V, body, num_bodies, dirichlet)
    if stiffness is not None:  # springs in the form hold motions too (nullspace.held_by_stiffness)
        motions = held_by_stiffness(stiffness, V, motions,
                                    mean_free_diagonal(stiffness, dirichlet, comm, body, num_bodies), body)
    centroid, extent, eigenvectors, free = motions.centroid, motions.extent, motions.eigenvectors, motions.free
    supported = motions.supported
    normal_gram = np.zeros((num_bodies, 6, 6))  # G_c per body: Σ (n·r)ᵀ(n·r) over its held contact facets
    motion_gram = np.zeros((num_bodies, 6, 6))  # Σ rᵀr over the same facets: the motions' whole size there
    held_by: list[list[int]] = [[] for _ in range(num_bodies)]  # the pairs whose contact holds each body
    for index, pair in enumerate(pairs):
        sides = [_surface_normals(V, body, pair.facet_tags, tags) for tags in (pair.slave_tags, pair.master_tags)]
        holds: list[list[int]] = [[], []]
        on = [np.unique(np.concatenate(comm.allgather(np.unique(side[0])))) for side in sides]
        for this, other in ((0, 1), (1, 0)):
            if not np.all(supported[on[other]]):
                continue
            holds[this].append(index)
            fb, midpoint, normal = sides[this]
            modes = rigid_modes_at((midpoint - centroid[fb]) / extent[fb, None])
            seen = np.einsum("fi,fia->fa", normal, modes)
            np.add.at(normal_gram, fb, np.einsum("fa,fb->fab", seen, seen))
            np.add.at(motion_gram, fb, np.einsum("fia,fib->fab", modes, modes))
        for this in (0, 1):
            if holds[this]:
                for k in on[this]:
                    held_by[int(k)].append(index)
    comm.Allreduce(MPI.IN_PLACE, normal_gram, op=MPI.SUM)
    comm.Allreduce(MPI.IN_PLACE, motion_gram, op=MPI.SUM)
    bad = []
    by_contact = []
    for k in range(num_bodies):
        if supported[k]:
            continue
        fraction = held_fraction(eigenvectors[k][:, free[k]], normal_gram[k], motion_gram[k])
        if fraction < HELD_FRACTION:
            bad.append(k)
            continue
        by_contact.append(HeldByContact(k, tuple(float(c) for c in centroid[k]), tuple(sorted(set(held_by[k])))))
        if comm.rank == 0:
            logger.info("body %d: %d rigid motion(s) left free by its supports are held by contact alone (normal "
                        "fraction %.3g)", k, int(free[k].sum()), fraction)
    where = ""
    if bad:
        where = f" (centroid {np.array2string(centroid[bad[0]], precision=4, separator=', ')})"
    check_all(comm, not bad, f"body {bad[0] if bad else 0}{where} of the {num_bodies} bodies has no boundary "
              "conditions that remove its rigid motions: prescribe or clamp enough of its boundary (contact holds "
              "a body only along the normals of a pair with a body its own supports hold)")
    return by_contact


def coupling_matrix(V: dolfinx.fem.FunctionSpace, blocks: npt.NDArray[np.int32],
                    master_blocks: npt.NDArray[np.int64], weights: Array, prefix: str,
                    held: npt.NDArray[np.bool_] | None = None) -> PETSc.Mat:
    """M = I + Φ as a PETSc AIJ matrix (collective; owned rows of V's DOF layout).

    Args:
        V: The displacement space (block size 3).
        blocks: Local owned block index of each slave contact node, shape (m,).
        master_blocks: Global block indices of the master facet's nodes, shape (m, k) (−1: none).
        weights: φ_sj, shape (m, k).
        prefix: Options prefix of the problem; the matrix gets ``<prefix>coupling_``.
        held: The components a Dirichlet condition holds at each slave node, shape (m, 3) (None: none): their
            rows of Φ are 0, so u = z there and the condition holds z (the contact law does not act on them:
            :mod:`fenics_coulomb.model.frames`, "Contact nodes with held components").
    """
    import scipy.sparse as sp  # scipy only where used (fenics_coulomb/__init__.py)

    comm = V.mesh.comm
    imap = V.dofmap.index_map
    n = imap.size_local
    r0 = imap.local_range[0]
    size = (3 * n, 3 * imap.size_global)
    present = master_blocks >= 0
    # the diagonal, and φ_sj on (3 s + c, 3 j + c) for c = 0, 1, 2 (rows local, columns global)
    diag = np.arange(3 * r0, 3 * (r0 + n), dtype=np.int64)
    slave_rows = 3 * (blocks.astype(np.int64) + r0)
    k = master_blocks.shape[1]
    rows = np.broadcast_to(slave_rows[:, None, None] + np.arange(3)[None, None, :], (blocks.size, k, 3))
    cols = 3 * master_blocks[:, :, None] + np.arange(3)[None, None, :]
    vals = np.broadcast_to(weights[:, :, None], cols.shape)
    keep = np.broadcast_to(present[:, :, None], cols.shape)
    if held is not None and np.any(held):
        keep = keep & ~np.asarray(held, dtype=bool)[:, None, :]
    local = sp.csr_matrix((np.concatenate([np.ones(diag.size), vals[keep]]),
                           (np.concatenate([diag, rows[keep]]) - 3 * r0, np.concatenate([diag, cols[keep]]))),
                          shape=(3 * n, size[1]))
    local.sum_duplicates()
    local.sort_indices()
    M = PETSc.Mat().createAIJ((size, size), bsize=3, csr=(local.indptr.astype(PETSc.IntType),
                                                          local.indices.astype(PETSc.IntType),
                                                          local.data.astype(PETSc.ScalarType)), comm=comm)
    M.setOptionsPrefix(f"{prefix}coupling_")
    M.assemble()
    return M


def linearized_pair_gaps(configuration: npt.ArrayLike | None, nodes: dict[str, npt.NDArray[Any]],
                         coupling: PETSc.Mat, u: Array) -> Array:
    """g + n·(w − w_c) of the owned slave ``nodes`` (keys blocks, gap, normals; ``coupling`` = I + Φ of their
    stencils), w = u_s − Σ_j φ_j u_j of the physical ``u`` and w_c of the ``configuration`` the gaps were evaluated
    in (their ``gap`` is g(X + u_c); None: X); collective."""
    x, y = coupling.createVecs()

    def w_of(v: npt.ArrayLike) -> Array:
        x.array[:] = np.asarray(v, dtype=np.float64)[:x.getLocalSize()]
        coupling.mult(x, y)  # (I + Φ) v
        return (2.0 * x.getArray(readonly=True) - y.getArray(readonly=True)).reshape(-1, 3)[nodes["blocks"]]

    w = w_of(u)
    if configuration is not None:
        w = w - w_of(configuration)
    x.destroy()
    y.destroy()
    return nodes["gap"] + np.einsum("ij,ij->i", nodes["normals"], w)


def body_rigid_modes(V: dolfinx.fem.FunctionSpace, body: npt.NDArray[np.int64], num_bodies: int,
                     M: PETSc.Mat) -> PETSc.NullSpace:
    """The near-nullspace of Ã for GAMG: (I − Φ) r_b = 2 r_b − M r_b for the six rigid modes r_b of each body
    (zero on the other bodies), orthonormalized (collective)."""
    imap = V.dofmap.index_map
    n = imap.size_local
    x = V.tabulate_dof_coordinates()[:n]
    modes = rigid_modes_at(x)
    owned_body = body[:n]
    vectors: list[PETSc.Vec] = []
    y = M.createVecRight()
    for b in range(num_bodies):
        inside = owned_body == b
        for k in range(6):
            v = M.createVecRight()
            values = np.zeros((n, 3))
            values[inside] = modes[inside, :, k]
            v.array[:] = values.ravel()
            M.mult(v, y)
            v.scale(2.0)
            v.axpy(-1.0, y)
            vectors.append(v)
    y.destroy()
    # modified Gram–Schmidt, twice (the modes of a body are far from orthogonal in raw coordinates)
    basis: list[PETSc.Vec] = []
    for v in vectors:
        norm0 = v.norm()
        for _ in range(2):
            for q in basis:
                v.axpy(-v.dot(q), q)
        norm = v.norm()
        if norm > 1e-10 * max(norm0, np.finfo(float).tiny):
            v.scale(1.0 / norm)
            basis.append(v)
        else:
            v.destroy()
    return PETSc.NullSpace().create(vectors=basis, comm=V.mesh.comm)
