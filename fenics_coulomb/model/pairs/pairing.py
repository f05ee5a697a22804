r"""The pairing of contact pairs: for every owned slave node of every pair its stencil (a row of Φ in the
change of variables u = (I + Φ) z), gap and frame, by the pair's method (:mod:`fenics_coulomb.model.pairs.registry`).

:func:`pair_surfaces` gathers each pair's master surface, asks the pair's method for the stencils of its candidate
slave nodes (no Dirichlet-clamped or driven node), keeps for a node in several pairs the pair of the smallest
|g|, and checks the pairs::

    pairs = [ContactPair(facet_tags, slave=2, master=1, friction=0.3, name="press")]
    pairing = pair_surfaces(V, pairs, excluded=dirichlet_blocks)   # collective
    # pairing.blocks[i] (local, owned) ↔ pairing.master_blocks[i] (global, −1 padded) with pairing.weights[i]

* Several pairs: a node belongs to the pair with the smallest |g| among those where it is a contact node
  (ties, |g| equal within 1e-10 × the largest bounding-box diagonal of the pairs' M ∪ S: the first pair).

Checks (InputError, one line, the same on every rank before the next collective call)
-------------------------------------------------------------------------------------
V not a vector P1/Q1 space; facet tags of another dimension than the facets'; a tag that no facet carries
on any rank; a tagged facet that is not on the mesh boundary; a pair that does not join two bodies: slave and
master surfaces with a common facet (slave = master, or one containing the other), or (in the reference
configuration) both on one connected part of the mesh (:func:`fenics_coulomb.model.pairs.two_body.connected_bodies`;
a slave node of that body named); Φ² ≠ 0 (a contact node that is itself a vertex of a master facet used by
any contact node — with two bodies per pair only possible across pairs — both nodes named by coordinates);
an overlap at the reference configuration that cannot be an interference, on the true geometry: a slave node
over M, not a contact node, whose node-to-surface distance to M (:mod:`fenics_coulomb.model.pairs.projection`) is
below −(the search distance) (a body inside the other), or a master node over S within the search distance whose
node-to-surface distance to S is below −max(1e-6 × the diagonal of the bounding box of M ∪ S, twice the deepest contact
node's interference), counted only to the thickness of the slave's cell layer under its closest point (twice
the distance of that cell's centroid from the facet: deeper, S alone cannot tell the inside of the slave body
from the space beyond a thin one) (node and depth named, the deepest over all ranks). A contact node inside
the master body is an interference: a negative initial gap, which the solve resolves (a shrink fit; two curved
surfaces meshed independently at the same radius overlap by their facetting). For mortar pairs this is NOT the nodal
gap g̃_j / D_j: the dual basis is negative on part of each facet, so g̃_j can be negative beside a curved master where
no point overlaps; such a node is a contact node with a negative initial gap, and the solve separates it. Invalid
ContactPair fields (friction, search distance, tags, name) are rejected when the pair is created. A pair with no
contact node is a logged warning (rank 0), not an error.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.mesh_checks import first_interior_facet
from fenics_coulomb.model.pairs.pair import ContactPair, Pairing
from fenics_coulomb.model.pairs.projection import (TIE_TOL, Surface, dot, facet_data, facet_ranks, facet_sizes,
                                                   gather_surface, layer_thickness, local_facets, project, where)
from fenics_coulomb.model.pairs.registry import pair_method
from fenics_coulomb.model.pairs.stencils import PairInput
from fenics_coulomb.model.pairs.two_body import connected_bodies

__all__ = ["OVERLAP_TOL", "pair_surfaces"]

logger = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: The reference overlap refused (× the bounding-box diagonal of the pair's surfaces).
OVERLAP_TOL = 1e-6


def _diagonal(comm: MPI.Comm, points: Array) -> tuple[Array, Array]:
    """The global bounding box (lower, upper corner) of every rank's points."""
    lo = points.min(axis=0) if points.size else np.full(3, np.inf)
    hi = points.max(axis=0) if points.size else np.full(3, -np.inf)
    glo, ghi = np.empty(3), np.empty(3)
    comm.Allreduce(lo, glo, op=MPI.MIN)
    comm.Allreduce(hi, ghi, op=MPI.MAX)
    return glo, ghi


def pair_surfaces(V: dolfinx.fem.FunctionSpace, pairs: Sequence[ContactPair],
                  excluded: npt.NDArray[np.int32], coordinates: Array | None = None,
                  resolution: float = 0.0, held: npt.NDArray[np.bool_] | None = None,
                  ties: tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]] | None = None) -> Pairing:
    """Pair the slave nodes of every contact pair with their master surfaces (see the module docstring).

    Collective.

    Args:
        V: Vector P1/Q1 function space (block size 3) of the mesh carrying both bodies.
        pairs: The contact pairs (their facet tags on V's mesh).
        excluded: Local DOF-block indices (owned and ghost) that are never contact nodes (clamped, or held at a
            non-zero value; nodes with components held at 0 stay, :mod:`fenics_coulomb.model.frames`).
        coordinates: The configuration to pair in: the position X + u of every local DOF block (owned and
            ghost), shape (number of blocks, 3); None for the reference configuration X. Only the reference
            configuration is checked for overlapping bodies (a deformed one is an iterate of finite sliding).
        resolution: The configuration's own displacement error (a length; 0 for the reference configuration):
            geometric decisions finer than it are not made (:class:`~fenics_coulomb.model.pairs.stencils.PairInput`).
        held: The components a support holds, of every local DOF block (owned and ghost), shape (blocks, 3)
            (:class:`~fenics_coulomb.model.pairs.stencils.PairInput`); None: none.
        ties: Geometry cycles' nodes (``PairInput.ties``); None: round-off.

    Returns:
        The owned contact nodes of all pairs.

    Raises:
        InputError: On every rank, one line (see the module docstring).
    """
    msh = V.mesh
    comm = msh.comm
    tdim = msh.topology.dim
    cell = msh.topology.cell_name()
    nv_cell = {"hexahedron": 8, "tetrahedron": 4}.get(cell)
    ok = (tdim == 3 and nv_cell is not None and V.dofmap.bs == 3 and V.dofmap.dof_layout.num_dofs == nv_cell
          and getattr(V.ufl_element(), "degree", 1) == 1)
    check_all(comm, ok, f"contact pairs need a vector P1 (tetrahedra) or Q1 (hexahedra) space in 3D, got "
                        f"{cell} cells with {V.dofmap.dof_layout.num_dofs} DOF blocks per cell and block size "
                        f"{V.dofmap.bs}")
    msh.topology.create_connectivity(tdim - 1, tdim)
    msh.topology.create_connectivity(tdim, tdim - 1)
    exterior = dolfinx.mesh.exterior_facet_indices(msh.topology)  # owned exterior facets
    num_owned = msh.topology.index_map(tdim - 1).size_local

    # tags: every tag must be carried by some facet, and only by boundary facets
    labels = [f"contact pair {i + 1}" + (f" ({pair.name!r})" if pair.name else "") for i, pair in enumerate(pairs)]
    surfaces: list[tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]] = []
    counts, message = [], ""
    for label, pair in zip(labels, pairs, strict=True):
        if pair.facet_tags.dim != tdim - 1 and not message:
            message = f"{label}: facet_tags of dimension {pair.facet_tags.dim}: must tag facets (dimension {tdim - 1})"
            continue
        both = []
        for key, tags in (("slave", pair.slave_tags), ("master", pair.master_tags)):
            facets = local_facets(pair.facet_tags, tags)
            counts.append([pair.facet_tags.find(t).size for t in tags])
            mid = None if message else first_interior_facet(msh, facets, exterior)  # each rank its owned facets
            if mid is not None:
                message = (f"{label}: {key} tag(s) {list(tags)} mark an interior facet (midpoint "
                           f"{where(mid)}): contact surfaces must lie on the mesh boundary")
            both.append(facets)
        surfaces.append((both[0], both[1]))
    total = comm.allreduce(np.asarray([c for cs in counts for c in cs], dtype=np.int64), op=MPI.SUM) \
        if counts else []
    position = 0
    for label, pair in zip(labels, pairs, strict=True):
        for key, tags in (("slave", pair.slave_tags), ("master", pair.master_tags)):
            for t in tags:
                if not message and total[position] == 0:
                    message = f"{label}: {key} tag {t}: no facet carries it (an unknown tag or an empty surface)"
                position += 1
    check_all(comm, not message, message)

    imap = V.dofmap.index_map
    n_owned = imap.size_local
    reference = coordinates is None
    X_dofs = V.tabulate_dof_coordinates() if reference else np.asarray(coordinates, dtype=np.float64)
    # a pair joins two bodies: no common facet, and (checked once, in the reference configuration) the surfaces
    # on different connected components of the mesh
    message = _common_facets(comm, pairs, labels, surfaces, num_owned)
    check_all(comm, not message, message)
    if reference:
        message = _one_body(V, pairs, labels, surfaces, X_dofs)
        check_all(comm, not message, message)
    nv = 4 if cell == "hexahedron" else 3
    excluded = np.asarray(excluded, dtype=np.int32)
    per_pair: list[dict[str, Any]] = []
    for pair, (slave_facets, master_facets) in zip(pairs, surfaces, strict=True):
        master = gather_surface(comm, facet_data(V, master_facets, X_dofs), nv)
        slave_blocks = np.unique(dolfinx.fem.locate_dofs_topological(V, tdim - 1, slave_facets))
        lo, hi = _diagonal(comm, np.concatenate([X_dofs[slave_blocks], master.X.reshape(-1, 3)]))
        body = float(np.linalg.norm(hi - lo))
        mlo, mhi = master.X.reshape(-1, 3).min(axis=0), master.X.reshape(-1, 3).max(axis=0)
        search = pair.search_distance if pair.search_distance is not None else 0.1 * float(np.linalg.norm(mhi - mlo))
        owned_slave = slave_blocks[slave_blocks < n_owned].astype(np.int32)
        nodes = np.setdiff1d(owned_slave, excluded).astype(np.int32)
        slave = _Gathered(V, slave_facets, X_dofs, nv)
        stencils = pair_method(pair.method)(PairInput(
            comm=comm, label=pair.label, x=X_dofs, owned_slave=owned_slave,
            global_slave=imap.local_to_global(owned_slave).astype(np.int64), nodes=nodes, master=master,
            size=facet_sizes(master), rank=facet_ranks(master), search=search, gather_slave=slave,
            resolution=resolution, held=held, ties=ties))
        g, contact, others, ro = stencils.gap, stencils.contact, stencils.others, stencils.projected
        # the other owned slave nodes over M (Dirichlet ones, beyond the search distance, mortar nodes not fully
        # covered): checked for penetration after a solve, with their node-to-surface projection
        go = dot(X_dofs[others] - ro["closest"], ro["normal"])
        over = ro["paired"]
        per_pair.append(dict(nodes=nodes, g=g, R=stencils.frames, contact=contact, closest=stencils.closest,
                             blocks=stencils.master_blocks, weights=stencils.weights, D=stencils.area, body=body,
                             partner_size=stencils.partner_size,
                             pointwise=stencils.pointwise, search=search,
                             master_depth=_master_overlap(imap, slave(), layer_thickness(comm, V, slave_facets,
                                                                                           X_dofs),
                                                          master, search) if reference else None,
                             free=dict(blocks=others[over], gap=go[over], normals=ro["normal"][over],
                                       master_blocks=master.blocks[ro["facet"][over]] if others.size
                                       else np.zeros((0, nv), np.int64), weights=ro["weights"][over])))

    # several pairs: the smallest |g| wins (ties: the first pair)
    allnodes = np.unique(np.concatenate([p["nodes"] for p in per_pair])) if per_pair else np.zeros(0, np.int32)
    absg = np.full((len(per_pair), allnodes.size), np.inf)
    for i, p in enumerate(per_pair):
        pos = np.searchsorted(allnodes, p["nodes"])
        absg[i, pos[p["contact"]]] = np.abs(p["g"][p["contact"]])
    # ties: |g| within TIE_TOL × the largest surfaces' size of the pairs (round-off of g is not a preference)
    tie = TIE_TOL * max((p["body"] for p in per_pair), default=0.0)
    best = absg.min(axis=0) if per_pair else np.zeros(0)
    winner = np.argmax(absg <= best + tie, axis=0) if per_pair else np.zeros(0, np.intp)
    is_contact = np.isfinite(best)
    blocks = allnodes[is_contact].astype(np.int32)
    winner = winner[is_contact]
    m = blocks.size
    positions = X_dofs[blocks].copy()
    closest, gap, area = np.zeros((m, 3)), np.zeros(m), np.zeros(m)
    # the stencils' width: 4 (node-to-surface) or the widest mortar stencil of a contact node on any rank
    width = 4
    for i, p in enumerate(per_pair):
        src = np.searchsorted(p["nodes"], blocks[winner == i])
        used = (p["blocks"][src] >= 0).sum(axis=1).max(initial=0) if src.size else 0
        width = max(width, int(used))
    width = comm.allreduce(width, op=MPI.MAX)
    frames, master_blocks, weights = np.zeros((m, 3, 3)), np.full((m, width), -1, np.int64), np.zeros((m, width))
    friction, partner_size = np.zeros(m), np.zeros(m)
    for i, p in enumerate(per_pair):
        sel = np.flatnonzero(winner == i)
        src = np.searchsorted(p["nodes"], blocks[sel])
        closest[sel], gap[sel], frames[sel] = p["closest"][src], p["g"][src], p["R"][src]
        k = min(p["blocks"].shape[1], width)
        master_blocks[sel, :k], weights[sel, :k] = p["blocks"][src, :k], p["weights"][src, :k]
        area[sel], partner_size[sel] = p["D"][src], p["partner_size"][src]
        friction[sel] = float(pairs[i].friction)

    # Φ² = 0: no contact node is a vertex of a master facet used by any contact node
    gblocks = imap.local_range[0] + blocks.astype(np.int64)
    all_g = np.concatenate(comm.allgather(gblocks))
    all_x = np.concatenate(comm.allgather(positions))
    all_mb = np.concatenate(comm.allgather(master_blocks))
    message = ""
    hit = np.flatnonzero(np.isin(all_g, all_mb))
    if hit.size:
        bad = int(hit[np.argmin(all_g[hit])])
        user = int(np.flatnonzero((all_mb == all_g[bad]).any(axis=1))[0])
        message = (f"contact node {where(all_x[bad])} is a vertex of the master facet used by contact node "
                   f"{where(all_x[user])}: Φ² = 0 needs slave surfaces without master-surface nodes "
                   "(check the pairs' slave and master tags)")
    check_all(comm, not message, message)

    # overlap at the reference configuration, on the true geometry (the pointwise node-to-surface distance, not
    # the mortar nodal gap g̃_j / D_j, which can be negative beside a curved master without any overlap): a contact
    # node inside the master body is an interference (a negative initial gap, which the solve resolves, as an
    # obstacle's indentation). Refused: a slave node over M inside it deeper than the search distance (no contact
    # node, and none can be: a body inside the other, or an overlap the search distance does not reach), and a
    # master node inside the slave body deeper than twice the deepest slave node's interference (an overlap
    # between the slave nodes, which they do not see: a master bump poking into the slave)
    worst = None
    local = 0.0
    for i, p in enumerate(per_pair if reference else []):
        sel = np.flatnonzero(winner == i)
        if sel.size:
            local = max(local, float(np.max(-p["pointwise"][np.searchsorted(p["nodes"], blocks[sel])])))
    interference = comm.allreduce(local, op=MPI.MAX)
    for i, p in enumerate(per_pair if reference else []):
        free = p["free"]
        deep = np.flatnonzero((-free["gap"] > p["search"]) & ~np.isin(free["blocks"], blocks))
        if deep.size:
            k = deep[int(np.argmax(-free["gap"][deep]))]
            depth = float(-free["gap"][k])
            if worst is None or depth > worst[0]:
                worst = (depth, f"{labels[i]}: the bodies overlap at the reference configuration beyond the search "
                                f"distance: slave node {where(X_dofs[free['blocks'][k]])} lies {depth:.6g} inside "
                                f"the master body (search distance {p['search']:.6g}): not an interference the pair "
                                "can resolve (a body inside the other?); enlarge search_distance or fix the geometry")
        x, d = p["master_depth"]
        allowed = max(OVERLAP_TOL * p["body"], 2.0 * interference)
        if d.size and d.max() > allowed:
            k = int(np.argmax(d))
            if worst is None or d[k] > worst[0]:
                worst = (float(d[k]), f"{labels[i]}: the bodies overlap at the reference configuration: master "
                                      f"node {where(x[k])} lies {d[k]:.6g} inside the slave body, between its "
                                      f"nodes (more than {allowed:.6g}: twice the deepest slave node's "
                                      "interference, or 1e-6 × the surfaces' size): the slave's nodes do not see "
                                      "that overlap")
    everyone = [w for w in comm.allgather(worst) if w is not None]
    if everyone:
        raise InputError(max(everyone, key=lambda w: w[0])[1])
    if reference and interference > OVERLAP_TOL * max((p["body"] for p in per_pair), default=0.0) \
            and comm.rank == 0:
        logger.info("contact pairs: the bodies overlap at the reference configuration by up to %.6g: an "
                    "interference (negative initial gaps)", interference)

    count = comm.allreduce(np.bincount(winner, minlength=len(pairs)).astype(np.int64), op=MPI.SUM) \
        if pairs else np.zeros(0, np.int64)
    if comm.rank == 0:
        for i, pair in enumerate(pairs):
            if count[i] == 0:
                logger.warning("%s (slave %s, master %s) has no contact node (the slave surface is out of the "
                               "search distance or beside the master surface)", labels[i],
                               list(pair.slave_tags), list(pair.master_tags))
    return Pairing(blocks=blocks, coordinates=positions, closest=closest, gap=gap, frames=frames,
                   master_blocks=master_blocks, weights=weights, area=area, pair_index=winner.astype(np.intp),
                   friction=friction, num_global=int(count.sum()) if pairs else 0,
                   free=_free_nodes([p["free"] for p in per_pair], blocks, nv), partner_size=partner_size)


def _common_facets(comm: MPI.Comm, pairs: Sequence[ContactPair], labels: list[str],
                   surfaces: list[tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]], num_owned: int) -> str:
    """The first pair whose slave and master surfaces share a facet (slave = master, one containing the other),
    as a one-line message ("" when none; collective)."""
    local = np.asarray([np.intersect1d(s[s < num_owned], m).size for s, m in surfaces], dtype=np.int64)
    common = comm.allreduce(local, op=MPI.SUM) if pairs else local
    for label, pair, n in zip(labels, pairs, common, strict=True):
        if n:
            what = "are the same surface" if set(pair.slave_tags) == set(pair.master_tags) else \
                f"share {int(n)} facet(s)"
            return (f"{label}: slave tag(s) {list(pair.slave_tags)} and master tag(s) {list(pair.master_tags)} "
                    f"{what}: a contact pair joins surfaces of two different bodies")
    return ""


def _one_body(V: dolfinx.fem.FunctionSpace, pairs: Sequence[ContactPair], labels: list[str],
              surfaces: list[tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]], X: Array) -> str:
    """The first pair whose slave and master surfaces lie on one body (a connected component of the mesh), as a
    one-line message naming a slave node of that body ("" when none; collective)."""
    comm = V.mesh.comm
    tdim = V.mesh.topology.dim
    body, num_bodies = connected_bodies(V)
    for label, pair, (slave_facets, master_facets) in zip(labels, pairs, surfaces, strict=True):
        sb = np.unique(dolfinx.fem.locate_dofs_topological(V, tdim - 1, slave_facets))
        mb = np.unique(dolfinx.fem.locate_dofs_topological(V, tdim - 1, master_facets))
        on = np.zeros((2, num_bodies), dtype=np.int64)
        on[0, body[sb]] = 1
        on[1, body[mb]] = 1
        on = comm.allreduce(on, op=MPI.SUM)
        both = np.flatnonzero((on[0] > 0) & (on[1] > 0))
        if both.size:
            mine = sb[body[sb] == both[0]]
            points = [p for p in comm.allgather(X[mine[0]] if mine.size else None) if p is not None]
            return (f"{label}: slave tag(s) {list(pair.slave_tags)} and master tag(s) {list(pair.master_tags)} lie "
                    f"on one body (the connected part of the mesh through the slave node {where(points[0])}): a "
                    "contact pair joins surfaces of two different bodies")
    return ""


def _master_overlap(imap: Any, slave: Surface, thickness: Array, master: Surface, search: float
                    ) -> tuple[Array, Array]:
    """The master nodes owned by this rank (``imap``: the DOF-block index map) that lie over the gathered slave
    surface S (in its normal cone) within the search distance and within the thickness of the cell layer under
    their closest slave facet (``thickness``, per facet of S; deeper, S alone does not tell inside the slave
    body from beyond a thin one), with their depth inside the slave body (−g, the node-to-surface gap on S):
    (coordinates, depth)."""
    lo, hi = imap.local_range
    vertices, first = np.unique(master.blocks.ravel(), return_index=True)
    mine = (vertices >= lo) & (vertices < hi)
    x = master.X.reshape(-1, 3)[first[mine]]
    if x.shape[0] == 0 or slave.X.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros(0)
    res = project(x, slave, facet_sizes(slave), facet_ranks(slave))
    g = dot(x - res["closest"], res["normal"])
    over = np.asarray(res["paired"], dtype=bool) & (np.abs(g) <= search) & (-g < thickness[res["facet"]])
    return x[over], -g[over]


def _free_nodes(per_pair: list[dict[str, np.ndarray]], contact: npt.NDArray[np.int32], nv: int
                ) -> dict[str, np.ndarray]:
    """The free slave nodes over a master surface, each with the pair of smallest |g| (not contact nodes of
    another pair)."""
    out: dict[str, np.ndarray] = {"blocks": np.zeros(0, np.int32), "gap": np.zeros(0), "normals": np.zeros((0, 3)),
           "master_blocks": np.full((0, 4), -1, np.int64), "weights": np.zeros((0, 4))}
    if not per_pair:
        return out
    blocks = np.concatenate([f["blocks"] for f in per_pair])
    keep = ~np.isin(blocks, contact)
    gap = np.concatenate([f["gap"] for f in per_pair])
    order = np.lexsort((np.abs(gap), blocks))
    order = order[keep[order]]
    first = order[np.unique(blocks[order], return_index=True)[1]]
    mb = np.full((first.size, 4), -1, np.int64)
    w = np.zeros((first.size, 4))
    mb[:, :nv] = np.concatenate([f["master_blocks"] for f in per_pair])[first]
    w[:, :nv] = np.concatenate([f["weights"] for f in per_pair])[first]
    out.update(blocks=blocks[first].astype(np.int32), gap=gap[first],
               normals=np.concatenate([f["normals"] for f in per_pair])[first], master_blocks=mb, weights=w)
    return out



class _Gathered:
    """A pair's slave surface, gathered on every rank at the first call (collective) and kept."""

    def __init__(self, V: dolfinx.fem.FunctionSpace, facets: npt.NDArray[np.int32], x: Array, nv: int) -> None:
        self._args = (V, facets, x, nv)
        self._surface: Surface | None = None

    def __call__(self) -> Surface:
        if self._surface is None:
            V, facets, x, nv = self._args
            self._surface = gather_surface(V.mesh.comm, facet_data(V, facets, x), nv)
        return self._surface
