"""An independent brute-force integrator of the dual mortar matrices D, M and the weighted gap g̃ (issue 28).

Nothing of fenics_coulomb.model.pairs.segmentation is used: no auxiliary-plane clipping, no inverse projections. Each
slave facet is split into n × n (triangle: n² sub-triangles; quadrilateral: n² sub-squares, each two triangles) pieces
of its REFERENCE element; each piece's 3 degree-2 Gauss points are mapped to the facet (x_s(ξ), the surface
element |x_ξ × x_η| dξ) and cast as rays along the facet's auxiliary-plane normal n_c (the outward unit normal
at its centre) onto the master facets: the ray meets master facet f where x_s + t n_c = x_f(ζ) with ζ inside
f (triangles: a 3 × 3 linear solve; bilinear quadrilaterals: Newton's method on the 3 equations in (t, ζ)).
Only master facets facing the slave facet count (n_f · n_c < 0); a point whose ray meets no master facet is
uncovered. The dual basis comes from closed forms checked here: triangles A = 4I − 1 (ψ_j = 3N_j − N_k − N_l),
parallelograms the tensor product of the 1D dual basis (2N₁ − N₂, 2N₂ − N₁); other quadrilaterals from
D M⁻¹ with D and M integrated on the same sub-pieces.
"""

from __future__ import annotations

import numpy as np

# degree-2 rule on the reference triangle (area 1/2): the edge midpoints, weights 1/6
_TRI2 = np.array([[0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])
_TRI2_W = np.full(3, 1 / 6)


def shape(nv, xi, eta):
    if nv == 3:
        return np.stack([1 - xi - eta, xi, eta], axis=-1)
    return np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta], axis=-1)


def point(X, xi, eta):
    """x(ξ, η) and x_ξ × x_η of one facet X (nv, 3) at arrays of reference points."""
    N = shape(X.shape[0], xi, eta)
    if X.shape[0] == 3:
        d1 = np.broadcast_to(X[1] - X[0], N.shape[:-1] + (3,))
        d2 = np.broadcast_to(X[2] - X[0], N.shape[:-1] + (3,))
    else:
        d1 = np.outer(1 - eta, X[1] - X[0]) + np.outer(eta, X[3] - X[2])
        d2 = np.outer(1 - xi, X[2] - X[0]) + np.outer(xi, X[3] - X[1])
    return N @ X, np.cross(d1, d2)


def sub_points(nv, n):
    """Reference points and weights of the n × n sub-pieces of the reference facet (triangle or unit square)."""
    pts, wts = [], []
    h = 1.0 / n
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    i, j = i.ravel(), j.ravel()
    # lower triangles of each sub-square: (i, j), (i+1, j), (i, j+1); upper: (i+1, j+1), (i, j+1), (i+1, j);
    # in the reference triangle the lower ones with i + j <= n − 1, the upper ones with i + j <= n − 2
    for corner, e1, e2, last in (((0, 0), (1, 0), (0, 1), n - 1), ((1, 1), (-1, 0), (0, -1), n - 2)):
        ok = np.ones(i.size, bool) if nv == 4 else (i + j <= last)
        for (a, b), w in zip(_TRI2, _TRI2_W, strict=True):
            x = (i[ok] + corner[0] + a * e1[0] + b * e2[0]) * h
            y = (j[ok] + corner[1] + a * e1[1] + b * e2[1]) * h
            pts.append(np.stack([x, y], axis=1))
            wts.append(np.full(x.size, w * h * h))
    return np.concatenate(pts), np.concatenate(wts)


def dual_matrix(X, n=64):
    """A of the dual basis of facet X: closed forms for triangles and parallelograms, else D M⁻¹ on sub-pieces."""
    nv = X.shape[0]
    if nv == 3:
        return 4 * np.eye(3) - np.ones((3, 3))
    if np.allclose(X[0] + X[3], X[1] + X[2], rtol=0, atol=1e-14 * np.abs(X).max()):
        a = np.array([[2.0, -1.0], [-1.0, 2.0]])
        # vertex k = (x-index k % 2, y-index k // 2): N_k = L_{k%2}(ξ) L_{k//2}(η)
        return np.array([[a[k % 2, l % 2] * a[k // 2, l // 2] for l in range(4)] for k in range(4)])
    P, W = sub_points(4, n)
    N = shape(4, P[:, 0], P[:, 1])
    _, J = point(X, P[:, 0], P[:, 1])
    w = W * np.linalg.norm(J, axis=1)
    M = (N * w[:, None]).T @ N
    return np.diag(M.sum(axis=1)) @ np.linalg.inv(M)


def _ray_facets(x, direction, masters):
    """For points x (q, 3) and one direction: the master facet hit (−1: none), its point and weights.

    Only the points whose projection along ``direction`` falls in the bounding box of the facet's projected
    vertices (widened by 1e-6 of its size) are cast at a facet: a facet (a triangle, or a bilinear quadrilateral:
    convex combinations of its vertices) lies in the convex hull of its vertices, so a ray outside that box
    cannot meet it, and each ray's own linear solve or Newton iteration is the same as when cast at every facet.
    """
    q = x.shape[0]
    hit = np.full(q, -1)
    xm = np.zeros((q, 3))
    wm = np.zeros((q, 4))
    best = np.full(q, np.inf)
    e1 = np.cross(direction, [1.0, 0.0, 0.0] if abs(direction[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    plane = np.column_stack([e1, np.cross(direction, e1)])
    xp = x @ plane
    order = np.argsort(xp[:, 0], kind="stable")
    first = xp[order, 0]
    for f, Y in enumerate(masters):
        nv = Y.shape[0]
        Yp = Y @ plane
        margin = 1e-6 * np.ptp(Yp, axis=0).max()
        lo, hi = Yp.min(axis=0) - margin, Yp.max(axis=0) + margin
        near = order[np.searchsorted(first, lo[0], "left"):np.searchsorted(first, hi[0], "right")]
        near = np.sort(near[(xp[near, 1] >= lo[1]) & (xp[near, 1] <= hi[1])])
        if near.size == 0:
            continue
        xn = x[near]
        qn = near.size
        if nv == 3:
            # x + t d = Y0 + a (Y1 − Y0) + b (Y2 − Y0)
            Mtx = np.column_stack([-direction, Y[1] - Y[0], Y[2] - Y[0]])
            sol = np.linalg.solve(Mtx, (xn - Y[0]).T).T
            t, a, b = sol.T
            inside = (a >= -1e-12) & (b >= -1e-12) & (a + b <= 1 + 1e-12)
            w = shape(3, a, b)
        else:
            t, a, b = np.zeros(qn), np.full(qn, 0.5), np.full(qn, 0.5)
            for _ in range(30):
                y, _ = point(Y, a, b)
                r = xn + t[:, None] * direction - y
                d1 = np.outer(1 - b, Y[1] - Y[0]) + np.outer(b, Y[3] - Y[2])
                d2 = np.outer(1 - a, Y[2] - Y[0]) + np.outer(a, Y[3] - Y[1])
                # Cramer's rule for [d, −x_ξ, −x_η] step = −r
                c0, c1, c2 = np.broadcast_to(direction, d1.shape), -d1, -d2
                det = np.einsum("qi,qi->q", c0, np.cross(c1, c2))
                rhs = -r
                step = np.stack([np.einsum("qi,qi->q", rhs, np.cross(c1, c2)),
                                 np.einsum("qi,qi->q", c0, np.cross(rhs, c2)),
                                 np.einsum("qi,qi->q", c0, np.cross(c1, rhs))], axis=1) / det[:, None]
                t, a, b = t + step[:, 0], a + step[:, 1], b + step[:, 2]
                if np.abs(step[:, 1:]).max() < 1e-15:
                    break
            inside = (a >= -1e-12) & (a <= 1 + 1e-12) & (b >= -1e-12) & (b <= 1 + 1e-12)
            w = shape(4, a, b)
        take = inside & (np.abs(t) < best[near])
        idx = near[take]
        hit[idx], best[idx] = f, np.abs(t[take])
        xm[idx] = w[take] @ Y
        wm[idx, :nv] = w[take]
    return hit, xm, wm


def brute_force(slave, slave_blocks, slave_sign, master, master_blocks, master_sign, nodes, n=128):
    """D_j, full ∫ N_j, covered ∫ N_j, g̃_j and M_jl (a dict per node) of the slave nodes ``nodes`` (global
    blocks), from the facets (coordinates (F, nv, 3), global blocks (F, nv), outward signs (F,)) of both
    surfaces."""
    nv = slave.shape[1]
    ref = {3: np.array([[0, 0], [1, 0], [0, 1]]), 4: np.array([[0, 0], [1, 0], [0, 1], [1, 1]])}[nv]
    # nodal frame normals: −(the normalized sum of the facets' outward normals at the vertex)
    total = {}
    for X, B, s in zip(slave, slave_blocks, slave_sign, strict=True):
        for k in range(nv):
            _, c = point(X, np.array([ref[k, 0]], float), np.array([ref[k, 1]], float))
            total[int(B[k])] = total.get(int(B[k]), 0.0) + s * c[0] / np.linalg.norm(c[0])
    normal = {b: -v / np.linalg.norm(v) for b, v in total.items()}
    mcentre = master.mean(axis=1)
    out = {int(j): {"D": 0.0, "full": 0.0, "covered": 0.0, "g": 0.0, "M": {}} for j in nodes}
    P, W = sub_points(nv, n)
    for X, B, s in zip(slave, slave_blocks, slave_sign, strict=True):
        if not any(int(b) in out for b in B):
            continue
        half = 0.5 if nv == 4 else 1 / 3
        _, c = point(X, np.array([half]), np.array([half]))
        nc = s * c[0] / np.linalg.norm(c[0])
        A = dual_matrix(X)
        x, J = point(X, P[:, 0], P[:, 1])
        w = W * np.linalg.norm(J, axis=1)
        N = shape(nv, P[:, 0], P[:, 1])
        psi = N @ A.T
        nbar = N @ np.array([normal[int(b)] for b in B])
        # candidate master facets: facing, and near (the test meshes' gaps are below 0.5)
        radius = np.linalg.norm(X - X.mean(axis=0), axis=1).max()
        cand = []
        for f, (Y, sg) in enumerate(zip(master, master_sign, strict=True)):
            centre = np.array([0.5 if Y.shape[0] == 4 else 1 / 3])
            _, cm = point(Y, centre, centre.copy())
            mradius = np.linalg.norm(Y - mcentre[f], axis=1).max()
            if sg * cm[0] @ nc < 0 and np.linalg.norm(mcentre[f] - X.mean(axis=0)) < 2 * (radius + mradius) + 0.5:
                cand.append(f)
        hit, xm, wm = _ray_facets(x, nc, [master[f] for f in cand])
        covered = hit >= 0
        g = np.einsum("qi,qi->q", x - xm, nbar)
        for k, b in enumerate(B):
            b = int(b)
            if b not in out:
                continue
            o = out[b]
            o["full"] += float(np.sum(w * N[:, k]))
            o["covered"] += float(np.sum((w * N[:, k])[covered]))
            o["D"] += float(np.sum((w * psi[:, k] * N[:, k])[covered]))
            o["g"] += float(np.sum((w * psi[:, k] * g)[covered]))
            for ci, f in enumerate(cand):
                on = hit == ci
                if not on.any():
                    continue
                for l, mb in enumerate(master_blocks[f]):
                    v = float(np.sum((w * psi[:, k] * wm[:, l])[on]))
                    o["M"][int(mb)] = o["M"].get(int(mb), 0.0) + v
    for b, o in out.items():
        o["normal"] = normal[b]
    return out
