"""Quasi-static load paths through ``ContactProblem`` (issue 14): friction on the slip increment.

Step k solves the static problem with the obstacles at δ_k and the slip s = T(ũ_k − ũ_{k−1}) − T(δ_k − δ_{k−1}).
Checked here: a one-step path is the static solve; without friction the end of a path does not depend on the
steps; with friction a loading–reversal path differs from the static solve of its final load; the physics
holds on the increments at every step; an independent Alart–Curnier solver (tests/brute_force.py, fed the
increments' shifts computed here) agrees step by step; a path resumed from a stored step equals the
uninterrupted one; 1 rank = 2 ranks.
"""

from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import numpy as np
import pytest
import ufl
from conftest import gather_by_coordinates, global_norm

from fenics_coulomb import ContactProblem, Plane, Sphere
from fenics_coulomb.scenes.builder import build_body, dirichlet_conditions
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.materials import epsilon, sigma
from fenics_coulomb.model.dof_values import owned_values

#: Tight settings: the comparisons below are at 1e-8.
TIGHT = {"rtol": 1e-11, "tol": 1e-10}
PHYSICS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction",
           "reaction_balance")


@dataclass
class PathCase:
    """A Section 7 body whose tractions are Constants (one per boundary), so that a path can change them."""

    problem: ContactProblem
    tractions: dict[str, dolfinx.fem.Constant]
    base: dict[str, np.ndarray]

    def load(self, factor: float = 1.0, **values: list[float]) -> None:
        """Set every traction to ``factor`` × its scene value, or to the given value."""
        for name, c in self.tractions.items():
            c.value[:] = np.asarray(values[name], dtype=np.float64) if name in values else factor * self.base[name]


def path_case(comm: MPI.Comm, friction: float, lev: int = 2, obstacles=None, prefix: str = "path_",
              sliding: str = "finite", **settings) -> PathCase:
    """The d3/L2 cuboid at ``lev`` with its tractions as Constants."""
    scene = Scene().override(lev=lev, gap="d3", load="L2", friction=friction)
    body = build_body(scene, comm)
    V = dolfinx.fem.functionspace(body.mesh, ("Lagrange", 1, (3,)))
    mu, lmbda = scene.material.material().lame
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    ds = ufl.Measure("ds", domain=body.mesh, subdomain_data=body.facet_tags)
    dx = ufl.Measure("dx", domain=body.mesh, metadata={"quadrature_degree": 2})
    a = ufl.inner(sigma(u, mu, lmbda), epsilon(v)) * dx
    base = {name: np.asarray(value, dtype=np.float64) for name, value in scene.traction_table().items()}
    tractions = {name: dolfinx.fem.Constant(body.mesh, value.astype(PETSc.ScalarType)) for name, value in base.items()}
    L = sum(ufl.inner(c, v) * ds(body.tag(name)) for name, c in tractions.items())
    bcs, _ = dirichlet_conditions(V, body, scene)
    problem = ContactProblem(a, L, bcs=bcs, contact=(body.facet_tags, [body.tag(n) for n in body.contact]),
                             friction=friction, obstacles=obstacles, settings={**TIGHT, **settings},
                             petsc_options_prefix=prefix, sliding=sliding)
    return PathCase(problem, tractions, base)


def owned(problem: ContactProblem) -> np.ndarray:
    """The owned DOF values of the problem's displacement (a copy)."""
    return owned_values(problem.u)


def assert_physics(problem: ContactProblem, label: str) -> None:
    checks = physics_residuals(problem.model, owned(problem))
    for key in PHYSICS:
        assert checks[key] < 1e-7, (label, key, checks[key])


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_one_step_path_is_the_static_solve_and_reset_forgets(friction):
    """The first solve of a path is the static problem of today (the CLI's, 1e-10); after reset() the same
    solve gives the same bits; a second solve with unchanged loads keeps the state (zero increment)."""
    from conftest import make_problem

    case = path_case(MPI.COMM_WORLD, friction)
    with case.problem as problem, make_problem(2, "d3", "L2", friction=friction, **TIGHT) as static:
        _, result = problem.solve()
        assert result.converged and problem.step == 1
        first = owned(problem)
        _, reference = static.solve()
        diff = global_norm(first - reference.displacement) / global_norm(reference.displacement)
        assert diff < 1e-10, diff
        _, again = problem.solve()  # step 2 with the same load: nothing moves
        assert problem.step == 2 and again.converged
        assert global_norm(owned(problem) - first) <= 1e-9 * global_norm(first)
        problem.reset()
        assert problem.step == 0
        problem.solve()
        assert np.array_equal(owned(problem), first)


def test_frictionless_end_state_does_not_depend_on_the_steps():
    """F = 0: the load ramped in 1 or in 4 steps ends in the same state (1e-8); each step obeys the physics."""
    ends = []
    for steps in (1, 4):
        case = path_case(MPI.COMM_WORLD, 0.0)
        with case.problem as problem:
            for j in range(1, steps + 1):
                case.load(j / steps)
                _, result = problem.solve()
                assert result.converged
                assert_physics(problem, f"step {j}/{steps}")
            ends.append(owned(problem))
    diff = global_norm(ends[0] - ends[1]) / global_norm(ends[0])
    assert diff < 1e-8, diff


def test_loading_reversal_differs_from_the_static_solve_of_its_final_load():
    """F = 0.3, the paper's d3/L2 case: load, then reverse the side load. Friction acts on the increment, so the
    path ends elsewhere than the static solve of the final load; every step obeys the physics on its increment
    (friction opposes the slip increment, |t| <= F λ), and the slip reported is the increment."""
    case = path_case(MPI.COMM_WORLD, 0.3)
    side = {name: value for name, value in case.base.items() if abs(value[0]) > 0}
    assert side, "the L2 case has a side load"
    reversed_side = {name: [-value[0], value[1], value[2]] for name, value in side.items()}
    with case.problem as problem:
        case.load(1.0)
        problem.solve()
        assert_physics(problem, "loading")
        loaded = owned(problem)
        model = problem.model
        before = loaded[model.contact.local_dofs]
        case.load(1.0, **reversed_side)
        _, result = problem.solve()
        assert result.converged and problem.step == 2
        assert_physics(problem, "reversal")
        path_end = owned(problem)
        # the local slip of the result is T(ũ₂ − ũ₁) on the sliding nodes (no obstacle motion here)
        increment = np.einsum("iab,ia->ib", model.contact.frames, path_end[model.contact.local_dofs] - before)
        v = np.einsum("iab,ia->ib", model.contact.frames, path_end[model.contact.local_dofs]) + model.local_shift
        assert np.allclose(v[:, :2], increment[:, :2], atol=1e-12 * max(global_norm(path_end), 1e-300))
        counts = result.counts
        assert counts["slip"] > 0 and counts["stick"] + counts["slip"] > 0
        problem.reset()
        problem.solve()
        static_end = owned(problem)
    difference = global_norm(path_end - static_end) / global_norm(static_end)
    assert difference > 1e-3, difference


@pytest.mark.serial
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_path_agrees_with_brute_force(friction):
    """A 3-step path at lev 1 on one rank: a sphere pressed in, dragged sideways and back, while the side load
    changes; the independent Alart–Curnier solver on the problem's matrices with the increments' shifts
    o = ũ_{k−1} + δ_k − δ_{k−1} (computed here from its own previous step) agrees at every step (1e-7)."""
    from brute_force import solve_contact
    from brute_force import scipy_matrix

    from fenics_coulomb.model.obstacles import closest_obstacle
    from fenics_coulomb.model.frames import local_shift

    sphere = Sphere(center=[1.0, 0.5, -10.0], radius=10.0, name="indenter")
    floor = Plane(point=[0.0, 0.0, -0.01], normal=[0.0, 0.0, 1.0], name="floor")
    moves = [[0.0, 0.0, 0.012], [0.003, 0.001, 0.012], [-0.001, 0.0, 0.011]]
    factors = [1.0, 0.6, -0.4]
    # the reference-configuration model the brute force shares (finite sliding: test_finite_sliding*.py)
    case = path_case(MPI.COMM_SELF, friction, lev=1, obstacles=[sphere, floor], pc="lu", rtol=1e-12,
                     tol=1e-13, sliding="small")
    side = {name: value for name, value in case.base.items() if abs(value[0]) > 0}
    previous_u, previous_delta, slid = None, np.zeros((2, 3)), False
    with case.problem as problem:
        model = problem.model
        cdofs = model.contact.local_dofs
        for k, (move, factor) in enumerate(zip(moves, factors), start=1):
            case.load(1.0, **{name: [factor * v[0], v[1], v[2]] for name, v in side.items()})
            problem.move("indenter", move)
            _, result = problem.solve()
            assert result.converged, k
            K, f = scipy_matrix(model.A), model.load.getArray(readonly=True).copy()
            obstacles = [sphere.moved(move), floor]
            index, g, _, R = closest_obstacle(obstacles, model.contact.coordinates)
            delta = np.array([o.displacement for o in obstacles])
            offset = delta[index] - previous_delta[index]
            if previous_u is not None:
                offset = offset + previous_u[cdofs]
            s = local_shift(R, g, offset)
            sol = solve_contact(K, f, cdofs, g, friction, frames=R, shifts=s[:, :2])
            u = result.displacement
            assert np.linalg.norm(sol.u - u) <= 1e-7 * np.linalg.norm(u), (k, np.linalg.norm(sol.u - u))
            lam = sol.force[:, 2]
            slid |= bool(np.any(np.linalg.norm(sol.slip, axis=1)[lam > 0] > 1e-6 * np.abs(u).max()))
            previous_u, previous_delta = sol.u, delta
            assert_physics(problem, f"step {k}")
    if friction > 0:
        assert slid  # the path exercises sliding on an increment


def test_resumed_path_equals_the_uninterrupted_one():
    """reset(u=ũ₂, step=2, obstacle_displacements=δ₂) then step 3 equals step 3 of the whole path (1e-8)."""
    sphere = Sphere(center=[1.0, 0.5, -10.0], radius=10.0, name="indenter")
    floor = Plane(point=[0.0, 0.0, -0.01], normal=[0.0, 0.0, 1.0])
    moves = [[0.0, 0.0, 0.01], [0.004, 0.0, 0.01], [0.001, 0.001, 0.009]]
    case = path_case(MPI.COMM_WORLD, 0.3, obstacles=[sphere, floor])
    with case.problem as problem:
        for k, move in enumerate(moves):
            problem.move(0, move)
            problem.solve()
            if k == 1:
                stored = problem.u.copy()
        whole = owned(problem)
        assert problem.step == 3
    case = path_case(MPI.COMM_WORLD, 0.3, obstacles=[sphere, floor])
    with case.problem as problem:
        problem.reset(stored, step=2, obstacle_displacements=[moves[1], [0.0, 0.0, 0.0]])
        problem.move("indenter", moves[2])
        problem.solve()
        assert problem.step == 3
        diff = global_norm(owned(problem) - whole) / global_norm(whole)
    assert diff < 1e-8, diff


@pytest.mark.compares_ranks
def test_path_on_this_communicator_equals_one_rank():
    """1 rank = 2 ranks: the loading–reversal path with a moving plane on COMM_WORLD and on COMM_SELF (each
    rank alone) agree at every node (1e-8)."""
    results = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        case = path_case(comm, 0.3, obstacles=[Plane(point=[0, 0, 0], normal=[0.01, 0.0, 1.0], name="base")],
                         prefix=f"path{comm.size}_")
        side = {name: value for name, value in case.base.items() if abs(value[0]) > 0}
        with case.problem as problem:
            for factor, move in [(1.0, [0, 0, 0]), (-1.0, [0.002, 0, 0])]:
                case.load(1.0, **{name: [factor * v[0], v[1], v[2]] for name, v in side.items()})
                problem.move("base", move)
                problem.solve()
            results.append(gather_by_coordinates(problem.V, owned(problem).reshape(-1, 3), comm))
    (x0, u0), (x1, u1) = results
    assert np.allclose(x0, x1)
    assert np.abs(u0 - u1).max() <= 1e-8 * np.abs(u1).max()


def test_move_and_reset_reject_bad_input():
    case = path_case(MPI.COMM_WORLD, 0.0, lev=1, obstacles=[Plane(point=[0, 0, 0], normal=[0, 0, 1], name="base")])
    with case.problem as problem:
        with pytest.raises(InputError, match="no obstacle named 'lid'"):
            problem.move("lid", [0, 0, 0])
        with pytest.raises(InputError, match="index below 1"):
            problem.move(3, [0, 0, 0])
        with pytest.raises(InputError, match="displacement"):
            problem.move("base", [0, 0, float("nan")])
        with pytest.raises(InputError, match="step -1"):
            problem.reset(step=-1)
        with pytest.raises(InputError, match="obstacle_displacements"):
            problem.reset(obstacle_displacements=[[0, 0]])
        problem.move(0, [0.0, 0.0, 0.001])
        assert problem.obstacles[0].displacement == (0.0, 0.0, 0.001)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_remaining_time_uses_the_warm_started_solves() -> None:
    """The first solve (cold start) only estimates while it is alone; after it, the median of the later solves."""
    from fenics_coulomb.scenes.path import remaining_time

    assert remaining_time([12.0], 4) == pytest.approx(48.0)
    assert remaining_time([12.0, 2.0, 3.0, 2.5], 4) == pytest.approx(10.0)  # median of 2, 3, 2.5: not the mean 4.9
    assert remaining_time([12.0, 2.0, 30.0, 2.5, 3.0], 2) == pytest.approx(5.5)  # one slow step: the median holds
    assert remaining_time([12.0, 2.0], 0) == 0.0
    assert remaining_time([], 3) == 0.0
