"""Dual mortar contact pairs (issue 28): the integrals against an independent brute-force integrator, the SCD
solve against an Alart–Curnier solve in u with the brute-force matrices, the patch-test property, swapping
slave and master, edge dropping, bad input.

The brute force (tests/mortar_brute_force.py) shares nothing with fenics_coulomb.model.pairs.segmentation but the
facets' vertex lists (``facet_data``: coordinates, global blocks, outward orientation).
"""

from __future__ import annotations

import sys
from math import factorial
from pathlib import Path

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest
import scipy.sparse as sp
from conftest import assert_physics, global_norm

from fenics_coulomb import ContactPair, ContactProblem
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs.forces import pair_forces
from fenics_coulomb.model.pairs.polygons import clip
from fenics_coulomb.model.pairs.segmentation import GAUSS7, GAUSS7_W, dual_coefficients, mortar_nodes
from fenics_coulomb.model.pairs import pair_surfaces
from fenics_coulomb.model.pairs.projection import facet_data, gather_surface, local_facets, project
from fenics_coulomb.model.dof_values import owned_values

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from mortar_brute_force import brute_force  # noqa: E402
from meshes.two_blocks import TAGS, two_blocks  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_two_body import elasticity  # noqa: E402

MASTER, SLAVE, LOWER_BOTTOM, UPPER_TOP = (TAGS[k] for k in ("lower_top", "upper_bottom", "lower_bottom", "upper_top"))
TIGHT = {"rtol": 1e-12, "tol": 1e-12}


def bend(x, y):
    """A curved lower top (its Q1 facets non-planar, its P1 facets tilted)."""
    return 0.06 * (x - 0.3) * (y + 0.2) + 0.03 * x * x


def surfaces(cell, slave_tag, master_tag, n_lower, n_upper=(4, 4, 2), gap=0.3, lower_top=bend):
    blocks = two_blocks(MPI.COMM_SELF, lower=(2.0, 1.0, 1.0), n_lower=n_lower, upper_origin=(0.2, 0.1),
                        upper=(1.6, 0.8, 1.0), n_upper=n_upper, gap=gap, cell_type=cell, lower_top=lower_top)
    V = dolfinx.fem.functionspace(blocks.mesh, ("Lagrange", 1, (3,)))
    X = V.tabulate_dof_coordinates()
    nv = 4 if cell == "hexahedron" else 3
    S = gather_surface(MPI.COMM_SELF, facet_data(V, local_facets(blocks.facet_tags, [slave_tag]), X), nv)
    M = gather_surface(MPI.COMM_SELF, facet_data(V, local_facets(blocks.facet_tags, [master_tag]), X), nv)
    return S, M


def library(S, M, nodes):
    size = np.linalg.norm(M.X[:, 0] - M.X[:, -1], axis=1)
    rank = np.arange(M.X.shape[0])
    verts, first = np.unique(S.blocks.ravel(), return_index=True)
    closest = project(S.X.reshape(-1, 3)[first], M, size, rank)["closest"]
    return mortar_nodes((S.X, S.blocks, S.sign), (M.X, M.blocks, M.sign), nodes, (verts, closest))


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_quadrature_and_dual_basis():
    """The 7-point rule integrates degree 5 exactly; the dual basis is biorthogonal on a warped quadrilateral."""
    a, b = GAUSS7[:, 1], GAUSS7[:, 2]
    for i in range(6):
        for j in range(6 - i):  # ∫_T x^i y^j = i! j! / (i + j + 2)!
            exact = factorial(i) * factorial(j) / factorial(i + j + 2)
            assert abs(0.5 * GAUSS7_W @ (a**i * b**j) - exact) <= 1e-15
    X = np.array([[[0, 0, 0], [1.2, 0.1, 0.05], [0.1, 0.9, -0.04], [1.1, 1.3, 0.2]]], dtype=float)
    A, De = dual_coefficients(X)
    g, gw = np.polynomial.legendre.leggauss(12)
    g, gw = 0.5 * (g + 1), 0.5 * gw
    xi, eta = np.repeat(g, 12), np.tile(g, 12)
    w = np.repeat(gw, 12) * np.tile(gw, 12)
    N = np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta], axis=1)
    dx = np.outer(1 - eta, X[0, 1] - X[0, 0]) + np.outer(eta, X[0, 3] - X[0, 2])
    de = np.outer(1 - xi, X[0, 2] - X[0, 0]) + np.outer(xi, X[0, 3] - X[0, 1])
    J = np.linalg.norm(np.cross(dx, de), axis=1) * w
    psi = N @ A[0].T
    assert np.allclose((psi * J[:, None]).T @ N, np.diag(De[0]), rtol=0, atol=1e-6 * De[0].max())
    assert np.allclose(psi.sum(axis=1), 1.0)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_clipping():
    """Sutherland–Hodgman: a square clipped by a rotated square is the octagon of the known area; disjoint
    polygons give nothing; a polygon inside the clipper is itself."""
    square = np.array([[[-1, -1], [1, -1], [1, 1], [-1, 1]]], dtype=float)
    c, s = np.cos(np.pi / 4), np.sin(np.pi / 4)
    rotated = square @ np.array([[c, s], [-s, c]])
    P, n = clip(square, np.array([4]), rotated, np.array([1e-12]))
    poly = P[0, : n[0]]
    area = 0.5 * np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - poly[:, 1] * np.roll(poly[:, 0], -1))
    assert n[0] == 8 and abs(area - 8 * (np.sqrt(2) - 1)) < 1e-12
    P, n = clip(square + 5, np.array([4]), square, np.array([1e-12]))
    assert n[0] == 0
    P, n = clip(0.5 * square, np.array([4]), square, np.array([1e-12]))
    assert n[0] == 4 and np.allclose(P[0, :4], 0.5 * square[0])


@pytest.mark.serial
@pytest.mark.parametrize(("cell", "case", "subdivisions", "tol"), [
    ("tetrahedron", "curved slave", 256, 1e-6),
    ("tetrahedron", "curved master", 128, 1e-6),
    ("hexahedron", "curved master", 64, 1e-6),
    # non-planar slave quadrilaterals: the brute force's own error (its sub-piece dual basis, its degree-2 rule
    # on a non-polynomial surface element) dominates: M within 3e-5 of D at n = 32, 1.1e-5 at 64; D 1e-8, g̃ 1e-12
    ("hexahedron", "curved slave", 48, 2e-5),
])
def test_integrals_agree_with_brute_force(cell, case, subdivisions, tol):
    """D_j, M_jl, g̃_j and the nodal normals of fully covered nodes equal the brute-force integrals (rays along
    n_c from many sub-triangles) to 1e-6 of D_j (g̃/D_j to 1e-8 absolute); ∫_S N_j exactly. Curved slave: the
    bent lower top (tilted triangles; non-planar bilinear quadrilaterals) under the flat upper bottom; curved
    master: the other way round."""
    if case == "curved slave":
        S, M = surfaces(cell, MASTER, SLAVE, n_lower=(10, 6, 2))
    else:
        S, M = surfaces(cell, SLAVE, MASTER, n_lower=(5, 3, 2))
    nodes = np.unique(S.blocks)
    res = library(S, M, nodes)
    covered = res.fully_covered
    assert covered.sum() >= 4
    pick = nodes[covered][:: max(1, covered.sum() // 3)][:3 if cell == "hexahedron" else 4]
    bf = brute_force(S.X, S.blocks, S.sign, M.X, M.blocks, M.sign, pick, n=subdivisions)
    for j in pick:
        k = int(np.flatnonzero(nodes == j)[0])
        o = bf[int(j)]
        assert abs(o["covered"] / o["full"] - 1) < 1e-9  # the brute force sees it covered as well
        assert abs(res.full[k] / o["full"] - 1) < 1e-9
        assert abs(res.D[k] / o["D"] - 1) < tol
        assert abs(res.weighted_gap[k] - o["g"]) <= 1e-8 * o["D"]
        assert np.allclose(res.normal[k], o["normal"], rtol=0, atol=1e-12)
        lib = {int(b): v for b, v in zip(res.stencil_blocks[k], res.M[k], strict=True) if b >= 0}
        keys = set(lib) | {b for b, v in o["M"].items() if abs(v) > 1e-12 * o["D"]}
        assert max(abs(lib.get(b, 0.0) - o["M"].get(b, 0.0)) for b in keys) <= tol * o["D"]
        # Σ_l Φ_jl = 1 on a covered node: exactly on planar facets; on non-planar slave quadrilaterals up to the
        # quadrature of the dual basis (4 × 4 Gauss points of |x_ξ × x_η|) against the segments' 7-point rule
        planar = not (cell == "hexahedron" and case == "curved slave")
        assert abs(res.stencil[k].sum() - 1) < (1e-12 if planar else 1e-7)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_partly_covered_nodes_are_free():
    """Slave = the larger lower top: the nodes whose facets reach past the upper block's footprint are not fully
    covered, whatever their gap (edge dropping); the fully covered ones lie inside the footprint."""
    S, M = surfaces("tetrahedron", MASTER, SLAVE, n_lower=(10, 6, 2), lower_top=None)
    nodes = np.unique(S.blocks)
    res = library(S, M, nodes)
    # flat and parallel: covered exactly when every facet around the node lies inside the upper footprint
    lo, hi = np.array([0.2, 0.1]) - 1e-12, np.array([1.8, 0.9]) + 1e-12
    facet_inside = np.all((S.X[:, :, :2] >= lo) & (S.X[:, :, :2] <= hi), axis=(1, 2))
    outside = np.unique(S.blocks[~facet_inside])
    inside = ~np.isin(nodes, outside)
    assert 0 < inside.sum() < nodes.size
    assert np.array_equal(res.fully_covered, inside)
    assert np.allclose(res.gap[inside], 0.3)  # flat and parallel: the gap itself


def tet_blocks(comm, lower=(5, 3, 2), upper=(4, 4, 2), gap=1e-3):
    blocks = two_blocks(comm, lower=(2.0, 1.0, 1.0), n_lower=lower, upper_origin=(0.2, 0.1), upper=(1.6, 0.8, 1.0),
                        n_upper=upper, gap=gap, cell_type="tetrahedron")
    return blocks.mesh, blocks.facet_tags


def pressed(comm, msh, ft, top=(0.0015, 0.0, -0.004)):
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    bcs = [dolfinx.fem.dirichletbc(np.asarray(top, float),
                                   dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)]
    return V, bcs, elasticity(V, 70.0, 0.2, upper=(20.0, 0.45))


@pytest.mark.serial
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_scd_agrees_with_alart_curnier_on_brute_force_matrices(friction):
    """Non-matching tetrahedral blocks pressed and sheared (the softer upper block slips where friction allows):
    the SCD solve of the mortar pair and an Alart–Curnier solve in u whose coupling w_j = u_j − Σ_l (M_jl/D_j) u_l,
    gaps g̃_j/D_j and normals all come from the brute-force integrator agree (1e-7); the physics holds; the
    force on each body from its own residual is equal and opposite (1e-8)."""
    from brute_force import solve_contact

    msh, ft = tet_blocks(MPI.COMM_SELF)
    V, bcs, a = pressed(MPI.COMM_SELF, msh, ft)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=friction)
    # the reference-configuration model the brute force shares (finite sliding: test_finite_sliding*.py)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="mbf_",
                        sliding="small") as problem:
        _, result = problem.solve()
        assert result.converged
        model = problem.model
        assert_physics(model, result.relative_displacement)
        ip, ix, vals = model.A_free.getValuesCSR()
        K = sp.csr_matrix((vals, ix, ip), shape=model.A_free.getSize())
        u_scd = owned_values(problem.u)
        blocks = model.pairing.blocks
        (forces,) = pair_forces(model, result, [pair])
        assert forces["balance"] < 1e-8
    X = V.tabulate_dof_coordinates()
    S = gather_surface(MPI.COMM_SELF, facet_data(V, local_facets(ft, [SLAVE]), X), 3)
    M = gather_surface(MPI.COMM_SELF, facet_data(V, local_facets(ft, [MASTER]), X), 3)
    bf = brute_force(S.X, S.blocks, S.sign, M.X, M.blocks, M.sign, blocks, n=128)
    m, n = blocks.size, K.shape[0]
    rows, cols, data, gaps, frames = [], [], [], np.zeros(m), np.zeros((m, 3, 3))
    for i, j in enumerate(blocks):
        o = bf[int(j)]
        gaps[i] = o["g"] / o["D"]
        nrm = o["normal"]
        t1 = np.cross(nrm, [1.0, 0, 0] if abs(nrm[0]) < 0.9 else [0, 1.0, 0])
        t1 /= np.linalg.norm(t1)
        frames[i] = np.column_stack([t1, np.cross(nrm, t1), nrm])
        for c in range(3):
            rows.append(3 * i + c), cols.append(3 * int(j) + c), data.append(1.0)
            for l, v in o["M"].items():
                rows.append(3 * i + c), cols.append(3 * l + c), data.append(-v / o["D"])
    G = sp.csr_matrix((data, (rows, cols)), shape=(3 * m, n))
    g = dolfinx.fem.Function(V)
    g.x.array[:] = np.nan
    for bc in bcs:
        bc.set(g.x.array)
    D = np.flatnonzero(~np.isnan(g.x.array))
    sol = solve_contact(K, np.zeros(n), np.arange(3 * m).reshape(-1, 3), gaps, friction, frames=frames, coupling=G,
                        dirichlet=(D, g.x.array[D]))
    assert np.linalg.norm(sol.u - u_scd) <= 1e-7 * np.linalg.norm(u_scd)
    if friction > 0:
        assert np.abs(sol.force[:, :2]).max() > 1e-3 * np.abs(sol.force[:, 2]).max()


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_swapping_slave_and_master_on_non_matching_meshes(friction):
    """The full-footprint blocks of docs/two-bodies (lower top 5 × 3, upper bottom 4 × 4 cells), pressed and
    sheared: the swapped mortar pair moves the displacement by well under 1 % (node-to-surface: 3.7 %)."""
    from test_two_body import two_blocks as blocks_hex

    results = []
    msh, ft = blocks_hex(MPI.COMM_WORLD, lower=(5, 3, 2), upper=(4, 4, 2), upper_origin=(0.0, 0.0),
                         upper_size=(2.0, 1.0, 1.0))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0008, 0.0, -0.004]),
                                   dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)]
    a = elasticity(V, 70.0, 0.2, upper=(20.0, 0.45))
    for slave, master in ((SLAVE, MASTER), (MASTER, SLAVE)):
        pair = ContactPair(ft, slave=slave, master=master, friction=friction, search_distance=0.05)
        # the swap is an identity of the reference-configuration model: in the deformed one the surfaces' borders
        # (here the same footprint) slide past each other differently
        with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="mswap_",
                            sliding="small") as p:
            _, result = p.solve()
            assert result.converged
            assert_physics(p.model, result.relative_displacement)
            results.append(owned_values(p.u))
    difference = global_norm(results[0] - results[1]) / global_norm(results[0])
    assert difference < 0.01, difference


def test_larger_slave_drops_its_border_nodes():
    """The larger lower top as the slave under the smaller upper block: only the fully covered nodes are contact
    nodes, and the solve still converges with the physics."""
    msh, ft = tet_blocks(MPI.COMM_WORLD, lower=(10, 6, 2), upper=(4, 4, 2))
    V, bcs, a = pressed(MPI.COMM_WORLD, msh, ft, top=(0.0, 0.0, -0.004))
    pair = ContactPair(ft, slave=MASTER, master=SLAVE, friction=0.0)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="mdrop_") as p:
        _, result = p.solve()
        assert result.converged
        x = p.model.pairing.coordinates
        h = np.array([0.2, 1 / 6])
        assert np.all((x[:, :2] >= np.array([0.2, 0.1]) + h - 1e-12) & (x[:, :2] <= np.array([1.8, 0.9]) - h + 1e-12))
        assert p.p > 0
        assert_physics(p.model, result.relative_displacement,
                       keys=("equilibrium", "penetration", "negative_pressure", "complementarity"))


def test_bad_method_and_non_convex_facets():
    msh, ft = tet_blocks(MPI.COMM_WORLD)
    with pytest.raises(InputError, match="method = 'nitsche'"):
        ContactPair(ft, slave=SLAVE, master=MASTER, method="nitsche")
    # a master quadrilateral seen edge-on from a slave facet folds in its projection: named
    X = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]], dtype=float)
    Y = np.array([[[0.1, 0.1, -0.1], [0.9, 0.1, -0.1], [0.1, 0.9, -0.1], [0.95, 0.95, -0.1]]], dtype=float)
    Y[0, 3] = [0.2, 0.2, -0.1]  # a non-convex (arrow-shaped) master facet
    with pytest.raises(InputError, match="not a convex quadrilateral"):
        mortar_nodes((X, np.array([[0, 1, 2, 3]]), np.array([-1.0])), (Y, np.array([[4, 5, 6, 7]]), np.array([1.0])),
                     np.array([0, 1, 2, 3]), (np.arange(4), X[0] - [0, 0, 0.1]))


def test_a_bad_facet_on_one_rank_is_an_error_on_every_rank(monkeypatch):
    """The segmentation's InputError (a non-convex projected quadrilateral) found by one rank only: every rank
    raises it, naming the pair, before the next collective call (no rank waits for the others)."""
    import fenics_coulomb.model.pairs.mortar as mortar_method

    comm = MPI.COMM_WORLD
    original = mortar_method.mortar_nodes

    def bad_on_rank_0(*args, **kwargs):
        if comm.rank == 0:
            raise InputError("master facet at (1, 2, 3): its projection ... is not a convex quadrilateral")
        return original(*args, **kwargs)

    monkeypatch.setattr(mortar_method, "mortar_nodes", bad_on_rank_0)
    msh, ft = tet_blocks(comm)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    with pytest.raises(InputError, match=r"contact pair 'press': master facet at \(1, 2, 3\)"):
        pair_surfaces(V, [ContactPair(ft, slave=SLAVE, master=MASTER, name="press")], np.zeros(0, np.int32))
