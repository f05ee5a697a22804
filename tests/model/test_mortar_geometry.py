"""Dual mortar decided by geometry, not by round-off: clip polygons without duplicate vertices, coverage from the
clip polygons' exact areas, the overlap check on the true geometry, and pairs that do not join two bodies.

* Aligned grids: hexahedral blocks whose meshes share grid lines (a master vertex on every slave edge's line,
  non-parallelogram facets) keep every geometrically covered slave node, and u equals u of the same blocks
  offset by 1e-9 and 1e-8.
* The two-body patch test on distorted (non-parallelogram, flat) and warped (non-planar, the hyperbolic
  paraboloid z = c x y that bilinear facets represent exactly) quadrilateral patches, matching and
  non-matching: every slave node a contact node and the contact forces those of the exact state.
* A punch with a fillet on a block, slave and master swapped: both solve and their normal forces agree; on a
  coarse block the swapped pair has negative weighted gaps beside the fillet but no pointwise overlap, and is
  accepted.
* Pairs within one body (slave = master, a slave containing the master, two surfaces of one block) refused
  with one line on every rank, for both methods; an overlap of the slave nodes is an interference (negative
  gaps), refused beyond the search distance, and a master node inside the slave body between its nodes refused.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest
from conftest import assert_physics, global_norm

from fenics_coulomb import ContactPair, ContactProblem
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs.forces import pair_forces
from fenics_coulomb.model.pairs.polygons import clean_polygon, clip, polygon_area
from fenics_coulomb.model.pairs import pair_surfaces

ROOT = Path(__file__).resolve().parents[2]
from meshes.two_blocks import BODIES, TAGS, two_blocks  # noqa: E402
from benchmarks.two_body_patch import CHECKS, HEIGHT, elasticity, exact_pressure  # noqa: E402

from fenics_coulomb.model.checks import physics_residuals  # noqa: E402
from fenics_coulomb.model.dof_values import owned_values  # noqa: E402

MASTER, SLAVE, LOWER_BOTTOM, UPPER_TOP = (TAGS[k] for k in ("lower_top", "upper_bottom", "lower_bottom", "upper_top"))
TIGHT = {"rtol": 1e-12, "tol": 1e-14}
NONE = np.zeros(0, np.int32)

Map = Callable[[np.ndarray], np.ndarray]


def reshape(blocks, xy: Map | None = None, lower_z: Callable | None = None, upper_z: Callable | None = None,
            top: float | None = None, bottom: float = 0.0, H: float = HEIGHT):
    """Move the vertices of ``two_blocks`` in place: (x, y) ↦ xy(x, y) on both blocks; the lower block's z by
    lower_z(x, y)·(z + H)/H (its bottom fixed), the upper one's by upper_z(x, y)·(top − z)/(top − bottom) (its
    top fixed). The facet tags stay those of the undeformed grid."""
    msh = blocks.mesh
    x = msh.geometry.x
    cells = blocks.cell_tags.indices[blocks.cell_tags.values == BODIES["upper"]]
    upper = np.zeros(x.shape[0], dtype=bool)
    upper[np.unique(msh.geometry.dofmap[cells])] = True
    p = x.copy()
    if lower_z is not None:
        lo = ~upper
        x[lo, 2] += lower_z(p[lo, 0], p[lo, 1]) * (p[lo, 2] + H) / H
    if upper_z is not None:
        x[upper, 2] += upper_z(p[upper, 0], p[upper, 1]) * (top - p[upper, 2]) / (top - bottom)
    if xy is not None:
        x[:, :2] = xy(p[:, :2])
    return blocks


def distortion(a: float, size=(1.0, 1.0)) -> Map:
    """A smooth in-plane map of [0, Lx] × [0, Ly] onto itself (its border fixed): parallelograms → general
    quadrilaterals."""
    Lx, Ly = size

    def move(p):
        s, t = np.pi * p[:, 0] / Lx, np.pi * p[:, 1] / Ly
        return p + a * np.stack([Lx * np.sin(s) * np.sin(2 * t), Ly * np.sin(2 * s) * np.sin(t)], axis=1)

    return move


def cellwise(n=(8, 4), size=(2.0, 1.0), amplitude: float = 0.25, seed: int = 3) -> Map:
    """The map bilinear on each cell of the n₁ × n₂ grid of [0, Lx] × [0, Ly] whose interior vertices are moved
    by up to ``amplitude`` × the spacing (seeded): every cell a general quadrilateral, and a grid nested in it
    keeps its vertices on the moved grid's edges (the shared grid lines stay shared)."""
    h = np.array(size) / np.array(n)
    rng = np.random.default_rng(seed)
    V = np.stack(np.meshgrid(np.arange(n[0] + 1) * h[0], np.arange(n[1] + 1) * h[1], indexing="ij"), axis=-1)
    V[1:-1, 1:-1] += amplitude * h * rng.uniform(-1, 1, size=(n[0] - 1, n[1] - 1, 2))

    def move(p):
        s = p / h
        i = np.clip(np.floor(s).astype(int), 0, np.array(n) - 1)
        xi, eta = (s - i)[:, 0:1], (s - i)[:, 1:2]
        a, b, c, d = V[i[:, 0], i[:, 1]], V[i[:, 0] + 1, i[:, 1]], V[i[:, 0], i[:, 1] + 1], V[i[:, 0] + 1, i[:, 1] + 1]
        return (1 - xi) * (1 - eta) * a + xi * (1 - eta) * b + (1 - xi) * eta * c + xi * eta * d

    return move


# -- the clip polygon ------------------------------------------------------------------------------------
@pytest.mark.serial  # rank-local (docs/testing.md)
def test_clip_polygons_lose_duplicate_and_collinear_vertices():
    """A master quadrilateral equal to the slave one, or 1e-9 / 1e-8 beside it, is the same 4-vertex polygon
    after cleaning (the clipping repeats vertices or adds ones 1e-9 from the corners); a collinear mid-edge
    vertex and a duplicate are removed; a sliver is empty. The areas are those of the uncleaned polygons."""
    square = np.array([[[0, 0], [1, 0], [1, 1], [0, 1]]], dtype=float)
    skew = np.array([[[0, 0], [1.3, 0], [1.1, 0.9], [0.2, 1.2]]], dtype=float)
    cleaned = []
    for shift in (0.0, 1e-9, 1e-8):
        P, n = clip(skew + [shift, 0.7 * shift], np.array([4]), skew, np.array([1e-12]))
        assert abs(polygon_area(P, n)[0] - polygon_area(skew, np.array([4]))[0]) < 2e-8
        Q, m = clean_polygon(P, n, np.array([1e-6]))
        assert m[0] == 4
        cleaned.append(Q[0, :4][np.lexsort(Q[0, :4].T)])
    assert np.allclose(cleaned, cleaned[0], rtol=0, atol=2e-8)
    assert np.allclose(cleaned[0], skew[0][np.lexsort(skew[0].T)], rtol=0, atol=1e-15)
    P = np.array([[[0, 0], [0.5, 0], [1, 0], [1, 0], [1, 1], [0, 1]]], dtype=float)
    Q, m = clean_polygon(P, np.array([6]), np.array([1e-6]))
    assert m[0] == 4 and np.allclose(Q[0, :4].mean(axis=0), [0.5, 0.5])
    sliver = np.array([[[0, 0], [1, 0], [1, 1e-9], [0, 1e-9]]], dtype=float)
    assert clean_polygon(sliver, np.array([4]), np.array([1e-6]))[1][0] == 0
    assert np.isclose(polygon_area(P, np.array([6]))[0], 1.0)
    P, n = clip(square, np.array([4]), square, np.array([1e-12]))
    assert np.isclose(polygon_area(P, n)[0], 1.0)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_two_neighbouring_collinear_vertices_do_not_take_the_corner():
    """A clip polygon of the drag patch test's stall (docs/sliding: a slave edge on a master grid line, the
    footprint's whole-cell state after sub-cell states): two vertices 1.7e-7 apart at a corner (tol 1.1e-7), each
    within tol of the line through the other one and its far neighbour. Removing both left two vertices — an
    empty polygon, a whole fan triangle (1/3 of a facet's D_j) lost or kept by round-off at every update; one of
    them goes and the triangle keeps its area."""
    P = np.array([[[-0.01428595317332, -0.02777732877841], [-0.01428587510903, -0.02777748057041],
                   [-0.01428570650813, 0.05555559112656], [-0.03095232737789, 0.05555559112656]]])
    Q, m = clean_polygon(P, np.array([4]), np.array([1.1e-7]))
    assert m[0] == 3
    assert abs(polygon_area(Q, m)[0] - polygon_area(P, np.array([4]))[0]) <= 1.1e-7 * 0.2
    # a run of three collinear vertices along an edge: all go, one by one; a row of only collinear ones is empty
    P = np.array([[[0, 0], [0.25, 0], [0.5, 0], [0.75, 0], [1, 0], [1, 1], [0, 1]]], dtype=float)
    Q, m = clean_polygon(P, np.array([7]), np.array([1e-6]))
    assert m[0] == 4 and np.isclose(polygon_area(Q, m)[0], 1.0)
    line = np.array([[[0, 0], [0.5, 1e-9], [1, 0], [0.5, -1e-9]]], dtype=float)
    assert clean_polygon(line, np.array([4]), np.array([1e-6]))[1][0] == 0


# -- aligned grids --------------------------------------------------------------------------------------
def aligned_solve(comm, offset: float, method: str = "mortar"):
    """Lower block [0, 2] × [0, 1] (8 × 4 cells), upper block [0.25, 1.75] × [0.25, 0.75] (12 × 4 cells: its grid
    lines on the lower block's), both moved in-plane by the same map (:func:`cellwise`: general quadrilaterals,
    the grid lines still shared), pressed; the upper block moved by ``offset`` (x) and 0.7 offset (y) before
    the map."""
    b = two_blocks(comm, lower=(2.0, 1.0, 0.5), n_lower=(8, 4, 2), upper_origin=(0.25 + offset, 0.25 + 0.7 * offset),
                   upper=(1.5, 0.5, 0.25), n_upper=(12, 4, 2), gap=0.0)
    reshape(b, xy=cellwise())
    V = dolfinx.fem.functionspace(b.mesh, ("Lagrange", 1, (3,)))
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0004, 0.0, -0.002]),
                                   dolfinx.fem.locate_dofs_topological(V, 2, b.facet_tags.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3),
                                   dolfinx.fem.locate_dofs_topological(V, 2, b.facet_tags.find(LOWER_BOTTOM)), V)]
    a = elasticity(V, b.cell_tags, ((210.0, 0.3), (70.0, 0.3)))
    pair = ContactPair(b.facet_tags, slave=SLAVE, master=MASTER, friction=0.3, method=method)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="maligned_") as p:
        _, result = p.solve()
        assert result.converged
        assert_physics(p.model, result.relative_displacement)
        (forces,) = pair_forces(p.model, result, [pair])
        return p.model.pairing.num_global, owned_values(p.u), forces


def test_aligned_grids_keep_every_covered_node_and_agree_with_offset_grids():
    """Every node of the upper block's bottom lies over the lower top (13 × 5 = 65, all covered); the aligned
    grids keep them all, and u and the pair force equal those of the grids offset by 1e-9 and 1e-8 (no
    round-off cliff: the measured differences are about 3 × the offset)."""
    comm = MPI.COMM_WORLD
    count, u0, f0 = aligned_solve(comm, 0.0)
    assert count == 13 * 5
    for offset in (1e-9, 1e-8):
        count_o, u, f = aligned_solve(comm, offset)
        assert count_o == count
        diff = global_norm(u - u0) / global_norm(u0)
        assert diff < 20 * offset, (offset, diff)
        assert abs(f["force_on_slave_body"][2] / f0["force_on_slave_body"][2] - 1) < 20 * offset


# -- the patch test on distorted and warped quadrilaterals ------------------------------------------------
SAME = ((70.0, 0.0), (70.0, 0.0))


def patch(comm, n_lower, n_upper, kind: str, delta: float = 0.001, c: float = 0.02) -> dict[str, float]:
    """The uniaxial patch test of benchmarks/two_body_patch.py on reshaped blocks of footprint [0, 1]².

    ``distorted``: the flat interface, both meshes distorted in-plane (general quadrilaterals), E 210 / 70,
    frictionless. ``warped``: both blocks' interface on z = c x y (c = 0.1; every facet non-planar, the two
    discrete surfaces identical), one material (so the uniaxial state u₃ = −ε(z + H) is continuous across the
    curved interface) and F = 0.5: the exact contact force on slave node j is vertical, p ∫ N_j dx dy (the
    traction σn ds = −p e₃ dx dy), its tangential part carried by sticking friction.
    Returns the number of contact nodes, their count expected, and max_j |f_j − p A_j e₃| / (p A_j) with A_j
    = ∫ N_j dx dy (the projected nodal area)."""
    b = two_blocks(comm, lower=(1.0, 1.0, HEIGHT), n_lower=n_lower, upper_origin=(0.0, 0.0),
                   upper=(1.0, 1.0, HEIGHT), n_upper=n_upper, gap=0.0)
    if kind == "distorted":
        reshape(b, xy=distortion(0.04))
        materials, friction = ((210.0, 0.0), (70.0, 0.0)), 0.0
    else:
        def warp(x, y):
            return c * x * y

        reshape(b, lower_z=warp, upper_z=warp, top=HEIGHT, bottom=0.0)
        materials, friction = SAME, 0.5
    V = dolfinx.fem.functionspace(b.mesh, ("Lagrange", 1, (3,)))
    pair = ContactPair(b.facet_tags, slave=SLAVE, master=MASTER, friction=friction)
    p = exact_pressure(delta, materials)
    with ContactProblem(elasticity(V, b.cell_tags, materials), None, rollers(V, b.facet_tags, delta),
                        contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="mpatch_") as problem:
        _, result = problem.solve()
        assert result.converged
        checks = physics_residuals(problem.model, result.relative_displacement)
        assert max(checks[k] for k in CHECKS) < 1e-9, checks
        pairing = problem.model.pairing
        area = projected_areas(V, b.facet_tags, pairing.blocks)
        error = np.linalg.norm(result.contact_force - p * area[:, None] * [0.0, 0.0, 1.0], axis=1) / (p * area)
        worst = comm.allreduce(float(error.max(initial=0.0)), op=MPI.MAX)
        nodes = pairing.num_global
    return {"contact_nodes": nodes, "slave_nodes": (n_upper[0] + 1) * (n_upper[1] + 1), "error": worst}


def rollers(V, facet_tags, delta: float) -> list:
    """benchmarks/two_body_patch.py's supports on reshaped blocks: the sides (x or y = 0 or 1) on rollers except
    at the slave surface's nodes, the lower bottom u₃ = 0, the upper top u₃ = −δ."""
    sides = np.concatenate([facet_tags.find(TAGS["lower_sides"]), facet_tags.find(TAGS["upper_sides"])])
    mid = dolfinx.mesh.compute_midpoints(V.mesh, 2, sides)
    slave = dolfinx.fem.locate_dofs_topological(V, 2, facet_tags.find(SLAVE))  # blocks
    bcs = []
    for axis in (0, 1):
        on = np.isclose(mid[:, axis], 0.0) | np.isclose(mid[:, axis], 1.0)
        dofs = dolfinx.fem.locate_dofs_topological(V.sub(axis), 2, sides[on])
        dofs = dofs[~np.isin(dofs // 3, slave)]
        bcs.append(dolfinx.fem.dirichletbc(0.0, dofs, V.sub(axis)))
    for tag, value in (("lower_bottom", 0.0), ("upper_top", -delta)):
        dofs = dolfinx.fem.locate_dofs_topological(V.sub(2), 2, facet_tags.find(TAGS[tag]))
        bcs.append(dolfinx.fem.dirichletbc(value, dofs, V.sub(2)))
    return bcs


def projected_areas(V, facet_tags, blocks) -> np.ndarray:
    """A_j = ∫ N_j dx dy over the slave facets (2 × 2 Gauss: exact for bilinear facets) at the local blocks."""
    from fenics_coulomb.model.pairs.projection import facet_data, gather_surface, local_facets

    comm = V.mesh.comm
    X = V.tabulate_dof_coordinates()
    S = gather_surface(comm, facet_data(V, local_facets(facet_tags, [SLAVE]), X), 4)
    g = 0.5 + np.array([-1, 1]) / (2 * np.sqrt(3))
    xi, eta = np.repeat(g, 2), np.tile(g, 2)
    N = np.stack([(1 - xi) * (1 - eta), xi * (1 - eta), (1 - xi) * eta, xi * eta], axis=1)
    P = S.X[:, :, :2]
    a, b, c = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 0] - P[:, 1] - P[:, 2] + P[:, 3]
    dx = a[:, None] + eta[None, :, None] * c[:, None]
    de = b[:, None] + xi[None, :, None] * c[:, None]
    J = np.abs(dx[..., 0] * de[..., 1] - dx[..., 1] * de[..., 0]) * 0.25  # (k, q), weights 1/4
    contrib = J @ N  # (k, 4)
    vertices, inverse = np.unique(S.blocks.ravel(), return_inverse=True)
    total = np.bincount(inverse, weights=contrib.ravel(), minlength=vertices.size)
    glob = V.dofmap.index_map.local_to_global(np.asarray(blocks, np.int32)).astype(np.int64)
    return total[np.searchsorted(vertices, glob)]


@pytest.mark.parametrize(("kind", "n_lower", "n_upper", "bound"), [
    # measured (docs/two-bodies/geometry.md): 3.9e-6, 4.0e-6, 7.9e-7 (the segment quadrature on general
    # quadrilaterals); warped 1.0e-9 (matching), 2.1e-6, 3.8e-6 (c² h²: the traction is not in the dual space)
    ("distorted", (6, 6, 2), (6, 6, 2), 1e-5),   # matching
    ("distorted", (4, 4, 2), (5, 5, 2), 1e-5),
    ("distorted", (5, 5, 2), (4, 4, 2), 1e-5),
    ("warped", (6, 6, 2), (6, 6, 2), 1e-8),      # matching
    ("warped", (4, 4, 2), (5, 5, 2), 1e-5),
    ("warped", (5, 5, 2), (4, 4, 2), 1e-5),
])
def test_patch_on_distorted_and_warped_quadrilaterals(kind, n_lower, n_upper, bound):
    """Every slave node a contact node; the contact forces those of the exact uniform state (docs/two-bodies:
    on matching meshes to round-off, on non-matching distorted ones at the level of the segment quadrature)."""
    row = patch(MPI.COMM_WORLD, n_lower, n_upper, kind)
    assert row["contact_nodes"] == row["slave_nodes"], row
    assert row["error"] < bound, row


# -- a curved master against a flat slave: the punch with a fillet -----------------------------------------
def fillet(R: float, x0: float, x1: float) -> Callable:
    """The rise of a punch's bottom with rounded edges at x = x0 and x = x1: flat inside, a circular arc of
    radius R over the last R sin 45° before each edge (rising to R (1 − cos 45°), the slope 1 at the edge)."""
    w = R * np.sin(np.pi / 4)

    def arc(s):
        u = np.clip(w - s, 0.0, w)
        return R - np.sqrt(R * R - u * u)

    return lambda x, y: arc(x - x0) + arc(x1 - x)


def punch_blocks(comm, n_lower, n_upper, R: float = 0.15):
    """A punch [0.1, 0.9] × [0, 0.2] × [0, 0.25] whose bottom is rounded at x = 0.1 and 0.9 (radius R) on a
    block [0, 1] × [0, 0.2] × [−0.5, 0] (the same width: a slice of a long punch; non-matching in x)."""
    b = two_blocks(comm, lower=(1.0, 0.2, 0.5), n_lower=n_lower, upper_origin=(0.1, 0.0), upper=(0.8, 0.2, 0.25),
                   n_upper=n_upper, gap=0.0)
    return reshape(b, upper_z=fillet(R, 0.1, 0.9), top=0.25, bottom=0.0)


def punch(comm, swapped: bool, n_lower=(20, 3, 2), n_upper=(16, 3, 2), R: float = 0.15, delta: float = 0.002):
    """The filleted punch pressed ``delta`` into the block (its bottom clamped); ``swapped``: the flat block
    top is the slave, the curved punch bottom the master. Returns the normal force on the punch, the number of
    contact nodes and the smallest nodal gap."""
    b = punch_blocks(comm, n_lower, n_upper, R)
    V = dolfinx.fem.functionspace(b.mesh, ("Lagrange", 1, (3,)))
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -delta]),
                                   dolfinx.fem.locate_dofs_topological(V, 2, b.facet_tags.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3),
                                   dolfinx.fem.locate_dofs_topological(V, 2, b.facet_tags.find(LOWER_BOTTOM)), V)]
    a = elasticity(V, b.cell_tags, ((210.0, 0.3), (70.0, 0.3)))
    slave, master = (MASTER, SLAVE) if swapped else (SLAVE, MASTER)
    pair = ContactPair(b.facet_tags, slave=slave, master=master, friction=0.0, search_distance=0.05)
    # the pairing of the reference configuration (the swap compares the two pairings, not a sliding model)
    small = {"sliding": "small"} if "sliding" in inspect.signature(ContactProblem).parameters else {}
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="mpunch_",
                        **small) as p:
        pairing = p.model.pairing
        gap = comm.allreduce(float(pairing.gap.min(initial=np.inf)), op=MPI.MIN)
        _, result = p.solve()
        assert result.converged
        assert_physics(p.model, result.relative_displacement,
                       keys=("equilibrium", "penetration", "negative_pressure", "complementarity"))
        (forces,) = pair_forces(p.model, result, [pair])
        on_punch = forces["force_on_master_body" if swapped else "force_on_slave_body"][2]
        return on_punch, pairing.num_global, gap


def test_punch_with_fillet_solves_swapped():
    """Slave ↔ master swapped on the filleted punch: both solve with mortar and the normal forces on the punch
    agree within 0.5 % (measured 0.05 %, while refining both meshes 1.5 times moves the force by 2.4 %;
    docs/two-bodies/geometry.md)."""
    comm = MPI.COMM_WORLD
    f_plain, n_plain, _ = punch(comm, swapped=False)
    f_swap, n_swap, _ = punch(comm, swapped=True)
    assert n_plain > 0 and n_swap > 0
    assert f_plain > 0 and f_swap > 0  # the block pushes the punch up
    assert abs(f_swap / f_plain - 1) < 0.005, (f_plain, f_swap)


def test_negative_weighted_gap_without_overlap_is_accepted():
    """The swapped punch on a coarse block (h = 0.1 against the fillet's R = 0.15): beside the fillet the nodal
    gap g̃_j/D_j is −0.0027 (ψ_j < 0 where the fillet rises) while every node of both surfaces lies outside
    the other body: a contact node with a negative initial gap, not an overlap."""
    b = punch_blocks(MPI.COMM_WORLD, (10, 3, 2), (16, 3, 2))
    V = dolfinx.fem.functionspace(b.mesh, ("Lagrange", 1, (3,)))
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=MASTER, master=SLAVE, search_distance=0.05)], NONE)
    smallest = MPI.COMM_WORLD.allreduce(float(P.gap.min(initial=np.inf)), op=MPI.MIN)
    assert P.num_global == 28 and smallest < -2e-3


# -- pairs that do not join two bodies, overlaps ------------------------------------------------------------
@pytest.mark.parametrize("method", ["mortar", "node-to-surface"])
@pytest.mark.parametrize(("slave", "master", "match"), [
    ([MASTER], [MASTER], r"slave tag\(s\) \[1\] and master tag\(s\) \[1\] are the same surface"),
    ([MASTER, TAGS["lower_sides"]], [MASTER],
     r"slave tag\(s\) \[1, 5\] and master tag\(s\) \[1\] share 16 facet\(s\)"),
    ([SLAVE], [UPPER_TOP], r"slave tag\(s\) \[2\] and master tag\(s\) \[4\] lie on one body \(the connected part of "
                           r"the mesh through the slave node \(.*\)\)"),
    ([MASTER], [LOWER_BOTTOM], r"slave tag\(s\) \[1\] and master tag\(s\) \[3\] lie on one body"),
])
def test_pairs_within_one_body_are_refused(method, slave, master, match):
    """Slave = master, a slave containing the master, two surfaces of one block: one line naming the pair, on
    every rank (node-to-surface and mortar alike)."""
    b = two_blocks(MPI.COMM_WORLD, gap=0.01, n_upper=(2, 2, 1))
    V = dolfinx.fem.functionspace(b.mesh, ("Lagrange", 1, (3,)))
    pair = ContactPair(b.facet_tags, slave=slave, master=master, name="self", method=method)
    with pytest.raises(InputError, match=r"^contact pair 1 \('self'\): " + match + ".*two different bodies$"):
        pair_surfaces(V, [pair], NONE)


@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_mortar_overlap_is_an_interference(cell):
    """A slave surface 0.01 inside the master body is an interference for mortar as for node-to-surface: the
    fully covered slave nodes are contact nodes with the weighted gap −0.01; out of the search distance's reach it
    is refused on the true geometry (a slave node and its depth named)."""
    b = two_blocks(MPI.COMM_WORLD, cell_type=cell, gap=-0.01, n_upper=(2, 2, 1), upper_origin=(0.3, 0.3))
    V = dolfinx.fem.functionspace(b.mesh, ("Lagrange", 1, (3,)))
    P = pair_surfaces(V, [ContactPair(b.facet_tags, slave=SLAVE, master=MASTER)], NONE)
    assert P.num_global == 9 and np.allclose(P.gap, -0.01, rtol=1e-9, atol=0)
    with pytest.raises(InputError, match=r"beyond the search distance: slave node .* lies 0\.01 inside the master"):
        pair_surfaces(V, [ContactPair(b.facet_tags, slave=SLAVE, master=MASTER, search_distance=0.005)], NONE)


def test_master_node_inside_the_slave_body_rejected():
    """A narrow bump of the master (fine lower mesh) poking 0.02 into a coarse slave block between its nodes:
    no slave node overlaps, the master node at the bump's tip does (named)."""
    b = two_blocks(MPI.COMM_WORLD, n_lower=(8, 8, 2), upper_origin=(0.25, 0.25), upper=(0.5, 0.5, 0.25),
                   n_upper=(2, 2, 1), gap=0.01)
    reshape(b, lower_z=lambda x, y: 0.03 * (np.isclose(x, 0.375) & np.isclose(y, 0.375)))
    V = dolfinx.fem.functionspace(b.mesh, ("Lagrange", 1, (3,)))
    with pytest.raises(InputError, match=r"master node \(0\.375, 0\.375, 0\.03\) lies 0\.02 inside the slave body"):
        pair_surfaces(V, [ContactPair(b.facet_tags, slave=SLAVE, master=MASTER)], NONE)
