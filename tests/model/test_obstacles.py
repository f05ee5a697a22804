"""Rigid obstacles (issue 13): geometry oracles, frames, selection, overlap and input checks, and the SCD
method in per-node frames checked against the paper's iteration on the explicitly rotated problem."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
import scipy.sparse as sp
from frame_scd import block_diagonal, frame_direction, paper_direction

from fenics_coulomb.scd.derivatives import s_blocks, sstar_blocks
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.obstacle_checks import check_not_overlapping
from fenics_coulomb.model.obstacles import (
    DEFAULT_PLANE,
    Cylinder,
    Plane,
    Sphere,
    closest_obstacle,
    obstacle_from_dict,
    obstacles_from_list,
)
from fenics_coulomb.model.frames import frames_from_normals, local_shift, to_global, to_local
from fenics_coulomb.scd.resolvent import SET_L, SET_M1, SET_M3M, SET_M3P, classify, resolvent

pytestmark = pytest.mark.serial

RNG = np.random.default_rng(20261123)


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_units(m, rng=RNG):
    return unit(rng.normal(size=(m, 3)))


def perpendicular_units(a, m, rng=RNG):
    """m random unit vectors ⊥ the unit vector a."""
    v = rng.normal(size=(m, 3))
    v -= (v @ a)[:, None] * a
    return unit(v)


def random_rotations(m, rng=RNG):
    q, r = np.linalg.qr(rng.normal(size=(m, 3, 3)))
    q = q * np.sign(np.diagonal(r, axis1=1, axis2=2))[:, None, :]
    q[np.linalg.det(q) < 0, :, 0] *= -1.0
    return q


def assert_frames(R, n):
    """Orthonormal, right-handed frames whose third column is n."""
    eye = np.broadcast_to(np.eye(3), R.shape)
    assert np.allclose(np.einsum("iab,iac->ibc", R, R), eye, atol=1e-14)
    assert np.allclose(np.linalg.det(R), 1.0, atol=1e-14)
    assert np.allclose(np.cross(R[:, :, 0], R[:, :, 1]), R[:, :, 2], atol=1e-14)
    assert np.array_equal(R[:, :, 2], n)
    assert np.all(np.isfinite(R))


# -- geometry oracles -------------------------------------------------------------------------------------
def test_plane_distances_normals_and_placement():
    nu = unit([1.0, 2.0, 2.0])
    p, delta = np.array([0.3, -0.2, 0.5]), np.array([0.01, 0.02, -0.03])
    plane = Plane(point=p, normal=3.7 * nu, displacement=delta, name="ramp")
    assert np.allclose(plane.normal, nu, atol=1e-15) and plane.placed == pytest.approx(tuple(p + delta))
    h = RNG.uniform(-1, 1, 50)
    foot = p + delta + 2.0 * RNG.normal(size=(50, 3))
    foot -= ((foot - p - delta) @ nu)[:, None] * nu  # points on the placed plane
    x = foot + h[:, None] * nu
    g, n, R = plane.evaluate(x)
    assert np.allclose(g, h, atol=1e-13) and np.allclose(n, nu)
    assert np.allclose(plane.signed_distance(x), g) and np.array_equal(plane.normals(x), n)
    assert np.allclose(plane.closest_point(x), foot, atol=1e-13)
    assert_frames(R, n)
    assert np.allclose(R, R[0])  # one frame for the whole plane
    # δ translates the obstacle: g(x; δ) = g(x − δ; 0)
    assert np.allclose(plane.at_scene_position().signed_distance(x - delta), g, atol=1e-14)
    # placing is exact and reversible: the normal is not re-rounded
    assert plane.at_scene_position().moved(delta) == plane and plane.moved(delta).placed == plane.placed


def test_sphere_distances_normals_and_placement():
    c, delta, radius = np.array([1.0, 0.5, -0.5]), np.array([0.002, 0.0, 0.01]), 0.5
    sphere = Sphere(center=c, radius=radius, displacement=delta)
    assert sphere.placed == pytest.approx(tuple(c + delta))
    direction = random_units(60)
    h = RNG.uniform(-0.45, 1.0, 60)
    x = c + delta + (radius + h)[:, None] * direction
    g, n, R = sphere.evaluate(x)
    assert np.allclose(g, h, atol=1e-13) and np.allclose(n, direction, atol=1e-13)
    assert np.allclose(sphere.closest_point(x), c + delta + radius * direction, atol=1e-13)
    assert_frames(R, n)
    assert np.allclose(sphere.moved([0, 0, 0]).signed_distance(x - delta), g, atol=1e-14)


def test_cylinder_distances_normals_tangents_and_placement():
    p, a, radius = np.array([0.0, 0.0, -0.3]), unit([0.2, 1.0, 0.1]), 0.3
    delta = np.array([0.01, -0.02, 0.005])
    cyl = Cylinder(point=p, axis=-2.0 * a, radius=radius, displacement=delta, name="roller")
    assert np.allclose(cyl.axis, -a, atol=1e-15)
    radial = perpendicular_units(a, 40)
    h = RNG.uniform(-0.25, 1.0, 40)
    along = RNG.uniform(-5, 5, 40)
    x = p + delta + along[:, None] * a + (radius + h)[:, None] * radial
    g, n, R = cyl.evaluate(x)
    assert np.allclose(g, h, atol=1e-13) and np.allclose(n, radial, atol=1e-13)
    assert_frames(R, n)
    assert np.allclose(R[:, :, 0], -a)  # t₁ = the axis: continuous along and around the cylinder
    assert np.allclose(cyl.at_scene_position().signed_distance(x - delta), g, atol=1e-14)


def test_default_plane_is_the_papers_obstacle():
    """The plane x3 = 0 with normal e₃: g = x3 and the identity frame, exactly (today's results unchanged)."""
    x = RNG.uniform(-1, 2, size=(30, 3))
    g, _, R = DEFAULT_PLANE.evaluate(x)
    assert np.array_equal(g, x[:, 2])
    assert np.array_equal(R, np.broadcast_to(np.eye(3), R.shape))
    index, g2, _, R2 = closest_obstacle([DEFAULT_PLANE], x)
    assert np.array_equal(index, np.zeros(30)) and np.array_equal(g2, g) and np.array_equal(R2, R)


def test_tangent_rule_plane_and_sphere():
    """t₁ is the projection of e₁ (of e₂ where |n·e₁| > 1/√2): continuous in each region, well conditioned."""
    n = random_units(2000)
    R = frames_from_normals(n)
    assert_frames(R, n)
    first = np.abs(n[:, 0]) <= 1 / np.sqrt(2)
    for mask, axis in ((first, 0), (~first, 1)):
        ref = np.eye(3)[axis]
        expected = unit(ref - np.outer(n[mask] @ ref, np.ones(3)) * n[mask])
        assert np.allclose(R[mask, :, 0], expected, atol=1e-14)
    # continuity: a smooth path of normals inside one region gives a smooth tangent
    s = np.linspace(0, 1, 401)
    path = unit(np.stack([0.3 * np.sin(3 * s), 0.6 * s - 0.3, np.ones_like(s)], axis=1))
    t = frames_from_normals(path)[:, :, 0]
    step = np.linalg.norm(np.diff(path, axis=0), axis=1).max()
    assert np.linalg.norm(np.diff(t, axis=0), axis=1).max() < 5 * step


def test_degenerate_points_have_a_documented_frame():
    sphere = Sphere(center=[0.1, 0.2, 0.3], radius=0.2, displacement=[0.0, 0.0, 0.1])
    g, n, R = sphere.evaluate(np.array([[0.1, 0.2, 0.4]]))
    assert g[0] == -0.2 and np.array_equal(n[0], [0.0, 0.0, 1.0])
    assert_frames(R, n)
    for axis, expected in (([0, 1, 0], [0, 0, 1]), ([0, 0, 1], [1, 0, 0]), ([1, 1, 1], unit([-1, -1, 2]))):
        cyl = Cylinder(point=[1.0, 1.0, 1.0], axis=axis, radius=0.5)
        x = np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0] + 2.0 * unit(axis)])
        g, n, R = cyl.evaluate(x)
        assert np.allclose(g, -0.5) and np.allclose(n, expected, atol=1e-15)
        assert_frames(R, n)


def test_several_obstacles_each_node_takes_the_closest():
    plane = Plane(point=[0, 0, 0], normal=[0, 0, 1])
    sphere = Sphere(center=[0.5, 0.5, -0.2], radius=0.25, name="ball")
    cyl = Cylinder(point=[1.5, 0, -0.1], axis=[0, 1, 0], radius=0.15)
    x = np.column_stack([RNG.uniform(0, 2, 300), RNG.uniform(0, 1, 300), RNG.uniform(0.0, 0.2, 300)])
    obstacles = [plane, sphere, cyl]
    index, g, n, R = closest_obstacle(obstacles, x)
    each = [o.evaluate(x) for o in obstacles]
    gaps = np.stack([e[0] for e in each])
    assert np.array_equal(g, gaps.min(axis=0))
    assert set(np.unique(index)) == {0, 1, 2}
    for k in range(3):
        sel = index == k
        assert np.all(gaps[k, sel] <= gaps[:, sel].min(axis=0))
        assert np.array_equal(n[sel], each[k][1][sel]) and np.array_equal(R[sel], each[k][2][sel])
    # ties go to the first obstacle
    twin = Plane(point=[0, 0, 0], normal=[0, 0, 2], name="twin")
    index, *_ = closest_obstacle([plane, twin], x)
    assert np.all(index == 0)
    index, *_ = closest_obstacle([twin, plane], x)
    assert np.all(index == 0)
    with pytest.raises(ValueError):
        closest_obstacle([], x)


# -- overlap --------------------------------------------------------------------------------------------
def test_overlap_at_the_scene_position_is_bad_input_naming_the_deepest_node():
    x = np.array([[0.0, 0.0, 0.01], [0.5, 0.5, 0.02], [1.0, 0.2, 0.05]])
    ball = Sphere(center=[0.5, 0.5, -0.3], radius=0.35, name="indenter")  # node 1 is 0.03 inside
    with pytest.raises(InputError) as err:
        check_not_overlapping([DEFAULT_PLANE, ball], x)
    msg = str(err.value)
    assert "\n" not in msg and "indenter" in msg and "0.5, 0.5, 0.02" in msg and "0.03" in msg
    # an overlap caused by the displacement δ is an indentation: valid
    pressed = Sphere(center=[0.5, 0.5, -0.4], radius=0.35, displacement=[0, 0, 0.1], name="indenter")
    assert pressed.signed_distance(x).min() < 0
    check_not_overlapping([DEFAULT_PLANE, pressed], x)
    # the deepest of several overlapping obstacles is named; round-off below the tolerance is accepted
    tilted = Plane(point=[0, 0, 0.049], normal=[0, 0, 1], name="floor")
    with pytest.raises(InputError, match=r"obstacle 2 \(plane 'floor'\).*node \(0, 0, 0.01\) lies 0.039 inside"):
        check_not_overlapping([ball, tilted], x)
    check_not_overlapping([Plane(point=[0, 0, 0.01 + 1e-15], normal=[0, 0, 1])], x)
    with pytest.raises(InputError):
        check_not_overlapping([Plane(point=[0, 0, 0.01 + 1e-9], normal=[0, 0, 1])], x)
    check_not_overlapping([Plane(point=[0, 0, 0.01 + 1e-9], normal=[0, 0, 1])], x, tol=1e-8)


# -- input ------------------------------------------------------------------------------------------------
SCENE = """
[[obstacle]]
name = "indenter"           # optional
type = "sphere"             # plane | sphere | cylinder
center = [1.0, 0.5, -0.5]
radius = 0.5
displacement = [0.002, 0.0, 0.01]   # rigid translation, default [0, 0, 0]

[[obstacle]]
type = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.01, -0.005, 1.0]

[[obstacle]]
type = "cylinder"
point = [0, 0, -1]
axis = [0, 3, 0]
radius = 1
"""


def test_scene_tables_parse_into_obstacles():
    obstacles = obstacles_from_list(tomllib.loads(SCENE)["obstacle"])
    assert obstacles == [
        Sphere(center=(1.0, 0.5, -0.5), radius=0.5, displacement=(0.002, 0.0, 0.01), name="indenter"),
        Plane(point=(0.0, 0.0, 0.0), normal=(0.01, -0.005, 1.0)),
        Cylinder(point=(0.0, 0.0, -1.0), axis=(0.0, 1.0, 0.0), radius=1.0),
    ]
    assert np.linalg.norm(obstacles[1].normal) == pytest.approx(1.0, abs=1e-15)
    assert all(isinstance(c, float) for c in obstacles[2].point) and isinstance(obstacles[2].radius, float)
    hash(obstacles[0])  # frozen


BAD_TABLES = [
    ({"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 0]}, "normal = [0, 0, 0]"),
    ({"type": "cylinder", "point": [0, 0, 0], "axis": [0.0, 0.0, 0.0], "radius": 1}, "axis = [0.0, 0.0, 0.0]"),
    ({"type": "sphere", "center": [0, 0, 0], "radius": -0.5}, "radius = -0.5"),
    ({"type": "sphere", "center": [0, 0, 0], "radius": 0}, "radius = 0"),
    ({"type": "sphere", "center": [0, 0, 0], "radius": "1"}, "radius = '1'"),
    ({"type": "sphere", "center": [0, 0, 0], "radius": True}, "radius = True"),
    ({"type": "sphere", "center": [0, 0, 0], "radius": float("nan")}, "radius = nan"),
    ({"type": "sphere", "center": [0, 0], "radius": 1}, "center = [0, 0]"),
    ({"type": "sphere", "center": [0, 0, "x"], "radius": 1}, "center = [0, 0, 'x']"),
    ({"type": "plane", "point": [0, 0, 0], "normal": [0, 0, float("inf")]}, "normal = [0, 0, inf]"),
    ({"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "displacement": [0, 1]}, "displacement = [0, 1]"),
    ({"type": "cone", "point": [0, 0, 0]}, "type = 'cone'"),
    ({"type": 3}, "type = 3"),
    ({"point": [0, 0, 0], "normal": [0, 0, 1]}, "missing type"),
    ({"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "radius": 1}, "unknown key 'radius'"),
    ({"type": "plane", "point": [0, 0, 0]}, "needs normal"),
    ({"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "name": 7}, "name = 7"),
    ({"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "name": ""}, "name = ''"),
]


@pytest.mark.parametrize(("table", "fragment"), BAD_TABLES)
def test_bad_obstacle_tables_are_one_line_input_errors(table, fragment):
    with pytest.raises(InputError) as err:
        obstacle_from_dict(table, 2)
    msg = str(err.value)
    assert fragment in msg and msg.startswith("[[obstacle]] 2") and "\n" not in msg


def test_bad_constructor_arguments_name_the_value():
    with pytest.raises(InputError, match=r"plane 'floor': normal = \[0, 0, 0\]"):
        Plane(point=[0, 0, 0], normal=[0, 0, 0], name="floor")
    with pytest.raises(InputError, match=r"sphere: radius = -1"):
        Sphere(center=[0, 0, 0], radius=-1)
    with pytest.raises(InputError, match=r"cylinder: radius = 0"):
        Cylinder(point=[0, 0, 0], axis=[1, 0, 0], radius=0)
    with pytest.raises(InputError, match="displacement"):
        Sphere(center=[0, 0, 0], radius=1).moved([0, np.nan, 0])
    with pytest.raises(InputError, match="obstacles 1 and 2 are both called 'a'"):
        obstacles_from_list([{"type": "sphere", "center": [0, 0, 0], "radius": 1, "name": "a"},
                             {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "name": "a"}])
    # an unnamed obstacle's output name ("sphere 1") taken by a named one: summary.json kept one of the two
    with pytest.raises(InputError, match="obstacles 1 and 2 are both called 'sphere 1'"):
        obstacles_from_list([{"type": "sphere", "center": [0, 0, 0], "radius": 1},
                             {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "name": "sphere 1"}])
    with pytest.raises(InputError, match="array of tables"):
        obstacles_from_list({"type": "plane"})
    # tiny (but non-zero) vectors are directions
    assert Plane(point=[0, 0, 0], normal=[0, 0, 1e-300]).normal == (0.0, 0.0, 1.0)


# -- the SCD method in per-node frames (the derivation of the module docstring) ---------------------------
def local_graph_point(kind, F, rng):
    """A point (v, z) of gph Q̃ strictly inside one set of (6.9): 'slide', 'stick' or 'open'."""
    if kind == "open":
        return np.array([rng.normal(), rng.normal(), rng.uniform(0.1, 1)]), np.zeros(3)
    theta = -rng.uniform(0.2, 2.0)
    if kind == "stick":
        g = F * -theta * rng.uniform(0.1, 0.8) * unit(rng.normal(size=2))
        return np.zeros(3), np.array([g[0], g[1], theta])
    v12 = rng.uniform(0.2, 2.0) * unit(rng.normal(size=2))
    g = -F * theta * v12 / np.linalg.norm(v12)
    return np.array([v12[0], v12[1], 0.0]), np.array([g[0], g[1], theta])


def projector(basis):
    q, _ = np.linalg.qr(basis)
    return q @ q.T


def adjoint_space(basis):
    """L* = {(−v*, u*) | (u*, v*) ∈ L^⊥} of (3.1), for L = rge(basis) ⊂ R³ × R³."""
    _, _, vt = np.linalg.svd(basis.T)
    perp = vt[3:].T
    return np.vstack([-perp[3:], perp[:3]])


@pytest.mark.parametrize("kind", ["slide", "stick", "open"])
def test_rotated_derivative_blocks_span_the_cartesian_graph(kind):
    """The Cartesian contact map Qᵢ(ũ) = R Q̃(Rᵀũ + s): its resolvent w ↦ R(J̃(Rᵀw + γs) − s) traces gph Qᵢ;
    finite differences of it span rge(R X, R Y) (SQ) and their adjoint rge(R W*, R U*) (S*Q)."""
    rng = np.random.default_rng(7)
    gamma, F = 1.7, 0.4
    for R in random_rotations(10, rng):
        s = np.array([rng.normal(), rng.normal(), rng.uniform(0, 1)])
        v, z = local_graph_point(kind, F, rng)
        # the Cartesian graph point: ũ = R(v − s), z̃ = R z, reached by the Cartesian resolvent from w = γũ + z̃
        u_cart, z_cart = R @ (v - s), R @ z
        w0 = gamma * u_cart + z_cart

        def cartesian_resolvent(w, R=R, s=s):
            vv, _ = resolvent((R.T @ w + gamma * s)[None, :], gamma, F)
            return R @ (vv[0] - s)

        assert np.allclose(cartesian_resolvent(w0), u_cart, atol=1e-12)
        h = 1e-6
        D = np.column_stack([(cartesian_resolvent(w0 + h * e) - cartesian_resolvent(w0 - h * e)) / (2 * h)
                             for e in np.eye(3)])
        tangent = np.vstack([D, np.eye(3) - gamma * D])  # columns (dũ, dz̃) = (D dw, dw − γ D dw)
        sets = classify(v[None], z[None], F)
        assert sets[0] == {"slide": SET_M1, "stick": SET_M3P, "open": SET_L}[kind]
        X, Y = s_blocks(v[None], z[None], sets, F)
        W, U = sstar_blocks(v[None], z[None], sets, F)
        rotated = np.vstack([R @ X[0], R @ Y[0]])
        assert np.linalg.norm(projector(rotated) - projector(tangent)) < 1e-7
        rotated_adjoint = np.vstack([R @ W[0], R @ U[0]])
        assert np.linalg.norm(projector(rotated_adjoint) - projector(adjoint_space(tangent))) < 1e-7


def random_problem(rng, nodes=12, m=7):
    """A random sparse SPD 'stiffness' on nodes×3 DOFs, a load, m contact nodes with frames and shifts."""
    G = sp.random(3 * nodes, 3 * nodes, density=0.3, random_state=rng) + sp.eye(3 * nodes)
    A = (G @ G.T + 0.5 * sp.eye(3 * nodes)).tocsr()
    load = rng.normal(size=3 * nodes)
    contact = np.sort(rng.choice(nodes, m, replace=False))
    R = random_rotations(m, rng)
    g = rng.uniform(0.0, 0.5, m)
    offset = 0.3 * rng.normal(size=(m, 3))
    return A, load, contact, R, local_shift(R, g, offset)


@pytest.mark.parametrize("variant", ["4a", "4b"])
def test_newton_step_in_frames_equals_the_papers_step_on_the_rotated_problem(variant):
    """Approximation and Newton step in Cartesian variables (rows Bⁱ → BⁱRᵢᵀ, Cⁱ → CⁱRᵢᵀ, shift d = 𝓡s) give
    𝓡 times the paper's step on (Â, l̂) = (𝓡ᵀA𝓡, 𝓡ᵀ(l̃ + A𝓡s)), from random states covering all sets."""
    rng = np.random.default_rng(11)
    seen = set()
    for _ in range(25):
        A, load, contact, R, s = random_problem(rng)
        nodes = A.shape[0] // 3
        cd = 3 * contact[:, None] + np.arange(3)
        F, gamma = 0.3, float(rng.uniform(0.5, 5.0))
        Rfull = np.broadcast_to(np.eye(3), (nodes, 3, 3)).copy()
        Rfull[contact] = R
        Rm = block_diagonal(Rfull)
        sfull = np.zeros(3 * nodes)
        sfull[cd] = s
        A_hat = (Rm.T @ A @ Rm).tocsr()
        l_hat = Rm.T @ (load + A @ (Rm @ sfull))
        u_phys = 0.5 * rng.normal(size=3 * nodes)
        u_hat = Rm.T @ u_phys + sfull
        du_hat, e_hat, v_hat, z_hat, sets = paper_direction(A_hat, l_hat, u_hat, contact, gamma, F, variant)
        # Cartesian: u = ũ + d with d = 𝓡 s, l = l̃ + A d
        d = Rm @ sfull
        assert np.allclose(d[cd], to_global(R, s))
        du, e, v, z, sets_c = frame_direction(A, load + A @ d, u_phys + d, contact, R, gamma, F, variant)
        assert np.array_equal(sets, sets_c)
        assert np.allclose(v, v_hat, atol=1e-12) and np.allclose(z, z_hat, atol=1e-12)
        assert np.allclose(e, Rm @ e_hat, atol=1e-12)
        assert np.linalg.norm(du - Rm @ du_hat) <= 1e-10 * np.linalg.norm(du_hat)
        seen.update(sets.tolist())
    assert {SET_L, SET_M1} <= seen and (SET_M3P in seen or SET_M3M in seen)


def test_local_shift_is_the_slip_of_a_moved_obstacle():
    """v = Rᵀũ + s has v₃ = g + n·ũ and v₁₂ = T(ũ − o)."""
    m = 20
    R = random_rotations(m)
    g = RNG.uniform(-0.1, 0.3, m)
    o = RNG.normal(size=(m, 3))
    u = RNG.normal(size=(m, 3))
    v = to_local(R, u) + local_shift(R, g, o)
    assert np.allclose(v[:, 2], g + np.einsum("ia,ia->i", R[:, :, 2], u))
    for k in range(2):
        assert np.allclose(v[:, k], np.einsum("ia,ia->i", R[:, :, k], u - o))
    assert np.allclose(to_global(R, to_local(R, u)), u)
    assert np.array_equal(local_shift(R, g)[:, :2], np.zeros((m, 2)))


# -- the motion check's samples ------------------------------------------------------------------------------
def test_motion_placements_start_and_end_at_the_two_placements():
    from fenics_coulomb.model.obstacle_checks import motion_placements

    before = Sphere(center=(1.0, 0.5, 1.5), radius=0.3, displacement=(0.1, 0.0, 0.0))
    cases = [  # one axis and centre (blended angle), none before, and two different axes (relative rotation)
        (before.rotated([10.0, [0, 1, 0], [1, 0.5, 0.5]]),
         before.moved([0.2, 0.0, -0.1]).rotated([70.0, [0, 1, 0], [1, 0.5, 0.5]])),
        (before, before.rotated([-30.0, [1, 0, 0], [0, 0, 0]])),
        (before.rotated([20.0, [0, 0, 1], [0, 0, 0]]),
         before.moved([0.0, 0.3, 0.0]).rotated([45.0, [1, 1, 0], [1, 0, 0]])),
    ]
    for a, b in cases:
        placements, angle, _, _, _ = motion_placements(a, b)
        R, c = placements(np.array([0.0, 0.5, 1.0]))
        for k, obstacle in ((0, a), (2, b)):
            Rk, ck = obstacle.placement()
            assert np.allclose(R[k], Rk, atol=1e-13) and np.allclose(c[k], ck, atol=1e-13)
        assert np.allclose(np.einsum("nij,nkj->nik", R, R), np.eye(3), atol=1e-13)  # rotations throughout
        assert angle > 0.0


def test_core_path_finds_a_long_move_and_a_half_turn_through_the_box():
    """A sphere's centre moved 2000 across the unit box, or turned half a turn about a point inside it: a sample
    lands in the box (the old sampling stepped over it), and a far move costs no more samples than a short one."""
    from fenics_coulomb.model.obstacle_checks import core_path

    lo, hi, spacing = np.zeros(3), np.ones(3), 0.05
    ball = Sphere(center=(0.5, 0.5, 1000.0), radius=0.1)
    points, t = core_path(ball, ball.moved([0.0, 0.0, -2000.0]), lo, hi, spacing)
    inside = np.all((points >= lo) & (points <= hi), axis=1)
    assert inside.any() and points.shape[0] < 2000
    gaps = np.diff(np.sort(points[np.abs(points[:, 2] - 0.5) < 2.0, 2]))
    assert gaps.max() <= spacing * (1 + 1e-9)
    above = Sphere(center=(0.5, 0.5, 1.1), radius=0.1)  # turned about the box's centre: inside for 33.6-56.4 and
    points, t = core_path(above, above.rotated([180.0, [0, 1, 0], [0.5, 0.5, 0.5]]), lo, hi, spacing)  # 123.6-146.4°
    inside = np.all((points >= lo) & (points <= hi), axis=1)
    angle = 180.0 * t[inside]
    assert inside.any() and np.all((np.abs(angle - 45.0) <= 11.5) | (np.abs(angle - 135.0) <= 11.5))
    assert np.allclose(points[-1], [0.5, 0.5, -0.1])  # the end placement: below the box
    steady, _ = core_path(above, above, lo, hi, spacing)
    assert np.allclose(steady, [[0.5, 0.5, 1.1]] * 2)


def test_inside_closed_is_the_ball_away_from_its_facets(tmp_path):

    from meshes.surfaces import icosphere

    from fenics_coulomb.model.surface import inside_closed

    X = icosphere(0.5, (1.0, 0.5, 1.5), level=3)
    rng = np.random.default_rng(5)
    x = rng.uniform([0.4, -0.1, 0.9], [1.6, 1.1, 2.1], size=(3000, 3))
    r = np.linalg.norm(x - [1.0, 0.5, 1.5], axis=1)
    clear = np.abs(r - 0.5) > 0.01  # the level-3 facets lie within 0.005 of the sphere
    assert np.array_equal(inside_closed(X, x[clear]), r[clear] < 0.5)


@pytest.mark.parametrize("resolution", [-1e-9, float("nan"), float("inf"), "1e-9", None, True])
def test_a_bad_resolution_names_the_value(resolution):
    """Obstacle.evaluate's ``resolution`` (a configuration's own error, within which a triangulated surface ties
    its facets): a finite length >= 0, else a one-line InputError naming the obstacle and the value."""
    from fenics_coulomb import Sphere

    with pytest.raises(InputError, match=r"^sphere 'ball': resolution = .*: must be a finite length >= 0$"):
        Sphere(center=(0.0, 0.0, 1.0), radius=0.5, name="ball").evaluate([[0.0, 0.0, 0.4]], resolution)

