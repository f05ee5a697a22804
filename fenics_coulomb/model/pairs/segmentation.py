r"""Dual mortar segmentation and integration: the stencil Φ_jl = M_jl / D_j, the weighted gap, the slave nodal
normals of a pair — the same change of variables u = (I + Φ) z as node-to-surface contact (the method itself:
:mod:`fenics_coulomb.model.pairs.mortar`; the polygons: :mod:`fenics_coulomb.model.pairs.polygons`).

With biorthogonal ("dual") multipliers the mortar matrix D of the slave side is diagonal, so the mortar
constraint of slave node j, D_j u_j − Σ_l M_jl u_l, divided by D_j is again a node-wise relative displacement

    w_j = u_j − Σ_l Φ_jl u_l,   Φ_jl = M_jl / D_j,

exactly the form of :mod:`fenics_coulomb.model.pairs.two_body` (there Φ_jl = the master shape functions at one
closest point). Only the pairing changes; the SCD Newton, the frames and friction are those of one node.

Derivation
----------
Let λ_h = Σ_j λ_j ψ_j be the contact traction on the slave surface S (ψ_j the dual basis below) and
u^s, u^m the slave and master displacements. The mortar coupling is the virtual work

    ∫_S λ_h · (u^s − u^m ∘ π) ds = Σ_j λ_j · (D_j u_j − Σ_l M_jl u_l),

    D_jk = ∫_S ψ_j N_k^s ds = δ_jk D_j   (biorthogonality),   M_jl = ∫_S ψ_j (N_l^m ∘ π) ds,

π the map of a slave point to the master point opposite it (here: the same point of an auxiliary plane).
So the slave node j receives the force f_j = D_j λ_j and the master node l receives −Σ_j M_jl λ_j = −Σ_j Φ_jl f_j
(the master forces of :meth:`fenics_coulomb.model.pairs.coupling.PairCoupling.master_forces`, unchanged), and the
contact conditions are imposed on the weighted gap g̃_j + n_j · (D_j u_j − Σ_l M_jl u_l) = D_j (g_j + n_j · w_j)
with the nodal gap g_j = g̃_j / D_j: node j is a contact node of the one-body form with u_j replaced by w_j and
the force f_j; its pressure is λ_j·n_j = f_j·n_j / D_j. A rigid translation c of both bodies gives
w_j = (1 − Σ_l Φ_jl) c = 0, since Σ_l N_l^m = 1 makes Σ_l M_jl = ∫ ψ_j = ∫ ψ_j Σ_k N_k^s = D_j on a fully
covered node. A uniform pressure p on a flat interface, λ_h = p n, has the nodal values λ_j = p n (Σ_j ψ_j = 1
reproduces constants) and gives the slave forces p D_j n = p ∫ N_j n and the master forces −p Σ_j M_jl n =
−p ∫ N_l^m n: the consistent loads of a uniform pressure on both bodies, so the patch test passes on any meshes.

The discretization (the definitions the held-out references use)
-----------------------------------------------------------------
All in the reference configuration, once per pair, for P1 triangles (N = 1 − ξ − η, ξ, η) and Q1
quadrilaterals (N = (1−ξ)(1−η), ξ(1−η), (1−ξ)η, ξη; basix vertex order).

* Slave nodal normal: n̂_j = the normalized sum, over the slave facets f containing vertex j, of f's unit
  outward normal (out of the SLAVE body) at x_j. The frame normal is n_j = −n̂_j (it plays the master's
  outward normal); t₁, t₂ from :func:`fenics_coulomb.model.frames.frames_from_normals`.
* Dual basis on each slave facet e: ψ_j = Σ_k A_jk N_k, A = D_e M_e⁻¹, D_e = diag(∫_e N_j ds),
  (M_e)_jk = ∫_e N_j N_k ds on the whole facet (triangle: the 7-point rule, exact; quadrilateral: 4 × 4 Gauss
  points of |x_ξ × x_η|, exact for a planar facet), so ∫_e ψ_j N_k = δ_jk ∫_e N_j.
* Segmentation: for each slave facet e the auxiliary plane P_e through its centre c_e (the vertex mean) with
  normal n_c = the facet's outward unit normal at its centre. The vertices of e and of each candidate master
  facet are projected orthogonally onto P_e (2D coordinates in an orthonormal basis of P_e), both polygons
  oriented counter-clockwise; a projected quadrilateral that is not convex is an InputError. The master
  polygon is clipped by the slave polygon (Sutherland–Hodgman). Each clip polygon loses its duplicate vertices
  (within CLEAN_TOL = 1e-6 × r_e of the previous one: a master vertex on the line of a slave edge comes out of
  the clipping twice) and its collinear ones (within 1e-6 r_e of the line through their neighbours); one left
  with fewer than 3 vertices (a sliver, an edge where two facets touch) is dropped. The rest is triangulated
  as the fan of its edges from its vertex mean, each triangle integrated with the symmetric 7-point Gauss rule
  of degree 5. So the triangles move continuously with the meshes: grids that share grid lines and the same
  grids offset by 1e-9 give the same triangles up to 1e-9 (where the 7-point rule is not exact — a
  non-parallelogram or warped facet — a vertex kept or not would change the result by the rule's error,
  1e-7 – 1e-5 of D_j, instead). The cleaning moves the integration domain by at most 1e-6 r_e × its
  perimeter, and only where a vertex lies that close to collinear (aligned meshes: by their offset from exact
  alignment); the coverage below uses the clip polygons before cleaning. A point p of P_e maps back
  to reference coordinates on e and on the master facet by inverting their projections onto P_e (linear for
  triangles, 20 Newton steps from the centre for the bilinear map of a quadrilateral); ds on e = dA / |n_c · n_e(ξ)|.
* D_j = Σ ∫ ψ_j N_j^s ds, M_jl = Σ ∫ ψ_j N_l^m ds, g̃_j = Σ ∫ ψ_j g ds over the segments of the facets containing
  j, with g = (x^s − x^m) · n(ξ), n(ξ) = Σ_k N_k^s n_k (the interpolated frame normal, not normalized).
  g_j = g̃_j / D_j, Φ_jl = M_jl / D_j (entries with |Φ_jl| <= 1e-12 are dropped: the zero-area slivers where
  a master facet only touches the slave facet along an edge or at a vertex).
* Coverage, decided by geometry: a slave facet e is covered when the shoelace areas of its clip polygons
  (exact polygon areas; a duplicate vertex adds nothing) sum to at least (1 − COVERAGE_TOL) × the area of e's
  own projection onto P_e; node j is fully covered when every slave facet containing j is covered. Only fully
  covered nodes are contact nodes (with no Dirichlet component and |g_j| <= the search distance): a partially
  covered node at the border of M is free, as a node beside M's outer edge is in node-to-surface contact
  ("edge dropping": the smaller surface should be the slave). The quadrature sums Σ ∫ N_j over the segments
  (``MortarNodes.covered``) are NOT the test: on a non-parallelogram or warped facet the 7-point rule
  integrates a non-polynomial integrand (the inverse bilinear maps, 1/|n_c · n_e|) and is off by 1e-8 – 5e-8,
  so a fixed threshold near 1 decides by round-off and quadrature error instead of geometry.

  COVERAGE_TOL = 1e-6, derived. Round-off: the clip vertices are intersections of lines through vertices of
  size r_e (relative error a few ε ≈ 1e-15), and the clipping counts points up to CLIP_TOL r_e = 1e-12 r_e
  outside an edge as inside, so a clip polygon's area is off by at most its perimeter × 1e-12 r_e; summed
  over the clip polygons of a facet (their perimeters add up to at most a few times 8 r_e) against the
  facet's area (≥ r_e²/10 for a facet that is not a sliver), the covered fraction of a covered facet is 1
  within about 1e-10: the tolerance is four orders above it. A real gap: a master border that leaves a strip
  of width w along a slave edge of length L uncovers the fraction ≈ w L / area ≈ w / h; below 1e-6 that strip
  is 1e-6 of a facet — under the geometric tolerance of mesh generators (gmsh: 1e-8 of the model) for borders
  meant to coincide, and far below any gap a model means. A node kept with an uncovered fraction τ <= 1e-6
  has D_j, M_jl, g̃_j over its covered part (their definitions unchanged): Σ_l Φ_jl = 1 up to about
  τ max|ψ_j| / (D_j / area) <= 40 τ, a rigid translation changing w_j by 4e-5 of it at worst, against
  freeing the node (100 % of its contact force lost).

  Coverage at aligned borders. Where the slave and the master surfaces end on one common border (a slice's cut
  face, both bodies held on it) and are curved, the projection along n_c — the facet's own normal, tilted
  against the border plane — moves the master's border vertices, which lie off P_e by the facets' sagittas and
  separation, across the slave's border by that distance times the tangent of the tilt: a strip along the slave
  facet's border is uncovered although nothing of the master is missing (measured: the shrink fit's one-layer
  quarter slice, docs/verification §7, in its deformed configuration: 1.5e-6 – 1.7e-5 of every bore facet, strips
  about 2e-6 h wide along the faces x3 = 0, t, where n_c tilts by 2e-3 out of the border plane and the shaft's border
  chords lie up to 1e-3 off P_e; finite sliding dropped all 42 bore nodes and cycled). A facet's covered fraction
  is therefore credited with the strip s_e × (its projected perimeter) of the width
  s_e = min(d_e · min(t_e, 1), ALIGNED_TOL · r_e): d_e the largest distance along n_c of e's vertices from their
  closest master points (their node-to-surface projections), t_e the tangent of the largest angle between n_c and
  the surfaces' normals (the slave nodal normals at e's vertices, the master facets e overlaps), and at most
  ALIGNED_TOL = 1e-4 of the facet's size (20× the shrink fit's strips; a kept node's Σ_l Φ_jl is then 1 to
  about 40 × its uncovered fraction, as above). s_e vanishes for parallel flat facets (every flat pair, whatever
  their separation: bit for bit as before) and for touching vertices; a facet reaching past a master edge by
  more than the strip stays uncovered. The
  credit applies to facets below a covered fraction of 1 and never raises one above 1.

  A deformed configuration X + u is known only to the displacement error ε of the solve that gave u (finite
  sliding: ERROR_PER_RTOL × its reduction × |u|∞, a loose intermediate solve's too): two borders meant to coincide
  lie up to 2ε apart by that error alone. The strip's width is therefore at least 2ε (still at most
  ALIGNED_TOL · r_e): a decision finer than the configuration is not made. Measured: the block of
  docs/verification/incline_two_bodies.toml on a 3× finer mesh (ν = 0: the exact u₂ is 0), GAMG's first loose
  solve (reduction 3.2e-4) left u₂ errors that uncovered strips 4e-8 – 3e-7 wide (2.9e-6 – 1.7e-5 of the facets)
  along the borders y = 0 and y = 1 where both bodies end; the geometry iteration dropped 12 nodes, then 48, and
  settled on 108 contact nodes with 35 free nodes penetrating by 3 % of the push, where LU keeps all 156.
  Once a finite sliding cycle is tied, the strip is at least its widest tie (``reach``, uncapped:
  :mod:`fenics_coulomb.model.geometry_cycles`).

Candidate master facets of a slave facet e: those facing it (n_m · n_c < 0 at the facets' centres, so the
far side of a curved or thin master is never counted twice) whose centre lies within 2 r_e + r_m of p_e, the
closest master point to e's centre (r the largest centre–vertex distance of a facet): every master facet
under e when the master is locally smooth and not steeper than about 60° against P_e. A master facet
parallel to n_c (projected area below 1e-10 of its own) is skipped.

Which slave nodes are segmented (:func:`fenics_coulomb.model.pairs.mortar.stencils`): those without a Dirichlet
component within 2 × the search distance + 4 h of M (their node-to-surface distance; h the largest diameter of
their slave facets). A node farther away cannot have |g_j| <= the search distance: on its facets g is at least
about its distance less h (the segments' x^s − x^m is at least as long as the distance of x^s from M, and n_c·n(ξ)
stays near 1 on a surface whose normals turn little across a facet), and g_j is an average of g with the weights
ψ_j, whose negative part is a fraction of D_j.

Vectorized over batches of (slave facet, master facet) pairs; contributions are summed per node in the
global order of the facets (sorted by their global vertex numbers), so every partition gives the same sums.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import chain
from typing import Any

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs.polygons import (clean_polygon, clip, convex, counter_clockwise, cross2,
                                                 polygon_area, polygon_perimeter)

__all__ = ["ALIGNED_TOL", "CLEAN_TOL", "COVERAGE_TOL", "GAUSS7", "GAUSS7_W", "MortarNodes", "dual_coefficients",
           "facet_map", "facet_normals", "mortar_nodes", "nodal_normals", "shape_functions"]

Array = npt.NDArray[np.float64]

#: Full coverage of a slave facet: its clip polygons' areas sum to at least (1 − COVERAGE_TOL) × its projected
#: area (derivation in the module docstring).
COVERAGE_TOL = 1e-6
#: At an aligned border a slave facet's uncovered strip is credited up to this × the facet's size (its largest
#: centre–vertex distance) wide, and only within the ambiguity of the projection direction (the module docstring,
#: "Coverage at aligned borders").
ALIGNED_TOL = 1e-4
#: Before triangulation a clip polygon loses the vertices within CLEAN_TOL × the slave facet's size of their
#: predecessor (duplicates) or of the line through their neighbours (collinear).
CLEAN_TOL = 1e-6
#: Stencil entries |Φ_jl| at most this are dropped (zero-area slivers).
DROP_TOL = 1e-12
#: Clipping: a point within CLIP_TOL × the slave facet's size of an edge's inside counts as inside.
CLIP_TOL = 1e-12
#: Candidate search: up to this many (slave facet, master facet) pairs are tested all at once, more with KD-trees
#: (the same candidates either way).
BRUTE_FORCE_PAIRS = 250_000
#: Pairs per batch (bounds the memory: about 56 quadrature points per pair).
BATCH = 4096

_S15 = np.sqrt(15.0)
_A1, _B1 = (9 - 2 * _S15) / 21, (6 + _S15) / 21
_A2, _B2 = (9 + 2 * _S15) / 21, (6 - _S15) / 21
#: The symmetric 7-point Gauss rule on a triangle, exact for degree 5: barycentric points and weights (sum 1).
GAUSS7 = np.array([[1 / 3, 1 / 3, 1 / 3],
                   [_A1, _B1, _B1], [_B1, _A1, _B1], [_B1, _B1, _A1],
                   [_A2, _B2, _B2], [_B2, _A2, _B2], [_B2, _B2, _A2]])
GAUSS7_W = np.array([9 / 40] + [(155 + _S15) / 1200] * 3 + [(155 - _S15) / 1200] * 3)

#: Polygon (cyclic) order of the facet vertices: triangle, quadrilateral (basix tensor order 0 1 2 3).
_CYCLE = {3: np.array([0, 1, 2]), 4: np.array([0, 1, 3, 2])}
#: Reference coordinates of the facet vertices.
_VERTICES = {3: np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
             4: np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])}


def _dot(a: npt.NDArray[Any], b: npt.NDArray[Any]) -> Array:
    return np.einsum("...i,...i->...", a, b)


def _norm(a: npt.NDArray[Any]) -> Array:
    return np.sqrt(_dot(a, a))


def shape_functions(nv: int, xi: Array, eta: Array) -> Array:
    """N at reference points (…): triangle (1 − ξ − η, ξ, η), quadrilateral the bilinear ones; shape (…, nv)."""
    if nv == 3:
        return np.stack([1 - xi - eta, xi, eta], axis=-1)
    return np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta], axis=-1)


def facet_map(X: Array, xi: Array, eta: Array) -> tuple[Array, Array, Array]:
    """x(ξ, η), x_ξ, x_η of facets X (…, nv, dim) at reference points (…) (broadcast over the leading axes)."""
    if X.shape[-2] == 3:
        a, b = X[..., 1, :] - X[..., 0, :], X[..., 2, :] - X[..., 0, :]
        x = X[..., 0, :] + xi[..., None] * a + eta[..., None] * b
        return x, np.broadcast_to(a, x.shape), np.broadcast_to(b, x.shape)
    a, b = X[..., 1, :] - X[..., 0, :], X[..., 2, :] - X[..., 0, :]
    c = X[..., 0, :] - X[..., 1, :] - X[..., 2, :] + X[..., 3, :]
    x = X[..., 0, :] + xi[..., None] * a + eta[..., None] * b + (xi * eta)[..., None] * c
    return x, a + eta[..., None] * c, b + xi[..., None] * c


def facet_normals(X: Array, sign: Array, xi: Array, eta: Array) -> Array:
    """Outward unit normals sign·(x_ξ × x_η)/|x_ξ × x_η| of facets X (…, nv, 3) at (ξ, η) (…)."""
    _, xx, xe = facet_map(X, xi, eta)
    N = np.cross(xx, xe)
    return sign[..., None] * N / _norm(N)[..., None]


def _inverse_2d(P: Array, p: Array) -> tuple[Array, Array]:
    """Reference coordinates of the points p (k, q, 2) in the 2D facets P (k, nv, 2): linear (triangle) or 20
    Newton steps from the centre (bilinear; a fixed count, so a point's result does not depend on its batch)."""
    a, b = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    r = p - P[:, None, 0]
    if P.shape[1] == 3:
        det = cross2(a, b)[:, None]
        return cross2(r, b[:, None]) / det, cross2(a[:, None], r) / det
    c = (P[:, 0] - P[:, 1] - P[:, 2] + P[:, 3])[:, None]
    a, b = a[:, None], b[:, None]
    xi = np.full(p.shape[:2], 0.5)
    eta = np.full(p.shape[:2], 0.5)
    for _ in range(20):
        f = xi[..., None] * a + eta[..., None] * b + (xi * eta)[..., None] * c - r
        ja, jb = a + eta[..., None] * c, b + xi[..., None] * c
        det = cross2(ja, jb)
        det = np.where(np.abs(det) > 0, det, 1.0)
        xi, eta = xi - cross2(f, jb) / det, eta - cross2(ja, f) / det
    return xi, eta


def dual_coefficients(X: Array) -> tuple[Array, Array]:
    """A = D_e M_e⁻¹ of the dual basis and D_e's diagonal ∫_e N_j ds for facets X (k, nv, 3) (whole facets)."""
    nv = X.shape[1]
    if nv == 3:
        xi, eta = GAUSS7[:, 1], GAUSS7[:, 2]
        w = 0.5 * GAUSS7_W
    else:
        nodes, node_weights = np.polynomial.legendre.leggauss(4)
        g, gw = 0.5 * (nodes + 1), 0.5 * node_weights
        xi, eta = np.repeat(g, 4), np.tile(g, 4)
        w = np.repeat(gw, 4) * np.tile(gw, 4)
    N = shape_functions(nv, xi, eta)  # (q, nv)
    _, xx, xe = facet_map(X[:, None], xi[None], eta[None])
    J = _norm(np.cross(xx, xe)) * w  # (k, q)
    Me = np.einsum("kq,qi,qj->kij", J, N, N)
    De = np.einsum("kq,qi->ki", J, N)
    A = np.transpose(np.linalg.solve(Me, De[:, :, None] * np.eye(nv)), (0, 2, 1))  # (M⁻¹ D)ᵀ = D M⁻¹
    return A, De


def _vertex_normals(X: Array, sign: Array) -> Array:
    """Each facet's outward unit normal at each of its vertices, shape (k, nv, 3)."""
    nv = X.shape[1]
    ref = _VERTICES[nv]
    return facet_normals(X[:, None], sign[:, None] * np.ones(nv), ref[None, :, 0] * np.ones((X.shape[0], 1)),
                         ref[None, :, 1] * np.ones((X.shape[0], 1)))


def nodal_normals(X: Array, blocks: npt.NDArray[np.int64], sign: Array) -> tuple[npt.NDArray[np.int64], Array]:
    """The slave FRAME normals n_j = −n̂_j of every vertex of the facets (sorted unique vertices, normals)."""
    vertices, inverse = np.unique(blocks.ravel(), return_inverse=True)
    total = np.zeros((vertices.size, 3))
    np.add.at(total, inverse, _vertex_normals(X, sign).reshape(-1, 3))
    return vertices, -total / _norm(total)[:, None]


@dataclass
class MortarNodes:
    """The mortar data of the requested slave nodes (in their order).

    Attributes:
        normal: Frame normal n_j = −n̂_j, shape (m, 3).
        D: D_j, shape (m,).
        full: ∫_S N_j ds over the whole slave facets containing j, shape (m,).
        covered: Σ ∫ N_j ds over the segments, shape (m,).
        weighted_gap: g̃_j, shape (m,).
        stencil_blocks: Global master blocks l with Φ_jl ≠ 0, ascending, −1 padded, shape (m, k).
        stencil: Φ_jl, 0 on padding, shape (m, k).
        M: M_jl on the same layout (unscaled), shape (m, k).
        coverage: The smallest, over the slave facets containing j, of the facet's covered fraction: the
            shoelace areas of its clip polygons summed, over its own projected area (1 up to round-off on a
            covered facet; credited with the projection's slack strip at an aligned border, capped at 1, see the
            module docstring), shape (m,).
    """

    normal: Array
    D: Array
    full: Array
    covered: Array
    weighted_gap: Array
    stencil_blocks: npt.NDArray[np.int64]
    stencil: Array
    M: Array
    coverage: Array

    @property
    def fully_covered(self) -> npt.NDArray[np.bool_]:
        """Every slave facet containing j covered: coverage >= 1 − COVERAGE_TOL (and D_j > 0)."""
        return (self.coverage >= 1 - COVERAGE_TOL) & (self.D > 0) & (self.full > 0)

    @property
    def gap(self) -> Array:
        """g_j = g̃_j / D_j (inf where D_j <= 0)."""
        return np.divide(self.weighted_gap, self.D, out=np.full_like(self.D, np.inf), where=self.D > 0)


def _tan_angle(a: Array, b: Array) -> Array:
    """tan of the angle between the unit vectors a and b (…, 3) (inf beyond 90°)."""
    cos = _dot(a, b)
    return np.where(cos > 0, _norm(np.cross(a, b)) / np.maximum(cos, np.finfo(float).tiny), np.inf)


def _where(x: Array) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in x) + ")"


def _candidates(s_centre: Array, s_radius: Array, anchors: Array, s_normal: Array, m_centre: Array,
                m_radius: Array, m_normal: Array) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """(slave facet, master facet) pairs with |c_m − p_e| <= 2 r_e + r_m, facing each other, sorted."""
    if anchors.shape[0] == 0 or m_centre.shape[0] == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    pad = 1e-9 * float(max(s_radius.max(), m_radius.max()))
    if anchors.shape[0] * m_centre.shape[0] <= BRUTE_FORCE_PAIRS:
        # every pair within 3 max(r_e, r_m) + pad (a superset of the pairs kept below, sorted like the queries')
        reach = 3 * np.maximum(s_radius[:, None], m_radius[None, :]) + 2 * pad
        d2 = np.sum((anchors[:, None, :] - m_centre[None, :, :]) ** 2, axis=-1)
        e, m = np.nonzero(d2 <= reach * reach)
    else:
        from scipy.spatial import cKDTree  # scipy only where used (fenics_coulomb/__init__.py)

        found = []
        # r_m <= r_e: within 3 r_e of p_e; r_m > r_e: within 3 r_m of c_m (the two queries cover every pair)
        lists = cKDTree(m_centre).query_ball_point(anchors, 3 * s_radius + pad)
        lengths = np.fromiter(map(len, lists), dtype=np.intp, count=len(lists))
        found.append((np.repeat(np.arange(len(lists)), lengths),
                      np.fromiter(chain.from_iterable(lists), dtype=np.intp, count=int(lengths.sum()))))
        lists = cKDTree(anchors).query_ball_point(m_centre, 3 * m_radius + pad)
        lengths = np.fromiter(map(len, lists), dtype=np.intp, count=len(lists))
        found.append((np.fromiter(chain.from_iterable(lists), dtype=np.intp, count=int(lengths.sum())),
                      np.repeat(np.arange(len(lists)), lengths)))
        e = np.concatenate([f[0] for f in found])
        m = np.concatenate([f[1] for f in found])
        key = np.unique(e.astype(np.int64) * m_centre.shape[0] + m)
        e, m = key // m_centre.shape[0], key % m_centre.shape[0]
    near = _norm(m_centre[m] - anchors[e]) <= 2 * s_radius[e] + m_radius[m] + pad
    facing = _dot(m_normal[m], s_normal[e]) < 0
    # necessary for overlapping projections: the centres within r_e + r_m of each other along the plane P_e
    d = m_centre[m] - s_centre[e]
    lateral = _norm(d - _dot(d, s_normal[e])[:, None] * s_normal[e])
    keep = near & facing & (lateral <= s_radius[e] + m_radius[m] + pad)
    return e[keep].astype(np.intp), m[keep].astype(np.intp)


def mortar_nodes(slave: tuple[Array, npt.NDArray[np.int64], Array], master: tuple[Array, npt.NDArray[np.int64], Array],
                 nodes: npt.NDArray[np.int64], vertex_closest: tuple[npt.NDArray[np.int64], Array],
                 resolution: float = 0.0, reach: float = 0.0) -> MortarNodes:
    """The mortar data of the slave nodes ``nodes`` (global blocks) of one pair (see the module docstring).

    Args:
        slave: The whole slave surface (every rank's facets): vertex coordinates (F, nv, 3), global blocks
            (F, nv), outward orientation ±1 (F,) (out of the slave body), facets sorted by their vertices.
        master: The whole master surface, likewise (orientation out of the master body).
        nodes: The global blocks of the slave nodes wanted.
        vertex_closest: The closest master points (the node-to-surface projection) of the vertices of every slave
            facet at ``nodes``: their global blocks (sorted) and the points; a facet's anchor p_e (the candidate
            search) is the mean of its vertices' points.
        resolution: The configuration's own displacement error (a length; 0 for the reference configuration): a
            facet's uncovered border strip up to 2 × resolution wide is credited as covered (see "Coverage at
            aligned borders").
        reach: The widest tie of a geometry cycle (0: none): a facet's uncovered border strip up to that wide is
            credited as covered (see "Coverage at aligned borders"; :mod:`fenics_coulomb.model.geometry_cycles`).

    Raises:
        InputError: A projected quadrilateral that is not convex (the facet named by its centre).
    """
    sX, sB, sS = slave
    mX, mB, mS = master
    m = nodes.size
    nv, nvm = sX.shape[1], mX.shape[1]
    empty = MortarNodes(np.zeros((m, 3)), np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(m),
                        np.full((m, 1), -1, np.int64), np.zeros((m, 1)), np.zeros((m, 1)), np.zeros(m))
    if m == 0 or sX.shape[0] == 0:
        return empty
    vertices, frame_normals = nodal_normals(sX, sB, sS)
    mine = np.isin(sB, nodes).any(axis=1)
    E = np.flatnonzero(mine)
    X, B, sign = sX[E], sB[E], sS[E]
    A, De = dual_coefficients(X)
    nF = E.size
    # the auxiliary planes: centre, normal, an orthonormal basis (e1, e2) with e1 × e2 = n_c
    centre = X.mean(axis=1)
    half = np.full(nF, 0.5) if nv == 4 else np.full(nF, 1 / 3)
    nc = facet_normals(X, sign, half, half)
    e1 = X[:, 1] - X[:, 0]
    e1 -= _dot(e1, nc)[:, None] * nc
    e1 /= _norm(e1)[:, None]
    e2 = np.cross(nc, e1)
    s2 = np.stack([_dot(X - centre[:, None], e1[:, None]), _dot(X - centre[:, None], e2[:, None])], axis=-1)
    s_poly, s_area = counter_clockwise(s2[:, _CYCLE[nv]])
    s_radius = _norm(X - centre[:, None]).max(axis=1)
    # the slave nodal normals' tilt against n_c (tan of the largest angle over e's vertices)
    n_hat = -frame_normals[np.searchsorted(vertices, B)]  # (nF, nv, 3), out of the slave body
    tilt = _tan_angle(n_hat, nc[:, None]).max(axis=1)
    if nv == 4:
        bad = np.flatnonzero(~convex(s_poly))
        if bad.size:
            raise InputError(f"slave facet at {_where(centre[bad[0]])}: its projection onto its own auxiliary plane is "
                             "not a convex quadrilateral (a warped facet): the mortar segmentation needs convex facets")
    m_centre = mX.mean(axis=1)
    m_radius = _norm(mX - m_centre[:, None]).max(axis=1)
    mhalf = np.full(mX.shape[0], 0.5 if nvm == 4 else 1 / 3)
    m_normal = facet_normals(mX, mS, mhalf, mhalf)
    known, points = vertex_closest
    closest = points[np.searchsorted(known, B)]  # (nF, nv, 3)
    anchors = closest.mean(axis=1)
    ei, mi = _candidates(centre, s_radius, anchors, nc, m_centre, m_radius, m_normal)

    parts: dict[str, list] = {k: [] for k in ("e", "D", "cov", "g", "M", "m", "e_all", "area", "tilt")}
    for start in range(0, ei.size, BATCH):
        e, f = ei[start:start + BATCH], mi[start:start + BATCH]
        c, n1, n2 = centre[e], e1[e], e2[e]
        m2 = np.stack([_dot(mX[f] - c[:, None], n1[:, None]), _dot(mX[f] - c[:, None], n2[:, None])], axis=-1)
        m_poly, m_area = counter_clockwise(m2[:, _CYCLE[nvm]])
        true_area = 0.5 * _norm(np.cross(mX[f, 1] - mX[f, 0], mX[f, -1] - mX[f, 0] if nvm == 4 else
                                         mX[f, 2] - mX[f, 0])) * (2 if nvm == 4 else 1)
        lo, hi = m_poly.min(axis=1), m_poly.max(axis=1)
        slo, shi = s_poly[e].min(axis=1), s_poly[e].max(axis=1)
        tol = CLIP_TOL * s_radius[e]
        keep = (m_area > 1e-10 * true_area) & (lo <= shi + tol[:, None]).all(axis=1) & \
            (hi >= slo - tol[:, None]).all(axis=1)
        if nvm == 4:
            bad = np.flatnonzero(keep & ~convex(m_poly))
            if bad.size:
                j = bad[0]
                raise InputError(f"master facet at {_where(m_centre[f[j]])}: its projection onto the auxiliary "
                                 f"plane of the slave facet at {_where(c[j])} is not a convex quadrilateral: the "
                                 "mortar segmentation needs facets that face each other (refine, or use method = "
                                 "'node-to-surface')")
        e, f, m2, m_poly, c, tol = e[keep], f[keep], m2[keep], m_poly[keep], c[keep], tol[keep]
        if e.size == 0:
            continue
        P, count = clip(m_poly, np.full(e.size, nvm), s_poly[e], tol)
        parts["e_all"].append(e)
        parts["area"].append(np.where(count > 0, polygon_area(P, count), 0.0))
        # each clip polygon without its duplicate and collinear vertices, the fan from its vertex mean, the
        # 7-point rule on each triangle
        P, count = clean_polygon(P, count, CLEAN_TOL * s_radius[e])
        # an empty clip polygon contributes exact zeros to every sum below: not integrated
        live = count > 0
        e, f, m2, P, count = e[live], f[live], m2[live], P[live], count[live]
        if e.size == 0:
            continue
        width = P.shape[1]
        valid = np.arange(width)[None, :] < count[:, None]
        mean = np.sum(P * valid[..., None], axis=1) / np.maximum(count, 1)[:, None]
        nxt = (np.arange(width)[None, :] + 1) % np.maximum(count, 1)[:, None]
        Q = np.take_along_axis(P, nxt[..., None], axis=1)
        area = 0.5 * cross2(P - mean[:, None], Q - mean[:, None]) * valid  # (k, width)
        pts = (GAUSS7[None, None, :, 0, None] * mean[:, None, None] + GAUSS7[None, None, :, 1, None] * P[:, :, None]
               + GAUSS7[None, None, :, 2, None] * Q[:, :, None]).reshape(e.size, -1, 2)
        wts = (area[:, :, None] * GAUSS7_W[None, None]).reshape(e.size, -1)
        xs, es = _inverse_2d(s2[e], pts)
        xm, em = _inverse_2d(m2, pts)
        Ns = shape_functions(nv, xs, es)
        Nm = shape_functions(nvm, xm, em)
        x_s = facet_map(X[e][:, None], xs, es)[0]
        x_m = facet_map(mX[f][:, None], xm, em)[0]
        if nv == 3:  # a triangle's normal is the same at every point (the same bits as evaluated point by point)
            ne = facet_normals(X[e], sign[e], xs[:, 0], es[:, 0])[:, None]
        else:
            ne = facet_normals(X[e][:, None], sign[e][:, None] * np.ones(xs.shape[1]), xs, es)
        W = wts / np.abs(_dot(ne, nc[e][:, None]))
        vert = np.searchsorted(vertices, B[e])
        nbar = Ns @ frame_normals[vert]  # (k, q, 3)
        g = _dot(x_s - x_m, nbar)
        parts["tilt"].append(_tan_angle(-m_normal[f], nc[e]))  # the master facet's tilt against n_c
        psi = Ns @ np.transpose(A[e], (0, 2, 1))  # ψ_j = Σ_l A_jl N_l
        Wpsi = W[..., None] * psi
        parts["e"].append(e)
        parts["m"].append(f)
        parts["D"].append(np.sum(Wpsi * Ns, axis=1))
        parts["cov"].append(np.sum(W[..., None] * Ns, axis=1))
        parts["g"].append(np.sum(Wpsi * g[..., None], axis=1))
        parts["M"].append(np.transpose(Wpsi, (0, 2, 1)) @ Nm)

    # sums per node, in the global order of the (slave facet, master facet) pairs
    order = np.argsort(nodes)
    sorted_nodes = nodes[order]

    def node_index(blocks: npt.NDArray[np.int64]) -> npt.NDArray[np.intp]:
        pos = np.clip(np.searchsorted(sorted_nodes, blocks), 0, m - 1)
        return np.where(sorted_nodes[pos] == blocks, order[pos], -1)

    idx = node_index(B)
    ok = idx >= 0
    full: Array = np.bincount(idx[ok], weights=De[ok], minlength=m).astype(np.float64, copy=False)
    normal = frame_normals[np.searchsorted(vertices, nodes)]
    # geometric coverage: each slave facet's clip areas (in the global pair order) over its projected area; a
    # node's coverage is the smallest of its facets'
    covered_area = np.zeros(nF)
    if parts["e_all"]:
        np.add.at(covered_area, np.concatenate(parts["e_all"]), np.concatenate(parts["area"]))
    fraction = covered_area / np.maximum(s_area, np.finfo(float).tiny)
    # credited with the projection's slack strip along the facet's perimeter (an aligned border: see "Coverage at
    # aligned borders"); 0 for parallel flat facets
    master_tilt = np.zeros(nF)
    if parts["tilt"]:
        np.maximum.at(master_tilt, np.concatenate(parts["e"]), np.concatenate(parts["tilt"]))
    separation = np.abs(_dot(X - closest, nc[:, None])).max(axis=1)
    strip = np.minimum(np.maximum(separation * np.minimum(master_tilt + tilt, 1.0), 2.0 * resolution),
                       ALIGNED_TOL * s_radius)
    strip = np.maximum(strip, reach)  # a geometry cycle tied: coverage decided to its width
    slack = strip * polygon_perimeter(s_poly)
    fraction = np.where(fraction < 1.0, np.minimum(fraction + slack / np.maximum(s_area, np.finfo(float).tiny), 1.0),
                        fraction)
    coverage = np.full(m, np.inf)
    np.minimum.at(coverage, idx[ok], np.broadcast_to(fraction[:, None], idx.shape)[ok])
    coverage[~np.isfinite(coverage)] = 0.0
    if not parts["e"]:
        return MortarNodes(normal, np.zeros(m), full, np.zeros(m), np.zeros(m), np.full((m, 1), -1, np.int64),
                           np.zeros((m, 1)), np.zeros((m, 1)), coverage)
    e = np.concatenate(parts["e"])
    f = np.concatenate(parts["m"])
    idx = node_index(B[e])  # (k, nv)
    ok = idx >= 0
    D: Array = np.bincount(idx[ok], weights=np.concatenate(parts["D"])[ok], minlength=m).astype(np.float64, copy=False)
    covered: Array = np.bincount(idx[ok], weights=np.concatenate(parts["cov"])[ok],
                                 minlength=m).astype(np.float64, copy=False)
    gt: Array = np.bincount(idx[ok], weights=np.concatenate(parts["g"])[ok], minlength=m).astype(np.float64, copy=False)
    Mv = np.concatenate(parts["M"])  # (k, nv, nvm)
    rows = np.broadcast_to(idx[:, :, None], Mv.shape)
    cols = np.broadcast_to(mB[f][:, None, :], Mv.shape)
    sel = rows >= 0
    rows, cols, vals = rows[sel], cols[sel], Mv[sel]
    span = int(cols.max(initial=0)) + 1
    key, inverse = np.unique(rows.astype(np.int64) * span + cols, return_inverse=True)
    sums = np.bincount(inverse.ravel(), weights=vals, minlength=key.size)
    r, l = key // span, key % span
    phi = sums / np.where(D[r] > 0, D[r], 1.0)
    keep = np.abs(phi) > DROP_TOL
    r, l, phi, sums = r[keep], l[keep], phi[keep], sums[keep]
    width = max(int(np.bincount(r, minlength=m).max(initial=0)), 1)
    first = np.searchsorted(r, np.arange(m))
    slot = np.arange(r.size) - first[r]
    blocks = np.full((m, width), -1, np.int64)
    stencil, Mjl = np.zeros((m, width)), np.zeros((m, width))
    blocks[r, slot], stencil[r, slot], Mjl[r, slot] = l, phi, sums
    return MortarNodes(normal, D, full, covered, gt, blocks, stencil, Mjl, coverage)
