"""The independent Alart–Curnier solver (brute_force.py): its own physics, agreement with the SCD solver on
the paper's plane problem, and with the SCD method in per-node frames for tilted, moved and curved obstacles."""

from __future__ import annotations

import dataclasses

from mpi4py import MPI

import numpy as np
import pytest
import scipy.sparse as sp
from brute_force import scipy_matrix, solve_contact
from conftest import assembled, make_problem
from frame_scd import solve_in_frames

from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.model.obstacles import DEFAULT_PLANE, Plane, Sphere, closest_obstacle
from fenics_coulomb.model.frames import local_shift, to_global
from fenics_coulomb.scd.resolvent import OPEN, SLIP, STICK, classify, contact_states

pytestmark = pytest.mark.serial

#: The SCD solver run to round-off: LU, forcing 1e-13, reduction 1e-12.
EXACT = {"rtol": 1e-12, "pc": "lu", "tol": 1e-13}


@pytest.fixture(scope="module")
def lev1():
    """The d3/L2 cuboid at lev 1 (336 unknowns) on this rank alone: K, l̃, contact DOFs and coordinates."""
    with make_problem(1, "d3", "L2", comm=MPI.COMM_SELF) as problem:
        return assembled(problem)


def physics(K, f, cdofs, R, g, shifts, F, sol):
    """Residuals of the discrete conditions, each relative to its scale."""
    force = np.einsum("iab,ib->ia", R, sol.force)  # Cartesian force on the body
    fc = np.zeros_like(f)
    fc[cdofs] = force
    lam, pt = sol.force[:, 2], sol.force[:, :2]
    w = np.einsum("iab,ia->ib", R, sol.u[cdofs])
    gn, s = g + w[:, 2], w[:, :2] + shifts
    scale_f, scale_u = np.linalg.norm(f), np.abs(sol.u).max()
    npt, ns = np.linalg.norm(pt, axis=1), np.linalg.norm(s, axis=1)
    sliding = ns > 1e-9 * scale_u
    return {
        "equilibrium": np.linalg.norm(K @ sol.u - f - fc) / scale_f,
        "kinematics": max(np.abs(gn - sol.gap).max(), np.abs(s - sol.slip).max()) / scale_u,
        "penetration": max(-gn.min(), 0.0) / scale_u,
        "pressure": max(-lam.min(), 0.0) / lam.max(),
        "complementarity": np.abs(lam * gn).max() / (lam.max() * scale_u),
        "cone": max((npt - F * lam).max(), 0.0) / lam.max(),
        "slip_direction": np.abs(pt[sliding] + (F * lam)[sliding, None] * s[sliding] / ns[sliding, None]).max()
        / lam.max() if np.any(sliding) else 0.0,
        "sliding": int(np.sum(sliding & (lam > 0))), "contact": int(np.sum(lam > 0)),
    }


@pytest.mark.parametrize("friction", [0.0, 0.23])
def test_agrees_with_the_scd_solver_on_the_papers_plane(friction):
    """Lev 1 and 2 of d3/L2: the SCD solver (LU, 1e-12) and the Alart–Curnier solver on the same assembled
    matrices, with the default plane's frames and gaps from fenics_coulomb.model.obstacles, agree to 1e-7."""
    for lev in (1, 2):
        with make_problem(lev, "d3", "L2", comm=MPI.COMM_SELF, friction=friction, rtol=1e-12, pc="lu",
                          tol=1e-13) as problem:
            _, result = problem.solve()  # from the paper's start u = 0 of the shifted unknown
            data = assembled(problem)
        assert result.converged
        K, f, cdofs = data["K"], data["load"], data["cdofs"]
        _, g, _, R = closest_obstacle([DEFAULT_PLANE], data["x"])
        assert np.array_equal(g, data["gap"]) and np.array_equal(R, np.broadcast_to(np.eye(3), R.shape))
        sol = solve_contact(K, f, cdofs, g, friction, frames=R)
        u = result.displacement
        assert np.linalg.norm(sol.u - u) <= 1e-7 * np.linalg.norm(u)
        lam = sol.force[:, 2]
        assert np.abs(lam - result.normal_force).max() <= 1e-7 * lam.max()
        assert np.abs(sol.force[:, :2] - result.tangential_force).max() <= 1e-7 * lam.max()
        checks = physics(K, f, cdofs, R, g, np.zeros((len(g), 2)), friction, sol)
        for key in ("equilibrium", "kinematics", "penetration", "pressure", "complementarity", "cone"):
            assert checks[key] < 1e-10, (key, checks[key])
        assert checks["slip_direction"] < 1e-6
        assert checks["sliding"] > 0


def obstacle_scene(lev1, which):
    """Frames, gaps and tangential shifts of the lev-1 bottom nodes for a tilted plane dragged sideways, or a
    large sphere moved up into the body and sideways (displacement-controlled indentation) beside a floor."""
    x = lev1["x"]
    if which == "tilted":
        obstacles = [Plane(point=[0.0, 0.0, -0.004], normal=[0.01, -0.005, 1.0], displacement=[0.002, -0.001, 0.0])]
    else:
        obstacles = [Sphere(center=[1.0, 0.5, -10.0], radius=10.0, displacement=[0.002, 0.001, 0.012]),
                     Plane(point=[0.0, 0.0, -0.01], normal=[0.0, 0.0, 1.0], name="floor")]
    index, g, _, R = closest_obstacle(obstacles, x)
    delta = np.array([o.displacement for o in obstacles])[index]
    s = local_shift(R, g, delta)
    return index, g, R, s


@pytest.mark.parametrize("which", ["tilted", "sphere"])
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_frames_scd_iteration_agrees_with_brute_force(lev1, which, friction):
    """The SCD method in per-node frames (the derivation of fenics_coulomb.model.obstacles, both variants) and the
    Alart–Curnier solver, on the assembled lev-1 matrices with a tilted moved plane or an indenting sphere
    beside a floor, reach the same displacement (1e-7) and forces; the solution obeys the physics."""
    K, f, cdofs = lev1["K"], lev1["load"], lev1["cdofs"]
    index, g, R, s = obstacle_scene(lev1, which)
    if which == "sphere":
        assert np.any(g < 0) and set(np.unique(index)) == {0, 1}  # the sphere indents; the floor holds some
    sol = solve_contact(K, f, cdofs, g, friction, frames=R, shifts=s[:, :2])
    checks = physics(K, f, cdofs, R, g, s[:, :2], friction, sol)
    for key in ("equilibrium", "kinematics", "penetration", "pressure", "complementarity", "cone"):
        assert checks[key] < 1e-10, (key, checks[key])
    assert checks["slip_direction"] < 1e-6 and checks["contact"] > 0
    if friction > 0:
        assert checks["sliding"] > 0
    nodes = cdofs[:, 0] // 3
    for variant in ("4a", "4b"):
        u, v, z, _ = solve_in_frames(K, f, nodes, R, s, friction, variant=variant)
        states = contact_states(classify(v, z, friction), friction)
        touching = states != OPEN
        if which == "sphere":  # both obstacles carry the body
            assert set(np.unique(index[touching])) == {0, 1}
        if friction > 0:  # sticking and sliding nodes
            assert np.any(states == STICK) and np.any(states == SLIP)
        assert np.linalg.norm(u - sol.u) <= 1e-7 * np.linalg.norm(sol.u), variant
        assert np.abs(-z - sol.force).max() <= 1e-7 * sol.force[:, 2].max()
        assert np.allclose(v[:, 2], sol.gap, atol=1e-9 * np.abs(sol.u).max())


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_real_solver_sphere_indentation_agrees_with_brute_force(lev1, friction):
    """ContactProblem(obstacles=[Sphere moved into the body and sideways, floor plane]) at lev 1: the real
    SCD solver (its own frames, shift and rows) and the Alart–Curnier solver on the problem's assembled matrices,
    with frames, gaps and shifts computed here, agree to 1e-7 in the displacement and the Cartesian contact
    forces; both obstacles carry the body, the indentation overlaps, and the physics checks hold in the frames."""
    obstacles = [Sphere(center=[1.0, 0.5, -10.0], radius=10.0, displacement=[0.002, 0.001, 0.012]),
                 Plane(point=[0.0, 0.0, -0.01], normal=[0.0, 0.0, 1.0], name="floor")]
    for variant in ("4a", "4b"):
        # the reference-configuration model the brute force shares (finite sliding: test_finite_sliding*.py)
        scene = Scene().override(lev=1, gap="d3", load="L2", friction=friction, variant=variant, sliding="small",
                                 **EXACT)
        scene = dataclasses.replace(scene, obstacles=list(obstacles))
        with make_problem(scene=scene, comm=MPI.COMM_SELF) as problem:
            model = problem.model
            _, result = problem.solve()
            assert result.converged
            K, f, cdofs = scipy_matrix(model.A), model.load.getArray(readonly=True).copy(), model.contact.local_dofs
            index, g, _, R = closest_obstacle(obstacles, model.contact.coordinates)
            assert np.any(g < 0.0)  # the sphere's displacement indents the body
            s = local_shift(R, g, np.array([o.displacement for o in obstacles])[index])
            sol = solve_contact(K, f, cdofs, g, friction, frames=R, shifts=s[:, :2])
            checks = physics_residuals(model, result.displacement)
        u = result.displacement
        assert np.linalg.norm(sol.u - u) <= 1e-7 * np.linalg.norm(u), variant
        force = to_global(R, sol.force)
        assert np.abs(force - result.contact_force).max() <= 1e-7 * sol.force[:, 2].max(), variant
        touching = sol.force[:, 2] > 1e-9 * sol.force[:, 2].max()
        assert set(np.unique(index[touching])) == {0, 1}
        for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone",
                    "slip_direction"):
            assert checks[key] < 1e-8, (variant, key, checks[key])
        assert checks["reaction_balance"] < 1e-8


def test_per_node_friction_and_dirichlet_input(lev1):
    """Friction per node (two coefficients on the two halves) obeys each node's cone; equal coefficients per node
    equal the scalar; a prescribed displacement through ``dirichlet`` is honoured."""
    K, f, cdofs, x = lev1["K"], lev1["load"], lev1["cdofs"], lev1["x"]
    g = lev1["gap"]
    R = np.broadcast_to(np.eye(3), (len(g), 3, 3))
    F = np.where(x[:, 0] < 1.0, 0.1, 0.5)
    sol = solve_contact(K, f, cdofs, g, F)
    checks = physics(K, f, cdofs, R, g, np.zeros((len(g), 2)), F, sol)
    for key in ("equilibrium", "penetration", "pressure", "complementarity", "cone"):
        assert checks[key] < 1e-10, (key, checks[key])
    assert checks["slip_direction"] < 1e-6
    same = solve_contact(K, f, cdofs, g, np.full(len(g), 0.23))
    scalar = solve_contact(K, f, cdofs, g, 0.23)
    assert np.allclose(same.u, scalar.u, rtol=0, atol=1e-14 * np.abs(scalar.u).max())
    assert np.linalg.norm(sol.u - scalar.u) > 1e-3 * np.linalg.norm(scalar.u)  # friction matters
    # push the first Dirichlet node up by 1e-3 in x3 (an arbitrary prescribed value)
    dofs = lev1["dirichlet"][2::3][:1]
    pushed = solve_contact(K, f, cdofs, g, 0.23, dirichlet=(dofs, [1e-3]))
    assert pushed.u[dofs[0]] == pytest.approx(1e-3, abs=1e-15)


def test_load_path_increment_shift(lev1):
    """Issue 14's friction on the increment through the tangential shift: step 2 of a path (a tilted plane
    dragged further, the side load reversed) with o = ũ₁ + δ₂ − δ₁. Brute force and the SCD iteration in frames
    agree; without friction the path's end equals the static solve of the final state, with friction it differs."""
    K, f, cdofs, x = lev1["K"], lev1["load"], lev1["cdofs"], lev1["x"]
    nodes = cdofs[:, 0] // 3
    plane = Plane(point=[0.0, 0.0, -0.004], normal=[0.01, -0.005, 1.0], displacement=[0.001, 0.0, 0.0])
    delta2 = np.array([-0.002, 0.001, 0.0])
    f2 = f.copy()
    f2[0::3] *= -1.0  # the side load's x1 component reversed
    for friction in (0.0, 0.3):
        # step 1: the static problem at δ₁
        _, g1, _, R1 = closest_obstacle([plane], x)
        s1 = local_shift(R1, g1, plane.displacement)
        step1 = solve_contact(K, f, cdofs, g1, friction, frames=R1, shifts=s1[:, :2])
        # step 2 at δ₂, friction on the increment: o = ũ₁ + δ₂ − δ₁
        moved = plane.moved(delta2)
        _, g2, _, R2 = closest_obstacle([moved], x)
        offset = step1.u[cdofs] + delta2 - np.asarray(plane.displacement)
        s2 = local_shift(R2, g2, offset)
        step2 = solve_contact(K, f2, cdofs, g2, friction, frames=R2, shifts=s2[:, :2])
        u, _, z, _ = solve_in_frames(K, f2, nodes, R2, s2, friction)
        assert np.linalg.norm(u - step2.u) <= 1e-7 * np.linalg.norm(step2.u)
        assert np.abs(-z - step2.force).max() <= 1e-7 * step2.force[:, 2].max()
        # the slip of step 2 is the increment T(ũ₂ − ũ₁) − T(δ₂ − δ₁)
        increment = np.einsum("iab,ia->ib", R2, step2.u[cdofs] - step1.u[cdofs] - (delta2 - plane.displacement))
        assert np.allclose(step2.slip, increment[:, :2], atol=1e-12 * np.abs(step2.u).max())
        static = solve_contact(K, f2, cdofs, g2, friction, frames=R2, shifts=local_shift(R2, g2, delta2)[:, :2])
        difference = np.linalg.norm(static.u - step2.u) / np.linalg.norm(static.u)
        if friction == 0.0:
            assert difference < 1e-10
        else:
            assert difference > 1e-2, difference


@pytest.mark.parametrize(("friction", "sticks"), [(0.0, False), (0.5, True), (0.2, False)])
def test_two_body_coupling_against_the_closed_form(friction, sticks):
    """Two nodes on springs k₁, k₂ (to the ground), node a pressed down by P onto node b (gap g) and pulled
    sideways by Q, contact on the relative displacement u_a − u_b (the coupling of issue 18): the closed form
    λ = (P/k₁ − g)/(1/k₁ + 1/k₂); sticking p_t = −Q/(1 + k₁/k₂) if |p_t| <= Fλ, else sliding p_t = −Fλ."""
    k1, k2, P, Q, g = 3.0, 5.0, 2.0, 0.4, 0.1
    K = sp.diags(np.r_[np.full(3, k1), np.full(3, k2)])
    f = np.array([Q, 0.0, -P, 0.0, 0.0, 0.0])
    G = sp.hstack([sp.eye(3), -sp.eye(3)])  # u_a − u_b
    sol = solve_contact(K, f, np.array([[0, 1, 2]]), [g], friction, coupling=G)
    lam = (P / k1 - g) / (1 / k1 + 1 / k2)
    stick = -Q / (1 + k1 / k2)
    pt = stick if abs(stick) <= friction * lam else -friction * lam
    assert (abs(stick) <= friction * lam) == sticks
    assert sol.force[0] == pytest.approx([pt, 0.0, lam], abs=1e-12)
    ua, ub = sol.u[:3], sol.u[3:]
    assert ua == pytest.approx([(Q + pt) / k1, 0.0, (-P + lam) / k1], abs=1e-12)
    assert ub == pytest.approx([-pt / k2, 0.0, -lam / k2], abs=1e-12)  # the reaction on b
    assert sol.gap[0] == pytest.approx(0.0, abs=1e-12)
