"""The two-body pairing (fenics_coulomb.model.pairs.pairing, issue 18) against oracles per formula, 1 and 2 ranks.

Oracles: analytic closest points and normals of flat and hyperbolic-paraboloid (z = c·x·y, exactly the
bilinear Q1 facets) master surfaces, scipy.optimize / dense sampling of the master facets, the tie rule
from the facets that geometrically contain x_m, and the convex-corner normal cone by hand.
"""

from __future__ import annotations

import logging

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.spatial import cKDTree

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs import ContactPair as _ContactPair
from fenics_coulomb.model.pairs import pair_surfaces

from meshes.two_blocks import TAGS, boxes_mesh, two_blocks

CELLS = ["hexahedron", "tetrahedron"]
NONE = np.zeros(0, dtype=np.int32)


def ContactPair(*args, method: str = "node-to-surface", **kwargs) -> _ContactPair:  # noqa: N802
    """The pairs of this module use the node-to-surface definitions (mortar: tests/model/test_mortar.py)."""
    return _ContactPair(*args, method=method, **kwargs)


def space(msh: dolfinx.mesh.Mesh, degree: int = 1) -> dolfinx.fem.FunctionSpace:
    return dolfinx.fem.functionspace(msh, ("Lagrange", degree, (3,)))


def global_coordinates(V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """Coordinates of every global DOF block, on every rank."""
    comm = V.mesh.comm
    imap = V.dofmap.index_map
    n = imap.size_local
    x = np.concatenate(comm.allgather(V.tabulate_dof_coordinates()[:n]))
    g = np.concatenate(comm.allgather(imap.local_range[0] + np.arange(n)))
    out = np.empty((imap.size_global, 3))
    out[g] = x
    return out


def gathered(V: dolfinx.fem.FunctionSpace, P) -> dict[str, np.ndarray]:
    """The pairing of all ranks, master stencils as vertex coordinates, sorted by the slave coordinates."""
    comm = V.mesh.comm
    X = global_coordinates(V)
    mx = np.where(P.master_blocks[:, :, None] >= 0, X[np.maximum(P.master_blocks, 0)], 0.0)
    data = dict(x=P.coordinates, xm=P.closest, g=P.gap, n=P.normals, w=P.weights, mx=mx, pair=P.pair_index,
                F=P.friction, mb=P.master_blocks)
    data = {k: np.concatenate(comm.allgather(v)) for k, v in data.items()}
    key = np.round(data["x"], 9)
    order = np.lexsort((key[:, 2], key[:, 1], key[:, 0]))
    return {k: v[order] for k, v in data.items()}


def master_facets(msh: dolfinx.mesh.Mesh, facet_tags, tag: int) -> np.ndarray:
    """Vertex coordinates (k, nv, 3) of the facets with ``tag`` on all ranks, from the mesh geometry."""
    facets = facet_tags.find(tag)
    msh.topology.create_connectivity(2, 3)
    nv = 4 if msh.topology.cell_name() == "hexahedron" else 3
    # (entities_to_geometry raises SIGFPE on an empty list in DOLFINx 0.9)
    nodes = dolfinx.mesh.entities_to_geometry(msh, 2, facets) if facets.size else np.zeros((0, nv), np.int32)
    return np.concatenate(msh.comm.allgather(msh.geometry.x[nodes].reshape(-1, nv, 3)))


def check_common(V, P, data) -> None:
    """Frames orthonormal and right-handed, weights a partition of unity reproducing x_m, g = (x_s − x_m)·n."""
    R = P.frames
    assert np.allclose(np.einsum("kji,kjl->kil", R, R), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0, atol=1e-12) if R.size else True
    assert np.allclose(data["w"].sum(axis=1), 1.0, atol=1e-12)
    assert (data["w"] >= -1e-12).all()
    assert np.allclose(np.einsum("kj,kji->ki", data["w"], data["mx"]), data["xm"], atol=1e-12)
    assert np.allclose(np.einsum("ki,ki->k", data["x"] - data["xm"], data["n"]), data["g"], atol=1e-13)
    assert np.all(np.diff(P.blocks) > 0) and (P.blocks < V.dofmap.index_map.size_local).all()


def check_tie_rule(b, V, data, cell: str, expect_shared: int) -> None:
    """Among the flat master facets (z = 0) containing x_m, φ is that of the one with the lexicographically
    smallest sorted global vertex indices (the vertices found by coordinates from the mesh geometry)."""
    facets = master_facets(b.mesh, b.facet_tags, TAGS["lower_top"])
    X = global_coordinates(V)
    lower = np.unique(lower_blocks(b, V))
    _, idx = cKDTree(X[lower]).query(facets.reshape(-1, 3))
    keys = np.sort(lower[idx].reshape(facets.shape[:2]), axis=1)
    keys = np.unique(keys, axis=0, return_index=True)
    facets = facets[keys[1]]
    keys = keys[0]
    xy = facets[:, :, :2]
    p = data["xm"][:, None, None, :2]
    if cell == "hexahedron":  # axis-aligned rectangles
        contains = ((p >= xy.min(axis=1)[None, :, None] - 1e-12) & (p <= xy.max(axis=1)[None, :, None] + 1e-12))
        contains = contains.all(axis=(2, 3))
    else:  # barycentric coordinates in the plane
        T = np.stack([xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]], axis=2)  # (k, 2, 2)
        lam = np.einsum("kab,mkb->mka", np.linalg.inv(T), data["xm"][:, None, :2] - xy[None, :, 0])
        contains = (lam >= -1e-12).all(axis=2) & (lam.sum(axis=2) <= 1 + 1e-12)
    assert contains.any(axis=1).all()
    shared = contains.sum(axis=1) > 1
    assert shared.sum() >= expect_shared, "the mesh should put some slave nodes on master edges or vertices"
    nv = keys.shape[1]
    got = np.sort(data["mb"], axis=1)[:, -nv:]  # the −1 padding of triangles sorts first
    for i in range(data["x"].shape[0]):  # a loop in the test oracle only
        candidates = keys[contains[i]]
        expected = candidates[np.lexsort(candidates.T[::-1])[0]]
        assert (got[i] == expected).all(), (data["x"][i], got[i], candidates)


@pytest.mark.parametrize("cell", CELLS)
def test_matching_touching(cell):
    """Matching meshes at gap 0: every slave node sits on a master vertex (a different DOF: Φ² holds),
    g = 0, n = the normalized sum of the facet normals there (e₃), φ = 1 at that vertex."""
    b = two_blocks(MPI.COMM_WORLD, cell_type=cell, gap=0.0, n_upper=(2, 2, 1))
    V = space(b.mesh)
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"])], NONE)
    data = gathered(V, P)
    assert P.num_global == 9
    check_common(V, P, data)
    assert np.allclose(data["g"], 0, atol=1e-15) and np.allclose(data["n"], [0, 0, 1], atol=1e-12)
    one = np.argmax(data["w"], axis=1)
    assert np.allclose(data["w"].max(axis=1), 1.0, atol=1e-12)
    assert np.allclose(data["mx"][np.arange(9), one], data["x"], atol=1e-14)
    check_tie_rule(b, V, data, cell, expect_shared=9)


def lower_blocks(b, V) -> np.ndarray:
    """Global DOF blocks of the lower body (cell tag 1), on every rank."""
    cells = b.cell_tags.find(1)
    local = np.unique(V.dofmap.list[cells]).astype(np.int32)
    local = local[local < V.dofmap.index_map.size_local]
    return np.concatenate(V.mesh.comm.allgather(V.dofmap.index_map.local_to_global(local)))


# -- flat non-matching boxes ------------------------------------------------------------------------------
@pytest.mark.parametrize("partitioner", [None, "bodies"])
@pytest.mark.parametrize("cell", CELLS)
def test_flat_non_matching(cell, partitioner):
    """Every slave node above a flat master: x_m = its projection, n = e₃, g = the gap; tie rule at edges."""
    gap = 0.02
    b = two_blocks(MPI.COMM_WORLD, cell_type=cell, gap=gap, upper_origin=(0.3, 0.2), upper=(0.5, 0.55, 0.25),
                   n_upper=(3, 4, 1), partitioner=partitioner)
    V = space(b.mesh)
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"],
                                      friction=0.3)], NONE)
    data = gathered(V, P)
    assert P.num_global == 4 * 5 == data["x"].shape[0]
    check_common(V, P, data)
    assert np.allclose(data["g"], gap, atol=1e-13)
    assert np.allclose(data["n"], [0, 0, 1], atol=1e-12)
    assert np.allclose(data["xm"], data["x"] * [1, 1, 0], atol=1e-13)
    assert (data["pair"] == 0).all() and (data["F"] == 0.3).all()

    check_tie_rule(b, V, data, cell, expect_shared=2)


# -- a curved bilinear master ----------------------------------------------------------------------------
C = 0.6  # lower top z = C·x·y: each Q1 top facet is exactly this hyperbolic paraboloid


def paraboloid_closest(x: np.ndarray) -> np.ndarray:
    """Closest point of z = C·x·y over [0, 1]² to x, by scipy.optimize from a dense-grid start."""
    s = np.linspace(0, 1, 201)
    gx, gy = np.meshgrid(s, s)
    pts = np.stack([gx.ravel(), gy.ravel(), C * gx.ravel() * gy.ravel()], axis=1)
    start = pts[np.argmin(np.linalg.norm(pts - x, axis=1)), :2]
    res = minimize(lambda q: np.sum((np.array([q[0], q[1], C * q[0] * q[1]]) - x) ** 2), start,
                   bounds=[(0, 1), (0, 1)], method="L-BFGS-B", options=dict(ftol=1e-16, gtol=1e-14))
    q = res.x
    return np.array([q[0], q[1], C * q[0] * q[1]])


def test_curved_quad_master():
    """x_m the true closest point of the bilinear surface, n its normal there (not the facet's average)."""
    gap = 0.05
    b = two_blocks(MPI.COMM_WORLD, cell_type="hexahedron", gap=gap + C, upper_origin=(0.2, 0.3),
                   upper=(0.7, 0.6, 0.2), n_upper=(4, 3, 1), n_lower=(3, 3, 1),
                   lower_top=lambda x, y: C * x * y)
    V = space(b.mesh)
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"],
                                      search_distance=1.0)], NONE)
    data = gathered(V, P)
    check_common(V, P, data)
    # the slave nodes whose closest point is inside [0, 1]² are paired; those closest to M's outer edge are free
    gx, gy = np.meshgrid(0.2 + 0.7 * np.arange(5) / 4, 0.3 + 0.6 * np.arange(4) / 3)
    slave = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, gap + C)], axis=1)
    inside = np.array([min(*q[:2], *(1 - q[:2])) > 1e-6 for q in map(paraboloid_closest, slave)])
    assert 0 < inside.sum() < inside.size
    assert np.allclose(np.sort(np.round(data["x"], 9), axis=0), np.sort(np.round(slave[inside], 9), axis=0))
    oracle = np.array([paraboloid_closest(x) for x in data["x"]])
    assert np.allclose(data["xm"], oracle, atol=2e-7)
    dist = np.linalg.norm(data["x"] - data["xm"], axis=1)
    assert (dist <= np.linalg.norm(data["x"] - oracle, axis=1) + 1e-12).all()  # never farther than scipy's
    xm = data["xm"]
    normal = np.stack([-C * xm[:, 1], -C * xm[:, 0], np.ones(len(xm))], axis=1)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    assert np.allclose(data["n"], normal, atol=1e-8)
    assert np.allclose(data["g"], dist, atol=1e-13)  # above the surface: g = |x_s − x_m| > 0
    # the facet's average normal (of its diagonals) differs from the normal at x_m
    d1, d2 = data["mx"][:, 3] - data["mx"][:, 0], data["mx"][:, 2] - data["mx"][:, 1]
    average = np.cross(d1, d2)
    average /= np.linalg.norm(average, axis=1)[:, None]
    assert np.max(np.linalg.norm(average - data["n"], axis=1)) > 1e-2


@pytest.mark.parametrize("cell", CELLS)
def test_brute_force_sampling(cell):
    """x_m is never farther than the nearest of dense samples of every master facet, and close to it."""
    b = two_blocks(MPI.COMM_WORLD, cell_type=cell, gap=0.03 + 0.3, upper_origin=(0.1, 0.15),
                   upper=(0.8, 0.7, 0.2), n_upper=(5, 4, 1), n_lower=(3, 2, 1),
                   lower_top=lambda x, y: 0.3 * np.sin(2 * x) * y)
    V = space(b.mesh)
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"],
                                      search_distance=1.0)], NONE)
    data = gathered(V, P)
    check_common(V, P, data)
    facets = master_facets(b.mesh, b.facet_tags, TAGS["lower_top"])
    s = np.linspace(0, 1, 81)
    u, v = np.meshgrid(s, s)
    u, v = u.ravel(), v.ravel()
    if cell == "hexahedron":  # geometry node order of the quadrilateral: tensor order
        W = np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], axis=1)
    else:
        keep = u + v <= 1
        W = np.stack([1 - u[keep] - v[keep], u[keep], v[keep]], axis=1)
    samples = np.einsum("sj,fjc->fsc", W, facets).reshape(-1, 3)
    near, _ = cKDTree(samples).query(data["x"])
    dist = np.linalg.norm(data["x"] - data["xm"], axis=1)
    spacing = np.max(np.linalg.norm(facets[:, 1] - facets[:, 0], axis=1)) / 80
    assert (dist <= near + 1e-12).all()
    assert (dist >= near - spacing).all()


def _box_minimum(f, starts: np.ndarray) -> float:
    """min of f over [0, 1]² by L-BFGS-B from the best of the grid points ``starts``."""
    start = starts[np.argmin([f(q) for q in starts])]
    res = minimize(f, start, bounds=[(0, 1), (0, 1)], method="L-BFGS-B", options=dict(ftol=1e-15, gtol=1e-12))
    return float(np.sqrt(min(res.fun, f(start))))


@pytest.mark.serial
@pytest.mark.parametrize("nv", [3, 4])
def test_closest_point_kernels(nv):
    """The facet kernels on random (non-planar) facets and points beside, above and below them: the distance
    equals scipy's minimum over the facet's parametrization (a collapsed square for triangles), the
    weights reproduce the point and sum to 1."""
    from fenics_coulomb.model.pairs.facet_closest import _closest_quad, _closest_triangle

    rng = np.random.default_rng(7)
    k = 60
    square = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)[:nv]
    X = square + rng.uniform(-1, 1, (k, nv, 3)) * [0.15, 0.15, 0.3]
    p = rng.uniform([-0.6, -0.6, -1.0], [1.6, 1.6, 1.0], (k, 3))
    q, w, dist = (_closest_quad if nv == 4 else _closest_triangle)(p, X)
    assert np.allclose(w.sum(axis=1), 1, atol=1e-13) and (w >= -1e-13).all()
    assert np.allclose(np.einsum("kj,kjc->kc", w, X), q, atol=1e-13)
    assert np.allclose(np.linalg.norm(q - p, axis=1), dist, atol=1e-14)
    g = np.linspace(0, 1, 21)
    starts = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    for i in range(k):  # a loop in the test oracle only
        if nv == 4:
            def x(z, V=X[i]):
                return V[0] * (1 - z[0]) * (1 - z[1]) + V[1] * z[0] * (1 - z[1]) + V[2] * (1 - z[0]) * z[1] \
                    + V[3] * z[0] * z[1]
        else:
            def x(z, V=X[i]):
                return V[0] + z[0] * ((V[1] - V[0]) + z[1] * (V[2] - V[1]))
        best = _box_minimum(lambda z, x=x, pi=p[i]: float(np.sum((x(z) - pi) ** 2)), starts)
        assert abs(dist[i] - best) <= 1e-7, (i, dist[i], best)
        assert dist[i] <= best + 1e-12


# -- the normal cone at a convex corner --------------------------------------------------------------------
@pytest.mark.parametrize("y0", [0.25, 0.75])
@pytest.mark.parametrize("cell", CELLS)
def test_convex_corner(cell, y0):
    """A slave node beyond M's outer edge is free; with the sides in M it is paired with n = d/|d| (in the
    cone of the top and side normals: at the edge x = 1, and at the corner vertex (1, 1, 0) when y0 = 0.75)."""
    gap = 0.05
    b = two_blocks(MPI.COMM_WORLD, cell_type=cell, gap=gap, upper_origin=(0.75, y0), upper=(0.5, 0.5, 0.25),
                   n_upper=(4, 4, 1))
    V = space(b.mesh)
    top = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"])],
                        NONE)
    data = gathered(V, top)
    assert (data["x"][:, :2] <= 1 + 1e-12).all()
    # x (and y) = 0.75, 0.875, 1 (at 1: d ∥ the top's normal, on its outer edge)
    assert top.num_global == (3 * 5 if y0 == 0.25 else 3 * 3)
    assert np.allclose(data["g"], gap) and np.allclose(data["n"], [0, 0, 1], atol=1e-12)

    both = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"],
                                         master=[TAGS["lower_top"], TAGS["lower_sides"]], search_distance=1.0)],
                          NONE)
    data = gathered(V, both)
    check_common(V, both, data)
    assert both.num_global == 5 * 5
    x = data["x"]
    beyond = (x[:, 0] > 1 + 1e-12) | (x[:, 1] > 1 + 1e-12)
    d = x - np.stack([np.minimum(x[:, 0], 1.0), np.minimum(x[:, 1], 1.0), 0 * x[:, 2]], axis=1)
    assert np.allclose(data["xm"], x - d, atol=1e-13)
    assert np.allclose(data["g"], np.linalg.norm(d, axis=1), atol=1e-13)
    assert np.allclose(data["n"][beyond], d[beyond] / np.linalg.norm(d[beyond], axis=1)[:, None], atol=1e-12)
    assert np.allclose(data["n"][~beyond], [0, 0, 1], atol=1e-12)
    assert beyond.sum() == (10 if y0 == 0.25 else 16)


# -- search distance, several pairs -------------------------------------------------------------------------
@pytest.mark.parametrize("gap,search,expected", [(0.05, 0.04, 0), (0.05, 0.06, 9), (0.15, None, 0),
                                                 (0.1, None, 9)])
def test_search_distance(gap, search, expected):
    """|g| <= search_distance (default 0.1 × the master's bounding-box diagonal √2); none: a warning."""
    b = two_blocks(MPI.COMM_WORLD, gap=gap, n_upper=(2, 2, 1))
    V = space(b.mesh)
    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = records.append  # on the module's own logger: the CLI's logger setup does not propagate
    log = logging.getLogger("fenics_coulomb.model.pairs.pairing")
    log.addHandler(handler)
    try:
        P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"],
                                          search_distance=search, name="press")], NONE)
    finally:
        log.removeHandler(handler)
    assert P.num_global == expected
    warned = any("'press'" in r.getMessage() and "no contact node" in r.getMessage() for r in records)
    assert warned == (expected == 0 and MPI.COMM_WORLD.rank == 0)


def three_blocks(a: float, b: float, cell: str = "hexahedron"):
    """Lower block (top z = 0), a thin slave block at z = a, an upper block with its bottom at z = b."""
    boxes = [((0, 0, -0.5), (1, 1, 0.5), (2, 2, 1)), ((0.25, 0.25, a), (0.5, 0.5, 0.0625), (3, 3, 1)),
             ((0, 0, b), (1, 1, 0.25), (2, 2, 1))]
    msh, cells = boxes_mesh(MPI.COMM_WORLD, boxes, cell, "bodies")
    msh.topology.create_connectivity(2, 3)
    facets = dolfinx.mesh.exterior_facet_indices(msh.topology)
    f2c = msh.topology.connectivity(2, 3)
    body = cells.values[f2c.array[f2c.offsets[facets]]]
    z = dolfinx.mesh.compute_midpoints(msh, 2, facets)[:, 2]
    value = np.select([(body == 1) & np.isclose(z, 0), (body == 2) & np.isclose(z, a), (body == 3) & np.isclose(z, b)],
                      [1, 2, 3], 0).astype(np.int32)
    keep = value > 0
    return msh, dolfinx.mesh.meshtags(msh, 2, facets[keep], value[keep])


@pytest.mark.parametrize("a,b,winner", [(0.0625, 0.25, 0), (0.1875, 0.28125, 1), (0.125, 0.25, 0)])
def test_two_pairs_smallest_gap(a, b, winner):
    """A slave surface between two masters: the pair with the smallest |g| wins, ties by pair order."""
    msh, ft = three_blocks(a, b)
    V = space(msh)
    below = ContactPair(ft, slave=2, master=1, friction=0.1, search_distance=0.5)
    above = ContactPair(ft, slave=2, master=3, friction=0.2, search_distance=0.5)
    P = pair_surfaces(V, [below, above], NONE)
    data = gathered(V, P)
    assert P.num_global == 16
    check_common(V, P, data)
    assert (data["pair"] == winner).all()
    assert np.allclose(data["F"], [0.1, 0.2][winner])
    assert np.allclose(data["g"], [a, b - a][winner])
    assert np.allclose(data["n"], [[0, 0, 1], [0, 0, -1]][winner], atol=1e-12)
    swapped = gathered(V, pair_surfaces(V, [above, below], NONE))
    if a == b - a:  # a tie: the first pair wins in either order
        assert (swapped["pair"] == 0).all() and np.allclose(swapped["F"], 0.2)
    else:
        assert (swapped["pair"] == 1 - winner).all() and np.allclose(swapped["F"], data["F"])


def test_excluded_nodes_are_free():
    """A slave node with a Dirichlet component is never a contact node."""
    b = two_blocks(MPI.COMM_WORLD, gap=0.01, n_upper=(2, 2, 1))
    V = space(b.mesh)
    x = V.tabulate_dof_coordinates()
    excluded = np.flatnonzero(np.isclose(x[:, 0], 0.25) & np.isclose(x[:, 2], 0.01)).astype(np.int32)
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"])], excluded)
    data = gathered(V, P)
    assert P.num_global == 6 and not np.isclose(data["x"][:, 0], 0.25).any()


# -- sign choice, overlap and bad input --------------------------------------------------------------------
def test_small_penetration_has_negative_gap():
    """A slave surface 1e-9 inside the master body (below 1e-6 × the size): paired with g < 0, n = e₃."""
    b = two_blocks(MPI.COMM_WORLD, gap=-1e-9, n_upper=(2, 2, 1), upper_origin=(0.3, 0.3))
    V = space(b.mesh)
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"])], NONE)
    data = gathered(V, P)
    assert P.num_global == 9
    assert np.allclose(data["g"], -1e-9, rtol=1e-6, atol=0) and np.allclose(data["n"], [0, 0, 1], atol=1e-12)


@pytest.mark.parametrize("cell", CELLS)
def test_overlap_is_an_interference(cell):
    """The upper block 0.01 inside the lower one: every slave node is a contact node with the gap −0.01 (an
    interference, resolved by the solve); with a search distance of 0.005 the overlap is out of reach: refused,
    one line naming a node and its depth."""
    b = two_blocks(MPI.COMM_WORLD, cell_type=cell, gap=-0.01, n_upper=(2, 2, 1), upper_origin=(0.3, 0.3))
    V = space(b.mesh)
    pair = ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], method="node-to-surface")
    P = pair_surfaces(V, [pair], NONE)
    assert P.num_global == 9 and np.allclose(P.gap, -0.01, rtol=1e-9, atol=0)
    near = ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], search_distance=0.005)
    with pytest.raises(InputError, match=r"^contact pair 1: the bodies overlap at the reference configuration "
                       r"beyond the search distance: slave node \(.*\) lies 0\.01 inside the master body"):
        pair_surfaces(V, [near], NONE)


def test_phi_squared_rejected():
    """Two pairs over one interface, each surface the slave of one and the master of the other: contact nodes
    that are vertices of master facets (a pair within one body is refused before: test_mortar_geometry.py)."""
    b = two_blocks(MPI.COMM_WORLD, gap=0.01, n_upper=(2, 2, 1))
    V = space(b.mesh)
    with pytest.raises(InputError, match=r"contact node \(.*\) is a vertex of the master facet used by contact "
                                         r"node \(.*\).*Φ²"):
        pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"]),
                          ContactPair(b.facet_tags, slave=TAGS["lower_top"], master=TAGS["upper_bottom"])], NONE)


def test_bad_tags_and_space():
    b = two_blocks(MPI.COMM_WORLD, gap=0.01, n_upper=(2, 2, 1))
    V = space(b.mesh)
    with pytest.raises(InputError, match="contact pair 2: master tag 99: no facet carries it"):
        pair_surfaces(V, [ContactPair(b.facet_tags, slave=2, master=1), ContactPair(b.facet_tags, slave=2, master=99)],
                      NONE)
    with pytest.raises(InputError, match="slave tag 42"):
        pair_surfaces(V, [ContactPair(b.facet_tags, slave=[2, 42], master=1)], NONE)
    with pytest.raises(InputError, match=r"vector P1 .* or Q1"):
        pair_surfaces(space(b.mesh, 2), [ContactPair(b.facet_tags, slave=2, master=1)], NONE)
    with pytest.raises(InputError, match="contact pair 1: facet_tags of dimension 3: must tag facets"):
        pair_surfaces(V, [ContactPair(b.cell_tags, slave=2, master=1)], NONE)
    # an interior facet layer (z = −0.25 inside the lower block)
    msh = b.mesh
    msh.topology.create_entities(2)
    inner = dolfinx.mesh.locate_entities(msh, 2, lambda x: np.isclose(x[2], -0.25))
    tags = dolfinx.mesh.meshtags(msh, 2, inner, np.full(inner.size, 7, dtype=np.int32))
    with pytest.raises(InputError, match=r"contact pair 2: slave tag\(s\) \[7\] mark an interior facet"):
        pair_surfaces(V, [ContactPair(b.facet_tags, slave=2, master=1), ContactPair(tags, slave=7, master=7)], NONE)


@pytest.mark.parametrize("kwargs,match", [
    (dict(friction=-0.1), "friction = -0.1"), (dict(friction=float("nan")), "friction = nan"),
    (dict(friction=True), "friction = True"), (dict(search_distance=0.0), "search_distance = 0.0"),
    (dict(search_distance=float("inf")), "search_distance = inf"), (dict(slave="top"), "slave = 'top'"),
    (dict(slave=[]), r"slave = \[\]: an empty surface"), (dict(master=1.5), "master = 1.5"),
    (dict(name=""), "name = ''"), (dict(facet_tags=None), "facet_tags = NoneType")])
def test_pair_validation(kwargs, match):
    b = two_blocks(MPI.COMM_SELF, n_upper=(1, 1, 1), n_lower=(1, 1, 1))
    args = dict(facet_tags=b.facet_tags, slave=2, master=1) | kwargs
    with pytest.raises(InputError, match=match):
        ContactPair(**args)


# -- 1 rank = 2 ranks -----------------------------------------------------------------------------------
@pytest.mark.compares_ranks
@pytest.mark.parametrize("method", ["node-to-surface", "mortar"])
@pytest.mark.parametrize("partitioner", ["bodies", None, "ghosted"])
@pytest.mark.parametrize("cell", CELLS)
def test_ranks_agree(cell, partitioner, method):
    """The same pairing on COMM_SELF and on all ranks (bodies on different ranks: every master facet on
    another rank than its slave nodes), compared by coordinates."""
    def run(comm, partitioner):
        b = two_blocks(comm, cell_type=cell, gap=0.45, upper_origin=(0.6, 0.2), upper=(0.6, 0.6, 0.2),
                       n_upper=(5, 4, 1), n_lower=(4, 3, 2),
                       partitioner=None if partitioner == "ghosted" else partitioner,
                       ghost_mode=dolfinx.mesh.GhostMode.shared_facet if partitioner == "ghosted"
                       else dolfinx.mesh.GhostMode.none,
                       lower_top=lambda x, y: 0.2 * x * (1 + y))
        V = space(b.mesh)
        P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=TAGS["upper_bottom"],
                                          master=[TAGS["lower_top"], TAGS["lower_sides"]], search_distance=1,
                                          method=method)],
                          NONE)
        return P, gathered(V, P)

    P, many = run(MPI.COMM_WORLD, partitioner)  # "ghosted": a layer of ghost cells (shared_facet)
    _, one = run(MPI.COMM_SELF, None)
    if MPI.COMM_WORLD.size > 1 and partitioner == "bodies":
        assert (P.size == 0) == (MPI.COMM_WORLD.rank == 0)  # slave nodes on rank 1, master facets on rank 0
    # mortar: the slave nodes past the lower block's edge x = 1 (or whose facets reach past it) are free
    assert many["x"].shape[0] == one["x"].shape[0] == (30 if method == "node-to-surface" else 15)
    for key in ("x", "xm", "g", "n"):
        assert np.allclose(many[key], one[key], atol=1e-12, rtol=0), key
    # the stencils as functionals Σ_j φ_j f(x_j) of smooth test functions: the global numbering (and so the
    # facet the tie rule picks at an edge or vertex) depends on the partition, the non-zero φ_j do not
    for a in ([1.0, 2.0, 3.0], [-2.0, 0.5, 1.5], [0.3, -1.0, 2.5]):
        f_many = np.einsum("kj,kj->k", many["w"], np.exp(many["mx"] @ a))
        f_one = np.einsum("kj,kj->k", one["w"], np.exp(one["mx"] @ a))
        assert np.allclose(f_many, f_one, atol=1e-12, rtol=0)



def test_a_held_node_decides_its_cone_in_the_directions_it_can_move():
    """A slave node on the plane y = 0 where the master facet ends, 1e-3 inside it; the facet tilted out of the plane
    by 0.01 (as the shrink fit's deformation tilted the shaft's facets at the quarter model's planes). Its closest
    point lies on the border edge, x − x_m is off the facet's normal by 1e-5: no contact node by the cone rule.
    Held along y (a symmetry plane: it cannot leave it), x − x_m and n agree in x and z: a contact node. Held along x
    only, it can move in y, where they disagree: still none. Held along y but beyond the border (a slave wider than
    its master, a roller on its side): none — the first version paired those too, a phantom support carrying 19 %
    of a plate's load over the gap between two rails."""
    from fenics_coulomb.model.pairs.node_to_surface import _held_cone
    from fenics_coulomb.model.pairs.projection import Surface, facet_ranks, facet_sizes, project

    surface = Surface(np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.01]]]), np.array([[0, 1, 2]]),
                      np.array([1.0]))
    x = np.array([[0.5, 0.0, -1e-3]])
    res = project(x, surface, facet_sizes(surface), facet_ranks(surface))
    assert not res["paired"][0]
    assert np.allclose(res["closest"], [[0.5, 0.0, 0.0]], atol=1e-15)
    size = facet_sizes(surface)
    assert _held_cone(x, res, np.array([[False, True, False]]), size)[0]
    assert not _held_cone(x, res, np.array([[True, False, False]]), size)[0]
    assert not _held_cone(x, res, np.array([[False, False, False]]), size)[0]
    # held along y but beyond the border (y = −0.001 … −100): the master does not go on there, no contact node
    for beyond in (1e-3, 0.1, 1.0, 100.0):
        far = np.array([[0.5, -beyond, -1e-3]])
        res = project(far, surface, size, facet_ranks(surface))
        assert not res["paired"][0] and not _held_cone(far, res, np.array([[False, True, False]]), size)[0]
