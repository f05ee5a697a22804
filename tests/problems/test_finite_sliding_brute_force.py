r"""Finite sliding against an independent brute-force re-pairing + Alart–Curnier solver (serial).

Two tetrahedral blocks with non-matching meshes: the lower block [0, 2]×[0, 1]×[−0.5, 0] clamped at its bottom,
the smaller upper block above it with its top prescribed to (0, 0, −press) (step 1), then to (sx, 0, −press)
(step 2: sx is about two master facet sizes, so every slave node changes its master facet), node-to-surface,
F = 0 and 0.3. The reference uses nothing of fenics_coulomb's pairing, mortar, sliding or solver code: K is
the form assembled here without boundary conditions, and a fixed-point iteration on the geometry computes, at
the configuration X + u⁽ᵐ⁾, every slave node's closest point on ALL master triangles (brute force, its own
closest-point-on-triangle routine), its barycentric stencil Φ, the facet's unit normal n (out of the master
body) and the gap g = (x_s − x_m)·n, and solves (tests/brute_force.py) the contact problem with

    gap    g_j(X + u⁽ᵐ⁾) + n_j·(w_j − w_j⁽ᵐ⁾),       w = G u,  (G u)_j = u_s − Σ_l Φ_jl u_l,
    slip   T_j (w_j − (G u^{k−1})_j)                  (the step's own stencil, T the tangent rows of a frame of n),

until the stencils repeat and u changes by less than 1e-12 (relative). The library's finite sliding path equals
it (u, contact forces, contact nodes and stencils to 1e-8), with at least one geometry update on the slide, and
differs from small sliding by far more than that.
"""

from __future__ import annotations


from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt
import pytest
import scipy.sparse as sp
import ufl

from fenics_coulomb import ContactPair, ContactProblem

from meshes.two_blocks import BODIES, TAGS, two_blocks  # noqa: E402

Array = npt.NDArray[np.float64]

TIGHT = {"rtol": 1e-12, "tol": 1e-14}
MATERIALS = {"lower": (70.0, 0.3), "upper": (200.0, 0.25)}
N_LOWER, N_UPPER = (6, 4, 2), (5, 4, 2)
#: Chosen so that every slave node projects into a master facet's interior, far from its edges, both pressed
#: and slid (asserted below): no tie or edge rule decides the answer.
ORIGIN, SIZE, GAP, PRESS, SLIDE = (0.27, 0.16), (0.85, 0.5, 0.3), 0.002, 0.01, 0.66
PATH = [(0.0, 0.0, -PRESS), (SLIDE, 0.0, -PRESS)]
#: A stencil weight below this (on a facet of size ~1/3) counts as "on an edge" in the final check.
MARGIN = 0.05


def _problem(friction: float, sliding: str):
    """The blocks, the problem (node-to-surface pair), the top's Constant, the form and the BCs."""
    blocks = two_blocks(MPI.COMM_SELF, lower=(2.0, 1.0, 0.5), n_lower=N_LOWER, upper_origin=ORIGIN, upper=SIZE,
                        n_upper=N_UPPER, gap=GAP, cell_type="tetrahedron")
    msh, ft = blocks.mesh, blocks.facet_tags
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    dx = ufl.Measure("dx", domain=msh, subdomain_data=blocks.cell_tags)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    a = 0
    for body, (E, nu) in MATERIALS.items():
        mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
        a = a + ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * dx(BODIES[body])
    top = dolfinx.fem.Constant(msh, np.zeros(3))
    bcs = [dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(
               V, 2, ft.find(TAGS["lower_bottom"])), V),
           dolfinx.fem.dirichletbc(top, dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["upper_top"])), V)]
    pair = ContactPair(ft, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], friction=friction,
                       method="node-to-surface")
    problem = ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, sliding=sliding,
                             petsc_options_prefix=f"fsbf_{sliding}_")
    return problem, top, a, bcs, ft


def _prescribed(V, bcs) -> tuple[npt.NDArray[np.int64], Array]:
    """The prescribed DOFs (unrolled) and their current values."""
    g = dolfinx.fem.Function(V)
    g.x.array[:] = np.nan
    for bc in bcs:
        bc.set(g.x.array)
    D = np.flatnonzero(~np.isnan(g.x.array))
    return D, g.x.array[D].copy()


# -- the brute-force geometry -------------------------------------------------------------------------------
def closest_on_triangles(x: Array, tri: Array) -> tuple[Array, Array, Array]:
    """The closest point of every triangle to every point (brute force).

    Args:
        x: Points, shape (m, 3).
        tri: Triangle vertices, shape (t, 3, 3).

    Returns:
        The closest points (m, t, 3), their barycentric coordinates (m, t, 3) and the distances (m, t).
    """
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = b - a, c - a
    # the projection onto the plane: solve the 2 × 2 Gram system for (λ1, λ2)
    g11, g12, g22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    det = g11 * g22 - g12 ** 2
    r = x[:, None, :] - a[None]
    r1, r2 = (r * e1[None]).sum(2), (r * e2[None]).sum(2)
    l1 = (g22 * r1 - g12 * r2) / det
    l2 = (g11 * r2 - g12 * r1) / det
    bary = np.stack([1.0 - l1 - l2, l1, l2], axis=2)
    best = np.einsum("mtk,tkd->mtd", bary, tri)
    dist = np.linalg.norm(x[:, None, :] - best, axis=2)
    inside = np.all(bary >= 0.0, axis=2)
    dist = np.where(inside, dist, np.inf)
    # else the closest point of each edge (segment clamp), keeping the nearest
    for i, j in ((0, 1), (1, 2), (2, 0)):
        p, q = tri[:, i], tri[:, j]
        e = q - p
        t = np.clip(((x[:, None, :] - p[None]) * e[None]).sum(2) / (e * e).sum(1)[None], 0.0, 1.0)
        y = p[None] + t[..., None] * e[None]
        d = np.linalg.norm(x[:, None, :] - y, axis=2)
        better = d < dist
        w = np.zeros(bary.shape)
        w[..., i], w[..., j] = 1.0 - t, t
        best = np.where(better[..., None], y, best)
        bary = np.where(better[..., None], w, bary)
        dist = np.where(better, d, dist)
    return best, bary, dist


def frames_of(n: Array) -> Array:
    """An orthonormal frame (t₁, t₂, n) as columns for each unit normal (any: friction is isotropic)."""
    helper = np.where(np.abs(n[:, [0]]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    t1 = np.cross(helper, n)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    t2 = np.cross(n, t1)
    return np.stack([t1, t2, n], axis=2)


def brute_force_geometry(X: Array, u: Array, slave: npt.NDArray[np.int64], triangles: npt.NDArray[np.int64]):
    """Pair every slave node with its closest point on the master triangles in X + u.

    Returns:
        stencil (m, 3) master blocks, φ (m, 3), n (m, 3), g (m,), the smallest interior barycentric
        coordinate of each closest point (m,; 0 on an edge or vertex).
    """
    x = X + u.reshape(-1, 3)
    tri = x[triangles]
    best, bary, dist = closest_on_triangles(x[slave], tri)
    k = np.argmin(dist, axis=1)  # ties: a point on a shared edge or vertex (asserted away at the end)
    rows = np.arange(slave.size)
    xm, phi = best[rows, k], bary[rows, k]
    normal = np.cross(tri[k, 1] - tri[k, 0], tri[k, 2] - tri[k, 0])
    normal *= np.sign(normal[:, 2])[:, None] / np.linalg.norm(normal, axis=1)[:, None]  # out of the lower block
    d = x[slave] - xm
    inner = phi.min(axis=1)
    edge = inner <= 1e-10
    n = normal.copy()
    n[edge] = d[edge] / np.linalg.norm(d[edge], axis=1)[:, None]  # the edge/vertex rule n = d/|d|
    g = np.einsum("ij,ij->i", d, n)
    return triangles[k], phi, n, g, inner


def coupling(slave: npt.NDArray[np.int64], stencil: npt.NDArray[np.int64], phi: Array, size: int) -> sp.csr_matrix:
    """G with (G u)_j = u_s − Σ_l φ_jl u_l (3 rows per slave node)."""
    m = slave.size
    rows = np.broadcast_to((3 * np.arange(m)[:, None] + np.arange(3))[:, :, None], (m, 3, 4))
    cols = np.concatenate([slave[:, None], stencil], axis=1)  # (m, 4)
    cols = 3 * cols[:, None, :] + np.arange(3)[None, :, None]  # (m, 3, 4)
    vals = np.broadcast_to(np.concatenate([np.ones((m, 1)), -phi], axis=1)[:, None, :], (m, 3, 4))
    return sp.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * m, size))


def reference_step(K, D, values, X, slave, triangles, friction, previous):
    """One step of the path by the fixed-point iteration on the geometry, from the previous step's u."""
    from brute_force import solve_contact

    n_dofs = K.shape[0]
    u_m = previous.copy()
    old = u_old = force = None
    for iteration in range(30):
        stencil, phi, n, g, inner = brute_force_geometry(X, u_m, slave, triangles)
        support = np.sort(stencil, axis=1)
        if old is not None and np.array_equal(support, old) and \
                np.linalg.norm(u_m - u_old) <= 1e-12 * np.linalg.norm(u_m):
            return u_m, dict(stencil=stencil, phi=phi, n=n, g=g, inner=inner, force=force, iterations=iteration)
        G = coupling(slave, stencil, phi, n_dofs)
        R = frames_of(n)
        w_m = (G @ u_m).reshape(-1, 3)
        gaps = g - np.einsum("ij,ij->i", n, w_m)  # g(X + u⁽ᵐ⁾) + n·(G u − G u⁽ᵐ⁾)
        shifts = -np.einsum("ija,ij->ia", R[:, :, :2], (G @ previous).reshape(-1, 3))  # s = T G (u − u^{k−1})
        sol = solve_contact(K, np.zeros(n_dofs), 3 * slave[:, None] + np.arange(3), gaps, friction, frames=R,
                            shifts=shifts, dirichlet=(D, values), coupling=G, tol=1e-14)
        force = np.einsum("iab,ib->ia", R, sol.force)  # Cartesian, on the slave
        old, u_old, u_m = support, u_m, sol.u
    raise AssertionError("the brute-force geometry iteration did not settle in 30 iterations")


@pytest.mark.serial
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_finite_sliding_equals_brute_force_re_pairing(friction):
    """Press, then slide ≈ 2 master facets: the library's finite sliding path equals the brute-force re-pairing
    + Alart–Curnier fixed point at every step (u, contact forces, contact nodes and stencils to 1e-8); the slide
    needs a geometry update; small sliding gives another answer."""
    problem, top, a, bcs, ft = _problem(friction, "finite")
    V = problem.V
    X = V.tabulate_dof_coordinates()
    size = 3 * X.shape[0]
    K = dolfinx.fem.assemble_matrix(dolfinx.fem.form(a)).to_scipy().tocsr()  # no boundary conditions
    slave = np.sort(dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["upper_bottom"]))).astype(np.int64)
    master_facets = ft.find(TAGS["lower_top"])
    triangles = np.sort(np.array([dolfinx.fem.locate_dofs_topological(V, 2, [f]) for f in master_facets]), axis=1)
    assert triangles.shape == (2 * N_LOWER[0] * N_LOWER[1], 3)
    facet = 2.0 / N_LOWER[0]  # the master facets' x-size
    assert SLIDE > 1.5 * facet
    with problem:
        u_prev = np.zeros(size)
        finals, pressed = [], None
        for k, value in enumerate(PATH):
            top.value[:] = value
            _, result = problem.solve()
            assert result.converged
            u_lib = problem.u.x.array.copy()
            D, values = _prescribed(V, bcs)
            assert not np.isin(3 * slave, D).any()  # no slave node has a Dirichlet component
            u_ref, ref = reference_step(K, D, values, X, slave, triangles, friction, u_prev)
            label = f"F = {friction}, step {k + 1}"
            # every slave node over a facet's interior (no tie or edge rule involved), far within the search
            # distance (0.1 × the master's bounding-box diagonal): every slave node is a contact node
            assert ref["inner"].min() > MARGIN, (label, ref["inner"].min())
            assert np.abs(ref["g"]).max() < 0.1 * np.hypot(2.0, 1.0)
            model = problem.model
            pairing = model.pairing
            assert np.array_equal(np.sort(pairing.blocks), slave), label
            order = np.argsort(pairing.blocks)
            lib_support = np.sort(np.where(pairing.weights != 0.0, pairing.master_blocks, -1), axis=1)[order]
            assert np.array_equal(lib_support[:, -3:], np.sort(ref["stencil"], axis=1)), label
            assert np.all(lib_support[:, :-3] == -1)
            # u, contact forces and the contact (closed) nodes
            error = np.linalg.norm(u_lib - u_ref) / np.linalg.norm(u_ref)
            assert error <= 1e-8, (label, error)
            f_lib = result.contact_force[order]
            scale = np.abs(ref["force"]).max()
            assert np.abs(f_lib - ref["force"]).max() <= 1e-8 * scale, (label, np.abs(f_lib - ref["force"]).max())
            pressure = np.einsum("ij,ij->i", ref["force"], ref["n"])
            assert np.array_equal(np.einsum("ij,ij->i", f_lib, ref["n"]) > 1e-6 * scale, pressure > 1e-6 * scale)
            assert (pressure > 1e-6 * scale).sum() >= slave.size // 2, label
            if k == 1:
                assert result.geometry_updates >= 1, label
                slid = np.linalg.norm(u_ref.reshape(-1, 3)[slave] - u_prev.reshape(-1, 3)[slave], axis=1)
                assert slid.min() > 1.5 * facet, label
                assert not np.any(np.all(np.sort(ref["stencil"], axis=1) == pressed, axis=1)), label  # new facets
                if friction > 0:  # sliding: the tangential force is F × the normal force
                    tangential = ref["force"] - pressure[:, None] * ref["n"]
                    assert np.isclose(np.linalg.norm(tangential.sum(axis=0)), friction * pressure.sum(), rtol=1e-3)
            finals.append(u_lib)
            pressed = np.sort(ref["stencil"], axis=1)
            u_prev = u_ref
    small, top_small, *_ = _problem(friction, "small")
    with small:
        for value in PATH:
            top_small.value[:] = value
            _, result = small.solve()
            assert result.converged
        u_small = small.u.x.array.copy()
    difference = np.linalg.norm(u_small - finals[-1]) / np.linalg.norm(finals[-1])
    assert difference > 1e-4, difference
