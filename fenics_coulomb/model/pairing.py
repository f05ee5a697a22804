r"""The pairing of two elastic bodies: node-to-surface (this module) and dual mortar
(:mod:`fenics_coulomb.model.mortar`, the default ``method``): slave nodes, stencils, gaps, frames.

A :class:`ContactPair` names a slave surface S and a master surface M (facet tag values of one mesh's facet
tags) and a Coulomb coefficient F. :func:`pair_surfaces` computes, once and in the REFERENCE configuration,
for every slave vertex the data of the two-body model's change of variables u = (I + Φ) z: the stencil of
master vertices (Φ's slave-row, master-column blocks Φ_jl I₃), the gap and the frame. Below: the
node-to-surface definitions (the closest master point, φ_j its master shape functions); the mortar ones are in
:mod:`fenics_coulomb.model.mortar`, which shares the gathering, the checks and the several-pairs rule here::

    pairs = [ContactPair(facet_tags, slave=2, master=1, friction=0.3, name="press")]
    pairing = pair_surfaces(V, pairs, excluded=dirichlet_blocks)   # collective
    # pairing.blocks[i] (local, owned) ↔ pairing.master_blocks[i] (global, −1 padded) with pairing.weights[i]

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
  on the global numbering (which depends on the partition).
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
  |g| <= ``search_distance`` (default 0.1 × the diagonal of the master surface's bounding box).
* SIGN CHOICE: "d lies in the normal cone" is read as "±d lies in it", so that a slave node inside the
  master body (d points into it: −d is in C) is paired with g < 0 (n = −d/|d| at an edge/vertex, n_f inside
  a facet; g = d·n = −|d|). When both hold (only possible for a cone containing a line), +d is used.
* Several pairs: a node belongs to the pair with the smallest |g| among those where it is a contact node
  (ties, |g| equal within 1e-10 × the largest bounding-box diagonal of the pairs' M ∪ S: the first pair).

Dist(d, C) for a polyhedral cone in ℝ³ is evaluated exactly via Carathéodory: the minimum of the
non-negative least-squares residuals over the single generators and the pairs of generators, and 0 when d
is a non-negative combination of three independent generators.

Checks (InputError, one line, the same on every rank before the next collective call)
-------------------------------------------------------------------------------------
V not a vector P1/Q1 space; facet tags of another dimension than the facets'; a tag that no facet carries
on any rank; a tagged facet that is not on the mesh boundary; a pair that does not join two bodies: slave and
master surfaces with a common facet (slave = master, or one containing the other), or (in the reference
configuration) both on one connected part of the mesh (:func:`fenics_coulomb.model.two_body.connected_bodies`;
a slave node of that body named); Φ² ≠ 0 (a contact node that is itself a vertex of a master facet used by
any contact node — with two bodies per pair only possible across pairs — both nodes named by coordinates);
an overlap at the reference configuration that cannot be an interference, on the true geometry: a slave node
over M, not a contact node, whose node-to-surface distance to M (the rules above) is below −(the search
distance) (a body inside the other), or a master node over S within the search distance whose node-to-surface
distance to S is below −max(1e-6 × the diagonal of the bounding box of M ∪ S, twice the deepest contact
node's interference), counted only to the thickness of the slave's cell layer under its closest point (twice
the distance of that cell's centroid from the facet: deeper, S alone cannot tell the inside of the slave body
from the space beyond a thin one) (node and depth named, the deepest over all ranks). A contact node inside
the master body is an interference: a negative initial gap, which the solve resolves (a shrink fit; two curved
surfaces meshed independently at the same radius overlap by their facetting). For mortar pairs this is NOT the nodal
gap g̃_j / D_j: the dual basis is negative on part of each facet, so g̃_j can be negative beside a curved master where
no point overlaps; such a node is a contact node with a negative initial gap, and the solve separates it. Invalid
ContactPair fields (friction, search distance, tags, name) are rejected when the pair is created. A pair with no
contact node is a logged warning (rank 0), not an error.

Parallel
--------
Every rank gathers every pair's whole master surface (vertex coordinates, global DOF-block indices, outward
orientation; facets deduplicated by their global vertices), so the pairing of a slave node does not depend
on where the master facets are: 1 rank and N ranks give the same pairing (up to the numbering, and the
zero-weight vertices listed for a node on a shared edge or vertex, see the tie rule).

Size: about 900 lines, 140 of them the exact model above (held-out references depend on it); the projection, the
cone test and the pairing are one algorithm that the surface obstacles (:mod:`fenics_coulomb.model.surface`) reuse.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import chain
from typing import Any

from mpi4py import MPI

import basix
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.frames import frames_from_normals
from fenics_coulomb.model.mortar import mortar_nodes

__all__ = ["ContactPair", "Pairing", "pair_surfaces"]

logger = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Relative tolerances (× the facet size h): coincident closest points, |x_s − x_m| ≈ 0, "on the boundary"
#: (in reference coordinates); the normal cone; the reference overlap (× the bounding-box diagonal).
TIE_TOL = 1e-10
CONE_TOL = 1e-8
OVERLAP_TOL = 1e-6
#: The discretizations of a pair: dual mortar (the default) and node-to-surface.
METHODS = ("mortar", "node-to-surface")


# -- the pair ---------------------------------------------------------------------------------------------
def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _is_real(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _tags(value: Any, key: str, owner: str) -> tuple[int, ...]:
    if _is_int(value):
        return (int(value),)
    if isinstance(value, (list, tuple, np.ndarray)) and all(_is_int(v) for v in value):
        if len(value) == 0:
            raise InputError(f"{owner}: {key} = {list(value)!r}: an empty surface (name at least one facet tag)")
        return tuple(int(v) for v in value)
    raise InputError(f"{owner}: {key} = {value!r}: must be a facet tag (an integer) or a list of them")


@dataclass(frozen=True)
class ContactPair:
    """A slave surface S, a master surface M (facet tag values of ``facet_tags``), a Coulomb coefficient.

    Attributes:
        facet_tags: The mesh's facet tags.
        slave: Tag value(s) of the slave surface S (its vertices become contact nodes).
        master: Tag value(s) of the master surface M.
        friction: Coulomb coefficient F >= 0.
        search_distance: Largest |g| of a contact node; default 0.1 × M's bounding-box diagonal.
        name: Optional name used in messages.
        method: ``"mortar"`` (default: dual mortar, :mod:`fenics_coulomb.model.mortar`; passes the patch test)
            or ``"node-to-surface"`` (each slave node against its closest master point, this module).
    """

    facet_tags: dolfinx.mesh.MeshTags
    slave: int | Sequence[int]
    master: int | Sequence[int]
    friction: float = 0.0
    search_distance: float | None = None
    name: str | None = None
    method: str = "mortar"

    def __post_init__(self) -> None:
        owner = self.label
        if self.method not in METHODS:
            raise InputError(f"{owner}: method = {self.method!r}: must be one of {', '.join(map(repr, METHODS))}")
        if self.name is not None and (not isinstance(self.name, str) or not self.name):
            raise InputError(f"contact pair: name = {self.name!r}: must be a non-empty string")
        _tags(self.slave, "slave", owner)
        _tags(self.master, "master", owner)
        if not _is_real(self.friction) or not math.isfinite(float(self.friction)) or float(self.friction) < 0:
            raise InputError(f"{owner}: friction = {self.friction!r}: must be a finite number >= 0")
        sd = self.search_distance
        if sd is not None and (not _is_real(sd) or not math.isfinite(float(sd)) or float(sd) <= 0):
            raise InputError(f"{owner}: search_distance = {sd!r}: must be a finite number > 0 (or None)")
        if not hasattr(self.facet_tags, "find") or getattr(self.facet_tags, "dim", None) is None:
            raise InputError(f"{owner}: facet_tags = {type(self.facet_tags).__name__}: must be dolfinx MeshTags")

    @property
    def label(self) -> str:
        """How messages name the pair (without its position; :func:`pair_surfaces` adds it)."""
        return f"contact pair {self.name!r}" if self.name else "contact pair"

    @property
    def slave_tags(self) -> tuple[int, ...]:
        """The slave tag values as a tuple."""
        return _tags(self.slave, "slave", self.label)

    @property
    def master_tags(self) -> tuple[int, ...]:
        """The master tag values as a tuple."""
        return _tags(self.master, "master", self.label)


@dataclass
class Pairing:
    """The contact nodes of all pairs owned by this rank (ascending local block).

    Attributes:
        blocks: LOCAL owned DOF-block index of each contact node, ascending, shape (m,).
        coordinates: x_s, shape (m, 3).
        closest: x_m, shape (m, 3).
        gap: g = (x_s − x_m)·n, shape (m,).
        frames: (t₁, t₂, n) as columns, shape (m, 3, 3).
        master_blocks: GLOBAL DOF-block indices of the stencil's master nodes, shape (m, k) (−1 padding):
            node-to-surface the chosen master facet's vertices (k = 4, padding for triangles); mortar the
            master nodes l with Φ_jl ≠ 0 (k the widest stencil on any rank, at least 4).
        weights: Φ_jl (node-to-surface: φ_j at x_m), 0 on padding, shape (m, k); rows sum to 1.
        area: Mortar D_j (the pressure is f_j·n_j / D_j); NaN for node-to-surface nodes, shape (m,).
        pair_index: Index of each node's pair, shape (m,).
        friction: The pair's F per node, shape (m,).
        num_global: Number of contact nodes on all ranks.
        free: The owned slave nodes that are NOT contact nodes but lie over a master surface (in its normal
            cone): beyond the search distance, or with a Dirichlet component. Keys ``blocks`` (local),
            ``gap``, ``normals``, ``master_blocks``, ``weights`` as above (the pair with the smallest |g|), for the
            penetration check after a solve
            (:meth:`fenics_coulomb.model.contact_model.ContactModel.free_slave_penetrations`).
    """

    blocks: npt.NDArray[np.int32]
    coordinates: Array
    closest: Array
    gap: Array
    frames: Array
    master_blocks: npt.NDArray[np.int64]
    weights: Array
    area: Array
    pair_index: npt.NDArray[np.intp]
    friction: Array
    num_global: int
    free: dict[str, np.ndarray] = field(default_factory=dict)

    def subset(self, keep: npt.NDArray[np.bool_], comm: MPI.Comm) -> Pairing:
        """The pairing of the nodes ``keep`` selects (collective: the global count)."""
        return Pairing(blocks=self.blocks[keep], coordinates=self.coordinates[keep], closest=self.closest[keep],
                       gap=self.gap[keep], frames=self.frames[keep], master_blocks=self.master_blocks[keep],
                       weights=self.weights[keep], area=self.area[keep], pair_index=self.pair_index[keep],
                       friction=self.friction[keep], num_global=comm.allreduce(int(np.sum(keep)), op=MPI.SUM),
                       free=self.free)

    @property
    def normals(self) -> Array:
        """n of each contact node, shape (m, 3)."""
        return np.ascontiguousarray(self.frames[:, :, 2])

    @property
    def size(self) -> int:
        """Number of contact nodes owned by this rank."""
        return int(self.blocks.size)


# -- facet geometry ---------------------------------------------------------------------------------------
def _norm(x: Array) -> Array:
    return np.linalg.norm(x, axis=-1)


def _dot(a: Array, b: Array) -> Array:
    return np.einsum("...i,...i->...", a, b)


def _segment(p: Array, a: Array, b: Array) -> tuple[Array, Array]:
    """Closest points of the segments [a, b] to p and their parameters t ∈ [0, 1]."""
    ab = b - a
    t = np.clip(_dot(p - a, ab) / np.maximum(_dot(ab, ab), np.finfo(float).tiny), 0.0, 1.0)
    return a + t[:, None] * ab, t


def _closest_triangle(p: Array, X: Array) -> tuple[Array, Array, Array]:
    """Closest points of triangles X (k, 3, 3) to p (k, 3): (points, barycentric weights (k, 3), distance)."""
    A, B, C = X[:, 0], X[:, 1], X[:, 2]
    e1, e2, r = B - A, C - A, p - A
    a11, a12, a22 = _dot(e1, e1), _dot(e1, e2), _dot(e2, e2)
    b1, b2 = _dot(e1, r), _dot(e2, r)
    det = a11 * a22 - a12 * a12
    l1 = (a22 * b1 - a12 * b2) / det
    l2 = (a11 * b2 - a12 * b1) / det
    inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
    w = np.stack([1 - l1 - l2, l1, l2], axis=1)
    candidates = [(A + l1[:, None] * e1 + l2[:, None] * e2, w, inside)]
    for i, j in ((0, 1), (1, 2), (2, 0)):
        q, t = _segment(p, X[:, i], X[:, j])
        we = np.zeros((p.shape[0], 3))
        we[:, i], we[:, j] = 1 - t, t
        candidates.append((q, we, np.ones_like(inside)))
    return _pick(p, candidates)


def _quad_map(X: Array, xi: Array, eta: Array) -> tuple[Array, Array, Array]:
    """x(ξ, η), x_ξ, x_η of bilinear quadrilaterals X (k, 4, 3)."""
    a, b = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    c = X[:, 0] - X[:, 1] - X[:, 2] + X[:, 3]
    x = X[:, 0] + xi[:, None] * a + eta[:, None] * b + (xi * eta)[:, None] * c
    return x, a + eta[:, None] * c, b + xi[:, None] * c


def _quad_weights(xi: Array, eta: Array) -> Array:
    return np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta], axis=1)


def _closest_quad(p: Array, X: Array) -> tuple[Array, Array, Array]:
    """Closest points of bilinear quadrilaterals X (k, 4, 3) to p (k, 3): (points, weights (k, 4), distance)."""
    k = p.shape[0]
    xi, eta = np.full(k, 0.5), np.full(k, 0.5)
    scale = np.maximum(_norm(X[:, 3] - X[:, 0]), _norm(X[:, 2] - X[:, 1]))
    active = np.arange(k)
    for _ in range(50):  # Newton on the stationarity of ½|x − p|², vectorized over the pairs still moving
        Xa, pa, xa, ea = X[active], p[active], xi[active], eta[active]
        x, xx, xe = _quad_map(Xa, xa, ea)
        r = x - pa
        g1, g2 = _dot(xx, r), _dot(xe, r)
        h11, h22, h12 = _dot(xx, xx), _dot(xe, xe), _dot(xx, xe)
        full = h12 + _dot(r, Xa[:, 0] - Xa[:, 1] - Xa[:, 2] + Xa[:, 3])
        det_full = h11 * h22 - full * full
        h12 = np.where(det_full > 1e-12 * h11 * h22, full, h12)  # Gauss–Newton where not positive definite
        det = np.maximum(h11 * h22 - h12 * h12, np.finfo(float).tiny)
        dxi = -(h22 * g1 - h12 * g2) / det
        deta = -(h11 * g2 - h12 * g1) / det
        xa, ea = np.clip(xa + dxi, -0.5, 1.5), np.clip(ea + deta, -0.5, 1.5)
        xi[active], eta[active] = xa, ea
        # done: converged, or pushed to the clipping box (far outside the patch: the edges hold the minimum)
        moving = (np.maximum(np.abs(dxi), np.abs(deta)) > 1e-14) & (np.abs(xa - 0.5) < 1) & (np.abs(ea - 0.5) < 1)
        active = active[moving]
        if active.size == 0:
            break
    x, xx, xe = _quad_map(X, xi, eta)
    r = x - p
    # the stationarity residual, relative to the patch: a converged interior point
    stationary = (np.abs(_dot(xx, r)) + np.abs(_dot(xe, r))) <= 1e-12 * scale * (scale + _norm(r))
    inside = stationary & (xi >= -TIE_TOL) & (xi <= 1 + TIE_TOL) & (eta >= -TIE_TOL) & (eta <= 1 + TIE_TOL)
    xi_c, eta_c = np.clip(xi, 0.0, 1.0), np.clip(eta, 0.0, 1.0)
    candidates = [(_quad_map(X, xi_c, eta_c)[0], _quad_weights(xi_c, eta_c), inside)]
    ones, zeros = np.ones(k), np.zeros(k)
    for i, j, fixed in ((0, 1, "eta0"), (2, 3, "eta1"), (0, 2, "xi0"), (1, 3, "xi1")):
        q, t = _segment(p, X[:, i], X[:, j])
        if fixed.startswith("eta"):
            a, b = t, (zeros if fixed == "eta0" else ones)
        else:
            a, b = (zeros if fixed == "xi0" else ones), t
        candidates.append((q, _quad_weights(a, b), np.ones(k, dtype=bool)))
    return _pick(p, candidates)


def _pick(p: Array, candidates: list) -> tuple[Array, Array, Array]:
    """The nearest valid candidate (the first on exact ties)."""
    dist = np.stack([np.where(ok, _norm(q - p), np.inf) for q, _, ok in candidates])
    best = np.argmin(dist, axis=0)
    rows = np.arange(p.shape[0])
    q = np.stack([c[0] for c in candidates])[best, rows]
    w = np.stack([c[1] for c in candidates])[best, rows]
    return q, w, dist[best, rows]


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


def _facet_normals(X: Array, w: Array, sign: Array) -> Array:
    """Outward unit normals of facets X (k, nv, 3) at the reference points of the weights w (k, nv)."""
    if X.shape[1] == 3:
        N = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
    else:
        xi, eta = _reference(w)
        _, xx, xe = _quad_map(X, xi, eta)
        N = np.cross(xx, xe)
    return sign[:, None] * N / _norm(N)[:, None]


# -- the master surface -----------------------------------------------------------------------------------
@dataclass
class _Surface:
    """Facets of a surface: vertex coordinates (k, nv, 3), global DOF blocks (k, nv), orientation (k,)."""

    X: Array
    blocks: npt.NDArray[np.int64]
    sign: Array

    def unique(self) -> _Surface:
        """Without duplicates (a facet gathered from several ranks), in sorted order of the global blocks."""
        key = np.sort(self.blocks, axis=1)
        _, first = np.unique(key, axis=0, return_index=True)
        return _Surface(self.X[first], self.blocks[first], self.sign[first])


def _local_facets(facet_tags: dolfinx.mesh.MeshTags, tags: Sequence[int]) -> npt.NDArray[np.int32]:
    """This rank's facets carrying any of ``tags``, ascending."""
    found = [facet_tags.find(t) for t in tags]
    return np.unique(np.concatenate(found)).astype(np.int32) if found else np.zeros(0, np.int32)


def _facet_data(V: dolfinx.fem.FunctionSpace, facets: npt.NDArray[np.int32], X_dofs: Array) -> _Surface:
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
    N = _facet_normals(X, w, np.ones(facets.size)) if facets.size else np.zeros((0, 3))
    centre = X.mean(axis=1)
    sign = np.where(_dot(N, centroid - centre) > 0, -1.0, 1.0)
    imap = V.dofmap.index_map
    gblocks = imap.local_to_global(blocks.ravel().astype(np.int32)).reshape(blocks.shape).astype(np.int64)
    return _Surface(X, gblocks, sign)


def _basix_cell(msh: dolfinx.mesh.Mesh) -> basix.CellType:
    return {"hexahedron": basix.CellType.hexahedron, "tetrahedron": basix.CellType.tetrahedron}[
        msh.topology.cell_name()]


def _gather(comm: MPI.Comm, surface: _Surface, nv: int) -> _Surface:
    X = np.concatenate(comm.allgather(surface.X.reshape(-1, nv, 3)))
    blocks = np.concatenate(comm.allgather(surface.blocks.reshape(-1, nv)))
    sign = np.concatenate(comm.allgather(surface.sign))
    return _Surface(X, blocks, sign).unique()


# -- closest points ---------------------------------------------------------------------------------------
def _closest(p: Array, X: Array) -> tuple[Array, Array, Array]:
    return _closest_triangle(p, X) if X.shape[1] == 3 else _closest_quad(p, X)


def _cone_distance(d: Array, N: Array, mask: npt.NDArray[np.bool_]) -> Array:
    """dist(d, cone{N[:, i] : mask[:, i]}) for each row: d (k, 3), N (k, q, 3), mask (k, q)."""
    k, q = mask.shape
    best = np.full(k, np.inf)
    for i in range(q):
        c = np.maximum(_dot(d, N[:, i]), 0.0)
        best = np.where(mask[:, i], np.minimum(best, _norm(d - c[:, None] * N[:, i])), best)
    for i in range(q):
        for j in range(i + 1, q):
            a, b = N[:, i], N[:, j]
            aa, ab, bb = _dot(a, a), _dot(a, b), _dot(b, b)
            det = aa * bb - ab * ab
            ok = mask[:, i] & mask[:, j] & (det > 1e-14)
            da, db = _dot(d, a), _dot(d, b)
            safe = np.where(ok, det, 1.0)
            ca, cb = (bb * da - ab * db) / safe, (aa * db - ab * da) / safe
            ok &= (ca >= 0) & (cb >= 0)
            res = _norm(d - ca[:, None] * a - cb[:, None] * b)
            best = np.where(ok, np.minimum(best, res), best)
    for i in range(q):
        for j in range(i + 1, q):
            for m in range(j + 1, q):
                M = np.stack([N[:, i], N[:, j], N[:, m]], axis=2)
                det = np.linalg.det(M)
                ok = mask[:, i] & mask[:, j] & mask[:, m] & (np.abs(det) > 1e-12)
                if not ok.any():
                    continue
                coef = np.linalg.solve(np.where(ok[:, None, None], M, np.eye(3)), d[:, :, None])[:, :, 0]
                ok &= (coef >= 0).all(axis=1)
                best = np.where(ok, 0.0, best)
    return best


def _pair_nodes(x: Array, surface: _Surface, size: Array, rank: npt.NDArray[np.intp]) -> dict[str, Array]:
    """Closest points, weights, normals and cone membership of the nodes x (m, 3) on the gathered surface.

    Candidate facets: a first bound U on each node's distance from its 4 nearest facet centres, then every facet
    whose centre lies within U + r_f (+ the tie tolerance) of the node — a facet nearer than U, or tied with the
    nearest, is among them (its distance is at least its centre distance − its radius r_f). The facets are
    grouped by radius (powers of 2) with a KD-tree per group, so the small facets of a graded surface are not
    searched with the radius of its largest facet."""
    m, nv = x.shape[0], surface.X.shape[1]
    out = {"closest": np.zeros((m, 3)), "weights": np.zeros((m, nv)), "facet": np.zeros(m, np.intp),
           "normal": np.zeros((m, 3)), "paired": np.zeros(m, dtype=bool)}
    nf = surface.X.shape[0]
    if m == 0 or nf == 0:
        return out
    centres = surface.X.mean(axis=1)
    radius = _norm(surface.X - centres[:, None]).max(axis=1)
    hmax = float(size.max())
    k0 = min(nf, 4)
    _, ii = cKDTree(centres).query(x, k=k0)
    ii = ii.reshape(m, k0)
    _, _, dist = _closest(np.repeat(x, k0, axis=0), surface.X[ii.ravel()])
    bound = dist.reshape(m, k0).min(axis=1) + TIE_TOL * hmax + 1e-12 * (hmax + np.abs(x).max())
    # the candidate (node, facet) pairs, by radius classes
    level = np.floor(np.log2(np.maximum(radius, np.finfo(float).tiny))).astype(np.int64)
    nodes_l, facets_l = [], []
    for lv in np.unique(level):
        members = np.flatnonzero(level == lv)
        lists = cKDTree(centres[members]).query_ball_point(x, bound + radius[members].max())
        lengths = np.fromiter(map(len, lists), dtype=np.intp, count=m)
        nodes_l.append(np.repeat(np.arange(m), lengths))
        facets_l.append(members[np.fromiter(chain.from_iterable(lists), dtype=np.intp, count=int(lengths.sum()))])
    node = np.concatenate(nodes_l)
    facet = np.concatenate(facets_l)
    order = np.lexsort((facet, node))
    node, facet = node[order], facet[order]
    q, w, dist = _closest(x[node], surface.X[facet])
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
        _select(x[sel], facet[src], q[src], w[src], dk, surface, size, rank, out, sel)
    return out


def _select(x: Array, ii: npt.NDArray[np.intp], q: Array, w: Array, dist: Array, surface: _Surface,
            size: Array, rank: npt.NDArray[np.intp], out: dict[str, Array], nodes: npt.NDArray[np.intp]) -> None:
    """Pick x_m, the lexicographic facet among the tied ones, n and the cone test for a batch of nodes."""
    if nodes.size == 0:
        return
    rows = np.arange(nodes.size)
    near = np.argmin(dist, axis=1)
    h = size[ii[rows, near]]
    tol = TIE_TOL * h
    tied = (dist <= dist[rows, near][:, None] + tol[:, None]) & (_norm(q - q[rows, near][:, None]) <= tol[:, None])
    chosen = np.argmin(np.where(tied, rank[ii], np.iinfo(np.intp).max), axis=1)
    facet = ii[rows, chosen]
    xm, wm = q[rows, chosen], w[rows, chosen]
    kq = ii.shape[1]
    normals = _facet_normals(surface.X[ii.ravel()], w.reshape(-1, w.shape[-1]),
                             surface.sign[ii.ravel()]).reshape(-1, kq, 3)
    d = x - xm
    dn = _norm(d)
    tiny = dn <= tol
    edge = (tied.sum(axis=1) > 1) | _on_boundary(wm)
    n = normals[rows, chosen].copy()
    # inside a facet: n = n_f(x_m); the node is paired if ±d is along n (always, up to round-off)
    along = _norm(d - _dot(d, n)[:, None] * n) <= CONE_TOL * h
    paired = along.copy()
    # on an edge or vertex: n = ±d/|d| if ±d lies in the cone of the tied facets' normals
    sel = np.flatnonzero(edge & ~tiny)
    if sel.size:
        order = np.argsort(~tied[sel], axis=1, kind="stable")  # tied facets first
        qt = int(tied[sel].sum(axis=1).max())
        order = order[:, :qt]
        Nt = np.take_along_axis(normals[sel], order[:, :, None], axis=1)
        mt = np.take_along_axis(tied[sel], order, axis=1)
        plus = _cone_distance(d[sel], Nt, mt) <= CONE_TOL * h[sel]
        minus = _cone_distance(-d[sel], Nt, mt) <= CONE_TOL * h[sel]
        unit = d[sel] / dn[sel, None]
        n[sel] = np.where(plus[:, None], unit, np.where(minus[:, None], -unit, n[sel]))
        paired[sel] = plus | minus
    # x_s on the surface: the normalized sum of the tied facets' normals
    sel = np.flatnonzero(tiny)
    if sel.size:
        s = np.einsum("kq,kqi->ki", tied[sel].astype(float), normals[sel])
        n[sel] = s / _norm(s)[:, None]
        paired[sel] = True
    out["closest"][nodes], out["weights"][nodes], out["facet"][nodes] = xm, wm, facet
    out["normal"][nodes], out["paired"][nodes] = n, paired


# -- the pairing ------------------------------------------------------------------------------------------
def _node_size(surface: _Surface, nodes: npt.NDArray[np.int64]) -> Array:
    """The largest diameter of the facets of ``surface`` at each of the global blocks ``nodes`` (0: none)."""
    nv = surface.X.shape[1]
    diameter = np.max([_norm(surface.X[:, i] - surface.X[:, j]) for i in range(nv) for j in range(i + 1, nv)], axis=0) \
        if surface.X.shape[0] else np.zeros(0)
    vertices, inverse = np.unique(surface.blocks.ravel(), return_inverse=True)
    largest = np.zeros(vertices.size)
    np.maximum.at(largest, inverse.ravel(), np.repeat(diameter, nv))
    pos = np.clip(np.searchsorted(vertices, nodes), 0, max(vertices.size - 1, 0))
    return np.where(vertices[pos] == nodes, largest[pos], 0.0) if vertices.size else np.zeros(nodes.size)


def _where(x: Array) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in x) + ")"


def _diagonal(comm: MPI.Comm, points: Array) -> tuple[Array, Array]:
    """The global bounding box (lower, upper corner) of every rank's points."""
    lo = points.min(axis=0) if points.size else np.full(3, np.inf)
    hi = points.max(axis=0) if points.size else np.full(3, -np.inf)
    glo, ghi = np.empty(3), np.empty(3)
    comm.Allreduce(lo, glo, op=MPI.MIN)
    comm.Allreduce(hi, ghi, op=MPI.MAX)
    return glo, ghi


def pair_surfaces(V: dolfinx.fem.FunctionSpace, pairs: Sequence[ContactPair],
                  excluded: npt.NDArray[np.int32], coordinates: Array | None = None) -> Pairing:
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
            facets = _local_facets(pair.facet_tags, tags)
            counts.append([pair.facet_tags.find(t).size for t in tags])
            inner = np.setdiff1d(facets[facets < num_owned], exterior)  # each rank checks its owned facets
            if inner.size and not message:
                mid = dolfinx.mesh.compute_midpoints(msh, tdim - 1, inner[:1])[0]
                message = (f"{label}: {key} tag(s) {list(tags)} mark an interior facet (midpoint "
                           f"{_where(mid)}): contact surfaces must lie on the mesh boundary")
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
    per_pair = []
    for pair, (slave_facets, master_facets) in zip(pairs, surfaces, strict=True):
        master = _gather(comm, _facet_data(V, master_facets, X_dofs), nv)
        slave_blocks = np.unique(dolfinx.fem.locate_dofs_topological(V, tdim - 1, slave_facets))
        lo, hi = _diagonal(comm, np.concatenate([X_dofs[slave_blocks], master.X.reshape(-1, 3)]))
        body = float(np.linalg.norm(hi - lo))
        mlo, mhi = master.X.reshape(-1, 3).min(axis=0), master.X.reshape(-1, 3).max(axis=0)
        search = pair.search_distance if pair.search_distance is not None else 0.1 * float(np.linalg.norm(mhi - mlo))
        owned_slave = slave_blocks[slave_blocks < n_owned].astype(np.int32)
        nodes = np.setdiff1d(owned_slave, excluded).astype(np.int32)
        size = np.max([_norm(master.X[:, i] - master.X[:, j]) for i in range(nv) for j in range(i + 1, nv)], axis=0)
        key = np.sort(master.blocks, axis=1)
        rank = np.empty(key.shape[0], dtype=np.intp)
        rank[np.lexsort(key.T[::-1])] = np.arange(key.shape[0])
        slave = _gather(comm, _facet_data(V, slave_facets, X_dofs), nv) if pair.method == "mortar" or reference \
            else None
        if pair.method == "mortar":
            # the node-to-surface projection of every vertex of the slave facets at this rank's owned slave
            # nodes, once: the nodes to segment, the facets' anchors, the free nodes' penetration check
            g_owned = imap.local_to_global(owned_slave).astype(np.int64)
            touch = np.isin(slave.blocks, g_owned).any(axis=1)
            verts, first = np.unique(slave.blocks[touch].ravel(), return_index=True)
            projected = _pair_nodes(slave.X[touch].reshape(-1, 3)[first], master, size, rank)
            position = np.searchsorted(verts, g_owned)  # owned slave node i ↔ vertex position[i]
            at_nodes = position[np.searchsorted(owned_slave, nodes)]
            # segmented: the nodes within 2 × search + 4 h of M (node-to-surface distance; h the largest slave
            # facet diameter at the node); the others cannot have |g_j| <= search (see the mortar module)
            gn = g_owned[np.searchsorted(owned_slave, nodes)]
            near = _norm(X_dofs[nodes] - projected["closest"][at_nodes]) <= 2 * search + 4 * _node_size(slave, gn)
            try:  # a rank's facets may be bad where another's are not: every rank raises, before the next collective
                mortar = mortar_nodes((slave.X, slave.blocks, slave.sign), (master.X, master.blocks, master.sign),
                                      gn[near], (verts, projected["closest"]))
                failure = ""
            except InputError as err:
                failure = f"{pair.label}: {err}"
            check_all(comm, not failure, failure)
            g = np.full(nodes.size, np.inf)
            g[near] = mortar.gap
            normal = np.tile([0.0, 0.0, 1.0], (nodes.size, 1))
            normal[near] = mortar.normal
            R = frames_from_normals(normal) if nodes.size else np.zeros((0, 3, 3))
            contact = np.zeros(nodes.size, dtype=bool)
            contact[near] = mortar.fully_covered & (np.abs(mortar.gap) <= search)
            closest = X_dofs[nodes] - np.where(np.isfinite(g), g, 0.0)[:, None] * normal
            # the overlap check's pointwise gap: the node-to-surface distance where the node lies over M
            pointwise = np.where(projected["paired"][at_nodes],
                                 _dot(X_dofs[nodes] - projected["closest"][at_nodes], projected["normal"][at_nodes]),
                                 np.inf)
            stencil_blocks = np.full((nodes.size, mortar.stencil.shape[1]), -1, np.int64)
            stencil = np.zeros((nodes.size, mortar.stencil.shape[1]))
            stencil_blocks[near], stencil[near] = mortar.stencil_blocks, mortar.stencil
            D = np.zeros(nodes.size)
            D[near] = mortar.D
            others = np.setdiff1d(owned_slave, nodes[contact]).astype(np.int32)
            at = position[np.searchsorted(owned_slave, others)]
            ro = {key: value[at] for key, value in projected.items()}
        else:
            res = _pair_nodes(X_dofs[nodes], master, size, rank)
            R = frames_from_normals(res["normal"]) if nodes.size else np.zeros((0, 3, 3))
            g = _dot(X_dofs[nodes] - res["closest"], res["normal"])
            contact = res["paired"] & (np.abs(g) <= search)
            closest = res["closest"]
            stencil_blocks = master.blocks[res["facet"]] if nodes.size else np.zeros((0, nv), np.int64)
            stencil = res["weights"]
            D = np.full(nodes.size, np.nan)
            pointwise = np.where(res["paired"], g, np.inf)
            others = np.setdiff1d(owned_slave, nodes[contact]).astype(np.int32)
            ro = _pair_nodes(X_dofs[others], master, size, rank)
        # the other owned slave nodes over M (Dirichlet ones, beyond the search distance, mortar nodes not fully
        # covered): checked for penetration after a solve, with their node-to-surface projection
        go = _dot(X_dofs[others] - ro["closest"], ro["normal"])
        over = ro["paired"]
        per_pair.append(dict(nodes=nodes, g=g, R=R, contact=contact, closest=closest, blocks=stencil_blocks,
                             weights=stencil, D=D, body=body, pointwise=pointwise, search=search,
                             master_depth=_master_overlap(imap, slave, _thickness(comm, V, slave_facets, X_dofs),
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
    coordinates = X_dofs[blocks].copy()
    closest, gap, area = np.zeros((m, 3)), np.zeros(m), np.zeros(m)
    # the stencils' width: 4 (node-to-surface) or the widest mortar stencil of a contact node on any rank
    width = 4
    for i, p in enumerate(per_pair):
        src = np.searchsorted(p["nodes"], blocks[winner == i])
        used = (p["blocks"][src] >= 0).sum(axis=1).max(initial=0) if src.size else 0
        width = max(width, int(used))
    width = comm.allreduce(width, op=MPI.MAX)
    frames, master_blocks, weights = np.zeros((m, 3, 3)), np.full((m, width), -1, np.int64), np.zeros((m, width))
    friction = np.zeros(m)
    for i, p in enumerate(per_pair):
        sel = np.flatnonzero(winner == i)
        src = np.searchsorted(p["nodes"], blocks[sel])
        closest[sel], gap[sel], frames[sel] = p["closest"][src], p["g"][src], p["R"][src]
        k = min(p["blocks"].shape[1], width)
        master_blocks[sel, :k], weights[sel, :k] = p["blocks"][src, :k], p["weights"][src, :k]
        area[sel] = p["D"][src]
        friction[sel] = float(pairs[i].friction)

    # Φ² = 0: no contact node is a vertex of a master facet used by any contact node
    gblocks = imap.local_range[0] + blocks.astype(np.int64)
    all_g = np.concatenate(comm.allgather(gblocks))
    all_x = np.concatenate(comm.allgather(coordinates))
    all_mb = np.concatenate(comm.allgather(master_blocks))
    message = ""
    hit = np.flatnonzero(np.isin(all_g, all_mb))
    if hit.size:
        bad = int(hit[np.argmin(all_g[hit])])
        user = int(np.flatnonzero((all_mb == all_g[bad]).any(axis=1))[0])
        message = (f"contact node {_where(all_x[bad])} is a vertex of the master facet used by contact node "
                   f"{_where(all_x[user])}: Φ² = 0 needs slave surfaces without master-surface nodes "
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
                                f"distance: slave node {_where(X_dofs[free['blocks'][k]])} lies {depth:.6g} inside "
                                f"the master body (search distance {p['search']:.6g}): not an interference the pair "
                                "can resolve (a body inside the other?); enlarge search_distance or fix the geometry")
        x, d = p["master_depth"]
        allowed = max(OVERLAP_TOL * p["body"], 2.0 * interference)
        if d.size and d.max() > allowed:
            k = int(np.argmax(d))
            if worst is None or d[k] > worst[0]:
                worst = (float(d[k]), f"{labels[i]}: the bodies overlap at the reference configuration: master "
                                      f"node {_where(x[k])} lies {d[k]:.6g} inside the slave body, between its "
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
    return Pairing(blocks=blocks, coordinates=coordinates, closest=closest, gap=gap, frames=frames,
                   master_blocks=master_blocks, weights=weights, area=area, pair_index=winner.astype(np.intp),
                   friction=friction, num_global=int(count.sum()) if pairs else 0,
                   free=_free_nodes([p["free"] for p in per_pair], blocks, nv))


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
    from fenics_coulomb.model.two_body import connected_bodies

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
                    f"on one body (the connected part of the mesh through the slave node {_where(points[0])}): a "
                    "contact pair joins surfaces of two different bodies")
    return ""


def _thickness(comm: MPI.Comm, V: dolfinx.fem.FunctionSpace, facets: npt.NDArray[np.int32], X: Array) -> Array:
    """Twice the distance of each facet's cell centroid from the facet's centre along its normal (about the
    thickness of the cell layer under the facet), in the order of :func:`_gather` of the same facets."""
    msh = V.mesh
    tdim = msh.topology.dim
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    surface = _facet_data(V, facets, X)
    cells = f2c.array[f2c.offsets[facets]]
    centroid = X[V.dofmap.list[cells]].mean(axis=1)
    nv = surface.X.shape[1]
    normal = _facet_normals(surface.X, np.full((facets.size, nv), 1.0 / nv), surface.sign) if facets.size \
        else np.zeros((0, 3))
    local = 2 * np.abs(_dot(centroid - surface.X.mean(axis=1), normal))
    blocks = np.concatenate(comm.allgather(surface.blocks.reshape(-1, nv)))
    thickness = np.concatenate(comm.allgather(local))
    _, first = np.unique(np.sort(blocks, axis=1), axis=0, return_index=True)
    return thickness[first]


def _master_overlap(imap: Any, slave: _Surface, thickness: Array, master: _Surface, search: float
                    ) -> tuple[Array, Array]:
    """The master nodes owned by this rank (``imap``: the DOF-block index map) that lie over the gathered slave
    surface S (in its normal cone) within the search distance and within the thickness of the cell layer under
    their closest slave facet (``thickness``, per facet of S; deeper, S alone does not tell inside the slave
    body from beyond a thin one), with their depth inside the slave body (−g, the node-to-surface gap on S):
    (coordinates, depth)."""
    nv = master.X.shape[1]
    lo, hi = imap.local_range
    vertices, first = np.unique(master.blocks.ravel(), return_index=True)
    mine = (vertices >= lo) & (vertices < hi)
    x = master.X.reshape(-1, 3)[first[mine]]
    if x.shape[0] == 0 or slave.X.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros(0)
    size = np.max([_norm(slave.X[:, i] - slave.X[:, j]) for i in range(nv) for j in range(i + 1, nv)], axis=0)
    key = np.sort(slave.blocks, axis=1)
    rank = np.empty(key.shape[0], dtype=np.intp)
    rank[np.lexsort(key.T[::-1])] = np.arange(key.shape[0])
    res = _pair_nodes(x, slave, size, rank)
    g = _dot(x - res["closest"], res["normal"])
    over = res["paired"] & (np.abs(g) <= search) & (-g < thickness[res["facet"]])
    return x[over], -g[over]


def _free_nodes(per_pair: list[dict[str, np.ndarray]], contact: npt.NDArray[np.int32], nv: int
                ) -> dict[str, np.ndarray]:
    """The free slave nodes over a master surface, each with the pair of smallest |g| (not contact nodes of
    another pair)."""
    out = {"blocks": np.zeros(0, np.int32), "gap": np.zeros(0), "normals": np.zeros((0, 3)),
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
