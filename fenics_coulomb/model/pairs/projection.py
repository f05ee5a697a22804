r"""The closest point of a surface of P1/Q1 facets: the node-to-surface projection, its normal and normal cone.

A surface is a set of facets gathered on every rank (:class:`Surface`: vertex coordinates, global DOF blocks, the
outward orientation); :func:`project` gives for points x_s the closest point x_m, the facet's shape functions
there (the stencil weights φ_j), the normal n and whether x_s lies in the normal cone. The node-to-surface method
(:mod:`fenics_coulomb.model.pairs.node_to_surface`), the mortar method's anchors and free-node checks
(:mod:`fenics_coulomb.model.pairs.mortar`), the pairing's overlap checks and the triangulated rigid obstacles
(:mod:`fenics_coulomb.model.surface`) use it.

Geometry
--------
Master facets are P1 triangles (tetrahedral meshes) or Q1 bilinear quadrilaterals (hexahedral meshes),
x(ξ, η) = v₀(1−ξ)(1−η) + v₁ξ(1−η) + v₂(1−ξ)η + v₃ξη on [0, 1]² (DOLFINx/basix tensor vertex order). For
each vertex x_s of S (owned by this rank, with no Dirichlet component):

* x_m = the closest point of M to x_s: the minimum over the master facets of the distance to the facet
  (triangle: projection on the plane, else the closest point of the three edges; quadrilateral: Newton's
  method for the stationary point (ξ, η) of ½|x(ξ, η) − x_s|² from the centre (the Gauss–Newton matrix
  where the full Hessian is not positive definite), accepted when it converges inside [0, 1]²; else, or when
  nearer, the closest point of the four straight edges — "edge/vertex clamping"). Candidate facets: a bound
  U on the distance from the 4 nearest facet centroids, then every facet whose centroid lies within
  U + its radius (+ the tie tolerance) — KD-trees per facet-radius class (powers of 2), so the small facets
  of a graded surface are not searched with the radius of its largest one.
* Facets "containing x_m" (the tie set T): the facets whose own closest point lies within 1e-10 h of the
  best one (h = the diameter of the best facet) at a distance within 1e-10 h of the best distance.
  φ_j = the shape functions at x_m of the facet of T whose SORTED GLOBAL vertex (DOF-block) indices are
  lexicographically smallest (P1: barycentric; Q1: bilinear); x_m is that facet's point, so
  Σ_j φ_j x_j = x_m exactly up to round-off and Σ_j φ_j = 1. On a shared edge or vertex every facet of T
  gives the same non-zero φ_j (conforming P1/Q1 shape functions restrict to the edge's linear ones, and to
  1 at a vertex): the rule only fixes which zero-weight vertices are listed, so the stencil does not depend
  on the global numbering (which depends on the partition). Where a point is known only to a width w (a
  configuration's own error, a finite-sliding cycle's nodes: ``ties``), T takes max(1e-10 h, w) for both
  bounds — its normals and "on the surface" below — while x_m and φ stay those of the 1e-10 h ties.
* n_f(x) = the outward unit normal of facet f at x: of the plane (triangle) or of the bilinear surface,
  ±(x_ξ × x_η)/|x_ξ × x_η| at (ξ, η) — the sign fixed per facet so that it points out of the MASTER body
  (away from the centroid of the facet's cell, evaluated at the facet centre; a bilinear facet that is not
  folded keeps that orientation everywhere).
* x_m in the interior of its facet (|T| = 1 and the reference coordinates farther than 1e-10 from the
  facet's boundary): n = n_f(x_m). Otherwise (x_m on an edge or vertex, shared by the facets T or on M's
  outer boundary): n = d/|d|, d = x_s − x_m; when |d| <= 1e-10 h: n = the normalized sum of n_f(x_m), f ∈ T.
* g = (x_s − x_m)·n; t₁, t₂ = :func:`fenics_coulomb.model.frames.frames_from_normals` (deterministic).
* Normal cone C = cone{n_f(x_m) : f ∈ T} (the outward normals at x_m of the facets containing it; a single
  ray inside a facet or on M's outer boundary, so a node beside M's outer edge is free). The node is a
  contact node of the pair if dist(d, C) <= 1e-8 h or dist(−d, C) <= 1e-8 h (or |d| <= 1e-10 h) and
  |g| <= ``search_distance`` (default 0.1 × the diagonal of the master surface's bounding box). Once a finite
  sliding cycle is tied (``reach``, the widest tie: :mod:`fenics_coulomb.model.geometry_cycles`), a node the cone
  test leaves unpaired within ``reach`` of x_m is paired as a node on the surface.
* Vague directions: a node (all but) on an edge or vertex whose ±d passes the cone test only within its absolute
  tolerance (dist(±d, C) <= 1e-8 h) but lies off C by more than CONE_ANGLE = 1e-3 rad (dist > CONE_ANGLE·|d|) takes
  the normalized sum of the tied facets' normals (as |d| <= 1e-10 h does): with |d| of the order of 1e-8 h any
  direction passes the test, and d/|d| — possibly tangential — would become the constraint's normal. Measured on
  the node-to-surface shrink fit in finite sliding: bore nodes pressed onto the shaft's vertices (|d| ~ 5e-10) were
  released by such a normal and penetrated 5e-5–1.4e-3 in the next geometry, which never settled; with the rule it
  settles in 5 updates, its pressure 7e-5 from small sliding's. Checked against a brute force of its own
  (closest points by enumeration, the cone distance by NNLS) at a pyramid's apex: tests/model/test_vague_normals.py.
* SIGN CHOICE: "d lies in the normal cone" is read as "±d lies in it", so that a slave node inside the
  master body (d points into it: −d is in C) is paired with g < 0 (n = −d/|d| at an edge/vertex, n_f inside
  a facet; g = d·n = −|d|). When both hold (only possible for a cone containing a line), +d is used.

Dist(d, C) for a polyhedral cone in ℝ³ is evaluated exactly via Carathéodory: the minimum of the
non-negative least-squares residuals over the single generators and the pairs of generators, and 0 when d
is a non-negative combination of three independent generators.

Parallel
--------
Every rank gathers every pair's whole master surface (vertex coordinates, global DOF-block indices, outward
orientation; facets deduplicated by their global vertices), so the pairing of a slave node does not depend
on where the master facets are: 1 rank and N ranks give the same pairing (up to the numbering, and the
zero-weight vertices listed for a node on a shared edge or vertex, see the tie rule).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import chain
from typing import Any

from mpi4py import MPI

import basix
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.pairs.facet_closest import TIE_TOL, closest_points, dot, norm, quad_map

__all__ = ["TIE_TOL", "CONE_TOL", "CONE_ANGLE", "Surface", "norm", "dot", "where", "outward_normals", "layer_thickness",
           "local_facets", "facet_data", "gather_surface", "project", "select_candidates", "node_size", "facet_sizes",
           "facet_ranks", "empty_closest", "closest_points", "candidate_facets", "tie_width"]

Array = npt.NDArray[np.float64]

#: Relative tolerance (× the facet size h) of the normal cone; TIE_TOL (coincident closest points, |x_s − x_m| ≈ 0,
#: "on the boundary" in reference coordinates) is the facet kernels' (:mod:`.facet_closest`).
CONE_TOL = 1e-8
#: An edge or vertex node whose ±d lies in the normal cone only within CONE_TOL·h, but off it by more than this
#: angle (radians), takes the cone's mean direction as its normal (module docstring).
CONE_ANGLE = 1e-3


# -- facet geometry ---------------------------------------------------------------------------------------
def empty_closest(m: int, nv: int) -> dict[str, npt.NDArray[Any]]:
    """The closest-point record of ``m`` points on a surface of ``nv``-vertex facets, before the search: closest
    point, facet weights, facet, normal (zeros) and whether a facet was found (False)."""
    return {"closest": np.zeros((m, 3)), "weights": np.zeros((m, nv)), "facet": np.zeros(m, np.intp),
            "normal": np.zeros((m, 3)), "paired": np.zeros(m, dtype=bool)}


def _reference(w: Array) -> tuple[Array, Array]:
    """Reference coordinates recovered from the weights (triangle: (λ₁, λ₂); quad: (ξ, η))."""
    if w.shape[-1] == 3:
        return w[..., 1], w[..., 2]
    return w[..., 1] + w[..., 3], w[..., 2] + w[..., 3]


def _on_boundary(w: Array) -> Array:
    """Whether the reference point of the weights lies on its facet's boundary (within TIE_TOL)."""
    if w.shape[-1] == 3:
        return w.min(axis=-1) <= TIE_TOL
    xi, eta = _reference(w)
    return np.minimum(np.minimum(xi, 1 - xi), np.minimum(eta, 1 - eta)) <= TIE_TOL


def outward_normals(X: Array, w: Array, sign: Array) -> Array:
    """Outward unit normals of facets X (k, nv, 3) at the reference points of the weights w (k, nv)."""
    if X.shape[1] == 3:
        N: Array = np.asarray(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), dtype=np.float64)
    else:
        xi, eta = _reference(w)
        _, xx, xe = quad_map(X, xi, eta)
        N = np.asarray(np.cross(xx, xe), dtype=np.float64)
    return sign[:, None] * N / norm(N)[:, None]


# -- the master surface -----------------------------------------------------------------------------------
@dataclass
class Surface:
    """Facets of a surface: vertex coordinates (k, nv, 3), global DOF blocks (k, nv), orientation (k,)."""

    X: Array
    blocks: npt.NDArray[np.int64]
    sign: Array

    def unique(self) -> Surface:
        """Without duplicates (a facet gathered from several ranks), in sorted order of the global blocks."""
        key = np.sort(self.blocks, axis=1)
        _, first = np.unique(key, axis=0, return_index=True)
        return Surface(self.X[first], self.blocks[first], self.sign[first])


def local_facets(facet_tags: dolfinx.mesh.MeshTags, tags: Sequence[int]) -> npt.NDArray[np.int32]:
    """This rank's facets carrying any of ``tags``, ascending."""
    found = [facet_tags.find(t) for t in tags]
    return np.unique(np.concatenate(found)).astype(np.int32) if found else np.zeros(0, np.int32)


def facet_data(V: dolfinx.fem.FunctionSpace, facets: npt.NDArray[np.int32], X_dofs: Array) -> Surface:
    """This rank's facets with their vertex coordinates, global blocks and outward orientation."""
    msh = V.mesh
    tdim = msh.topology.dim
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    c2f = msh.topology.connectivity(tdim, tdim - 1)
    cells = f2c.array[f2c.offsets[facets]]  # boundary facets: one cell
    nf = c2f.offsets[1] - c2f.offsets[0] if c2f.offsets.size > 1 else 1
    local = np.argmax(c2f.array.reshape(-1, nf)[cells] == facets[:, None], axis=1)
    ref = np.asarray(basix.topology(_basix_cell(msh))[tdim - 1], dtype=np.int64)
    dofs = V.dofmap.list[cells]
    blocks = np.take_along_axis(dofs, ref[local], axis=1)
    X = X_dofs[blocks]
    centroid = X_dofs[dofs].mean(axis=1)
    nv = ref.shape[1]
    w = np.full((facets.size, nv), 1.0 / nv)
    N = outward_normals(X, w, np.ones(facets.size)) if facets.size else np.zeros((0, 3))
    centre = X.mean(axis=1)
    sign = np.where(dot(N, centroid - centre) > 0, -1.0, 1.0)
    imap = V.dofmap.index_map
    gblocks = imap.local_to_global(blocks.ravel().astype(np.int32)).reshape(blocks.shape).astype(np.int64)
    return Surface(X, gblocks, sign)


def layer_thickness(comm: MPI.Comm, V: dolfinx.fem.FunctionSpace, facets: npt.NDArray[np.int32], X: Array) -> Array:
    """Twice the distance of each facet's cell centroid from the facet's centre along its normal (about the
    thickness of the cell layer under the facet), in the order of :func:`gather_surface` of the same facets."""
    msh = V.mesh
    tdim = msh.topology.dim
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    surface = facet_data(V, facets, X)
    cells = f2c.array[f2c.offsets[facets]]
    centroid = X[V.dofmap.list[cells]].mean(axis=1)
    nv = surface.X.shape[1]
    normal = outward_normals(surface.X, np.full((facets.size, nv), 1.0 / nv), surface.sign) if facets.size \
        else np.zeros((0, 3))
    local = 2 * np.abs(dot(centroid - surface.X.mean(axis=1), normal))
    blocks = np.concatenate(comm.allgather(surface.blocks.reshape(-1, nv)))
    _, first = np.unique(np.sort(blocks, axis=1), axis=0, return_index=True)
    return np.concatenate(comm.allgather(local))[first]


def _basix_cell(msh: dolfinx.mesh.Mesh) -> basix.CellType:
    return {"hexahedron": basix.CellType.hexahedron, "tetrahedron": basix.CellType.tetrahedron}[
        msh.topology.cell_name()]


def gather_surface(comm: MPI.Comm, surface: Surface, nv: int) -> Surface:
    X = np.concatenate(comm.allgather(surface.X.reshape(-1, nv, 3)))
    blocks = np.concatenate(comm.allgather(surface.blocks.reshape(-1, nv)))
    sign = np.concatenate(comm.allgather(surface.sign))
    return Surface(X, blocks, sign).unique()


# -- closest points ---------------------------------------------------------------------------------------
def _cone_distance(d: Array, N: Array, mask: npt.NDArray[np.bool_]) -> Array:
    """dist(d, cone{N[:, i] : mask[:, i]}) for each row: d (k, 3), N (k, q, 3), mask (k, q).

    The candidates — the rays of single normals, the planar cones of pairs, a triple's solid cone (distance 0
    when d is a non-negative combination) — are evaluated for every combination at once (the same arithmetic per
    combination as one at a time, so the same bits)."""
    k, q = mask.shape
    best: Array = np.full(k, np.inf)
    if k == 0 or q == 0:
        return best
    c = np.maximum(dot(d[:, None], N), 0.0)
    best = np.min(np.where(mask, norm(d[:, None] - c[..., None] * N), np.inf), axis=1, initial=np.inf)
    if q >= 2:
        i, j = np.triu_indices(q, 1)
        a, b = N[:, i], N[:, j]
        aa, ab, bb = dot(a, a), dot(a, b), dot(b, b)
        det = aa * bb - ab * ab
        ok = mask[:, i] & mask[:, j] & (det > 1e-14)
        dd = d[:, None]
        da, db = dot(dd, a), dot(dd, b)
        safe = np.where(ok, det, 1.0)
        ca, cb = (bb * da - ab * db) / safe, (aa * db - ab * da) / safe
        ok &= (ca >= 0) & (cb >= 0)
        res = norm(dd - ca[..., None] * a - cb[..., None] * b)
        best = np.minimum(best, np.min(np.where(ok, res, np.inf), axis=1, initial=np.inf))
    if q >= 3:
        grid = [t.ravel() for t in np.meshgrid(*(np.arange(q),) * 3, indexing="ij")]
        triple = (grid[0] < grid[1]) & (grid[1] < grid[2])
        i, j, m = grid[0][triple], grid[1][triple], grid[2][triple]
        M = np.stack([N[:, i], N[:, j], N[:, m]], axis=3)  # (k, T, 3, 3), columns the three normals
        det = np.linalg.det(M)
        ok = mask[:, i] & mask[:, j] & mask[:, m] & (np.abs(det) > 1e-12)
        if ok.any():
            coef = np.linalg.solve(np.where(ok[..., None, None], M, np.eye(3)),
                                   np.broadcast_to(d[:, None, :, None], (*ok.shape, 3, 1)))[..., 0]
            ok &= (coef >= 0).all(axis=-1)
            best = np.where(ok.any(axis=1), 0.0, best)
    return best


def project(x: Array, surface: Surface, size: Array, rank: npt.NDArray[np.intp],
            ties: float | Array = 0.0, reach: float = 0.0) -> dict[str, Array]:
    """Closest points, weights, normals and cone membership of the nodes x (m, 3) on the gathered surface (the
    candidate facets of :func:`candidate_facets`: a facet nearer than the bound, or tied with the nearest, is among
    them, its distance at least its centre's distance − its radius); ``ties``: a width (per node, or one) within
    which closest points tie, beyond the round-off rule's TIE_TOL·h; ``reach``: a node the cone test leaves
    unpaired within this of its closest point is paired, with the tied facets' mean normal (a geometry cycle's
    width: a node flush with M's outer edge)."""
    m, nv = x.shape[0], surface.X.shape[1]
    out = empty_closest(m, nv)
    nf = surface.X.shape[0]
    if m == 0 or nf == 0:
        return out
    hmax = float(size.max())
    widest = float(np.max(ties, initial=0.0))
    node, facet = candidate_facets(x, surface, 4, (max(TIE_TOL * hmax, widest), 1e-12 * (hmax + np.abs(x).max())))
    select_candidates(x, node, facet, surface, size, rank, out, ties, reach)
    return out


def candidate_facets(x: Array, surface: Surface, k0: int, slack: tuple[Any, ...]
                     ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """The (point, facet) pairs, sorted by point then facet, whose facet may hold a point's closest point: a bound
    on each point's distance from its ``k0`` nearest facet centres (+ the ``slack`` terms, added in turn), then, per
    class of facet radius (powers of 2), every facet whose centre lies within the bound + the class's radius."""
    from scipy.spatial import cKDTree  # scipy only where used (fenics_coulomb/__init__.py)

    m, nf = x.shape[0], surface.X.shape[0]
    centres = surface.X.mean(axis=1)
    radius = norm(surface.X - centres[:, None]).max(axis=1)
    k0 = min(nf, k0)
    _, ii = cKDTree(centres).query(x, k=k0)
    _, _, dist = closest_points(np.repeat(x, k0, axis=0), surface.X[ii.reshape(m, k0).ravel()])
    bound = dist.reshape(m, k0).min(axis=1)
    for term in slack:
        bound = bound + term
    level = np.floor(np.log2(np.maximum(radius, np.finfo(float).tiny))).astype(np.int64)
    nodes_l, facets_l = [], []
    for lv in np.unique(level):
        members = np.flatnonzero(level == lv)
        lists = cKDTree(centres[members]).query_ball_point(x, bound + radius[members].max())
        lengths = np.fromiter(map(len, lists), dtype=np.intp, count=m)
        nodes_l.append(np.repeat(np.arange(m), lengths))
        facets_l.append(members[np.fromiter(chain.from_iterable(lists), dtype=np.intp, count=int(lengths.sum()))])
    node, facet = np.concatenate(nodes_l), np.concatenate(facets_l)
    order = np.lexsort((facet, node))
    return node[order], facet[order]


def select_candidates(x: Array, node: npt.NDArray[np.intp], facet: npt.NDArray[np.intp], surface: Surface,
                      size: Array, rank: npt.NDArray[np.intp], out: dict[str, Array],
                      resolution: float | Array = 0.0, reach: float = 0.0) -> None:
    """The closest point of each point x_i among its candidate facets (the pairs (``node``, ``facet``), sorted by
    node), with the tie and normal-cone rules (:func:`_select`), written into ``out``; ``resolution``: the points'
    own position error (a length, 0: exact; one, or per point), below which ties and "on the surface" are decided
    as at round-off."""
    m = x.shape[0]
    q, w, dist = closest_points(x[node], surface.X[facet])
    # rectangular batches of nodes with similar candidate counts (padding: distance inf, never tied or chosen)
    count = np.bincount(node, minlength=m)
    first = np.concatenate([[0], np.cumsum(count)[:-1]])
    width = np.maximum(1, 2 ** np.ceil(np.log2(np.maximum(count, 1)))).astype(np.intp)
    for k in np.unique(width):
        sel = np.flatnonzero(width == k)
        slot = np.arange(k)[None, :]
        valid = slot < count[sel, None]
        src = np.where(valid, first[sel, None] + slot, first[sel, None])
        dk = np.where(valid, dist[src], np.inf)
        _select(x[sel], facet[src], q[src], w[src], dk, surface, size, rank, out, sel, resolution, reach)


def _select(x: Array, ii: npt.NDArray[np.intp], q: Array, w: Array, dist: Array, surface: Surface,
            size: Array, rank: npt.NDArray[np.intp], out: dict[str, Array], nodes: npt.NDArray[np.intp],
            resolution: float | Array = 0.0, reach: float = 0.0) -> None:
    """Pick x_m, the lexicographic facet among the tied ones, n and the cone test for a batch of nodes (ties and
    "on the surface" within TIE_TOL·h, or within ``resolution`` where the points are known no better; a node left
    unpaired within ``reach`` of x_m paired as one on the surface)."""
    if nodes.size == 0:
        return
    rows = np.arange(nodes.size)
    near = np.argmin(dist, axis=1)
    h = size[ii[rows, near]]
    width = np.asarray(resolution, dtype=np.float64)
    tol = np.maximum(TIE_TOL * h, width[nodes] if width.ndim else width)
    apart = norm(q - q[rows, near][:, None])
    tied = (dist <= dist[rows, near][:, None] + tol[:, None]) & (apart <= tol[:, None])
    # x_m and the weights: the lexicographic facet among those tied at round-off (the same point: the choice only
    # lists zero weights), so a wider tie (the normal's) does not make x_m depend on the numbering
    exact = (dist <= dist[rows, near][:, None] + TIE_TOL * h[:, None]) & (apart <= TIE_TOL * h[:, None])
    chosen = np.argmin(np.where(exact, rank[ii], np.iinfo(np.intp).max), axis=1)
    facet = ii[rows, chosen]
    xm, wm = q[rows, chosen], w[rows, chosen]
    kq = ii.shape[1]
    normals = outward_normals(surface.X[ii.ravel()], w.reshape(-1, w.shape[-1]),
                             surface.sign[ii.ravel()]).reshape(-1, kq, 3)
    d = x - xm
    dn = norm(d)
    tiny = dn <= tol
    edge = (tied.sum(axis=1) > 1) | _on_boundary(wm)
    n = normals[rows, chosen].copy()
    # inside a facet: n = n_f(x_m); the node is paired if ±d is along n (always, up to round-off)
    along = norm(d - dot(d, n)[:, None] * n) <= CONE_TOL * h
    paired = along.copy()
    # on an edge or vertex: n = ±d/|d| if ±d lies in the cone of the tied facets' normals
    sel = np.flatnonzero(edge & ~tiny)
    if sel.size:
        order = np.argsort(~tied[sel], axis=1, kind="stable")  # tied facets first
        qt = int(tied[sel].sum(axis=1).max())
        order = order[:, :qt]
        Nt = np.take_along_axis(normals[sel], order[:, :, None], axis=1)
        mt = np.take_along_axis(tied[sel], order, axis=1)
        d_plus, d_minus = _cone_distance(d[sel], Nt, mt), _cone_distance(-d[sel], Nt, mt)
        plus, minus = d_plus <= CONE_TOL * h[sel], d_minus <= CONE_TOL * h[sel]
        unit = d[sel] / dn[sel, None]
        n[sel] = np.where(plus[:, None], unit, np.where(minus[:, None], -unit, n[sel]))
        paired[sel] = plus | minus
        # ±d in the cone only within the absolute tolerance, its direction off the cone by more than CONE_ANGLE:
        # a node (all but) on the edge or vertex, whose d does not say which normal — the cone's mean direction
        off = np.where(plus, d_plus, d_minus) > CONE_ANGLE * dn[sel]
        vague = sel[paired[sel] & off]
        if vague.size:
            s = np.einsum("kq,kqi->ki", tied[vague].astype(float), normals[vague])
            n[vague] = s / norm(s)[:, None]
    # x_s on the surface (or within a geometry cycle's reach of it, unpaired): the tied facets' normals' sum
    sel = np.flatnonzero(tiny | (~paired & (dn <= reach)))
    if sel.size:
        s = np.einsum("kq,kqi->ki", tied[sel].astype(float), normals[sel])
        n[sel] = s / norm(s)[:, None]
        paired[sel] = True
    out["closest"][nodes], out["weights"][nodes], out["facet"][nodes] = xm, wm, facet
    out["normal"][nodes], out["paired"][nodes] = n, paired


def node_size(surface: Surface, nodes: npt.NDArray[np.int64]) -> Array:
    """The largest diameter of the facets of ``surface`` at each of the global blocks ``nodes`` (0: none)."""
    nv = surface.X.shape[1]
    diameter = np.max([norm(surface.X[:, i] - surface.X[:, j]) for i in range(nv) for j in range(i + 1, nv)], axis=0) \
        if surface.X.shape[0] else np.zeros(0)
    vertices, inverse = np.unique(surface.blocks.ravel(), return_inverse=True)
    largest = np.zeros(vertices.size)
    np.maximum.at(largest, inverse.ravel(), np.repeat(diameter, nv))
    pos = np.clip(np.searchsorted(vertices, nodes), 0, max(vertices.size - 1, 0))
    return np.where(vertices[pos] == nodes, largest[pos], 0.0) if vertices.size else np.zeros(nodes.size)


def tie_width(ties: tuple[npt.NDArray[np.int64], Array] | None, blocks: npt.ArrayLike) -> Array:
    """The width of each of the GLOBAL DOF blocks ``blocks`` in ``ties`` = (sorted global blocks, widths), the nodes
    of a geometry cycle (0 for a node not in it, and for every node when ``ties`` is None)."""
    blocks = np.asarray(blocks, dtype=np.int64)
    if ties is None or ties[0].size == 0:
        return np.zeros(blocks.shape)
    tied, width = ties
    pos = np.clip(np.searchsorted(tied, blocks), 0, tied.size - 1)
    return np.where(tied[pos] == blocks, width[pos], 0.0)


def where(x: Array) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in x) + ")"


def facet_sizes(surface: Surface) -> Array:
    """The diameter of every facet of ``surface`` (its longest vertex-to-vertex distance)."""
    nv = surface.X.shape[1]
    return np.max([norm(surface.X[:, i] - surface.X[:, j]) for i in range(nv) for j in range(i + 1, nv)], axis=0)


def facet_ranks(surface: Surface) -> npt.NDArray[np.intp]:
    """The rank of every facet of ``surface`` in the lexicographic order of its sorted global vertices (the tie
    rule of :func:`project`)."""
    key = np.sort(surface.blocks, axis=1)
    rank = np.empty(key.shape[0], dtype=np.intp)
    rank[np.lexsort(key.T[::-1])] = np.arange(key.shape[0])
    return rank
