"""Load-path scenes (issue 14): ``[[path.step]]`` parsing, what a step inherits, the plan of solves and the
in-place load coefficients (fenics_coulomb.scenes.path)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from mpi4py import MPI

import dolfinx
import numpy as np
import pytest

from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import PathStep, Scene
from fenics_coulomb.errors import InputError
from fenics_coulomb.scenes.loads import StepLoads, scene_state, step_state, zero_state
from fenics_coulomb.scenes.path import plan

ROOT = Path(__file__).resolve().parents[2]

SCENE = """
[body]
lev = 0
clamped = ["left"]
[load]
scale = 2.0
body_force = [0, 0, -0.5]
[tractions]
top = [0, 0, -1]
[prescribed]
right = [0.001, 0, 0]
[[obstacle]]
name = "ball"
type = "sphere"
center = [1.0, 0.5, -0.5]
radius = 0.5
displacement = [0, 0, 0.002]
[[obstacle]]
type = "plane"
point = [0, 0, -1]
normal = [0, 0, 1]
[[path.step]]
tractions = { top = [0, 0, -3], sides = [0.1, 0, "x1"] }
prescribed = { right = [0.002, 0, 0] }
move = { ball = [0.001, 0, 0.004] }
body_force = [0, 0, 0]
substeps = 4
[[path.step]]
"""


@pytest.fixture
def scene(mpi_tmp_path) -> Scene:
    path = mpi_tmp_path / "path.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(SCENE)
    MPI.COMM_WORLD.barrier()
    return Scene.from_toml(path)


def test_steps_parsed(scene):
    assert len(scene.path) == 2 and all(isinstance(s, PathStep) for s in scene.path)
    first, second = scene.path
    assert first.substeps == 4 and first.move == {"ball": [0.001, 0, 0.004]} and first.body_force == [0, 0, 0]
    assert second == PathStep()  # an empty table: the scene's loads, in one step
    demo = Scene.from_toml(ROOT / "demos" / "scenes" / "d3_L2_path.toml")
    assert [s.substeps for s in demo.path] == [3, 2, 2] and demo.load.case == "L2"


def test_a_step_inherits_the_scenes_values_not_the_previous_steps(scene):
    """What a step does not set is the scene's (per boundary, per obstacle), with the load scale applied to the
    step's tractions as to the scene's."""
    base = scene_state(scene)
    assert base.tractions["top"] == (0.0, 0.0, -2.0) and base.body_force == (0.0, 0.0, -0.5)
    assert base.prescribed == {"right": (0.001, 0.0, 0.0)}
    assert base.obstacles == ((0.0, 0.0, 0.002), (0.0, 0.0, 0.0))
    one = step_state(scene, scene.path[0])
    assert one.tractions["top"] == (0.0, 0.0, -6.0)  # times the scale 2
    x = np.array([[0.25, 1.0], [0.0, 0.0], [0.0, 0.0]])
    assert one.tractions["sides"][0] == 0.2 and np.allclose(one.tractions["sides"][2](x), [0.5, 2.0])
    assert one.prescribed == {"right": (0.002, 0.0, 0.0)} and one.body_force == (0.0, 0.0, 0.0)
    assert one.obstacles == ((0.001, 0.0, 0.004), (0.0, 0.0, 0.0))  # the unnamed plane keeps its δ
    two = step_state(scene, scene.path[1])
    assert two.tractions == base.tractions and "sides" not in two.tractions  # NOT step 1's
    assert two.prescribed == base.prescribed and two.obstacles == base.obstacles
    assert two.body_force == base.body_force


def test_plan_of_substeps_and_of_a_ramp(scene):
    solves = plan(scene)
    assert [s.time for s in solves] == [0.25, 0.5, 0.75, 1.0, 2.0]
    assert [(s.step, s.substep, s.substeps) for s in solves] == [(1, 1, 4), (1, 2, 4), (1, 3, 4), (1, 4, 4),
                                                                (2, 1, 1)]
    assert solves[0].start == zero_state(scene) and solves[3].weight == 1.0
    assert solves[1].obstacle_displacements[0] == pytest.approx((0.0005, 0.0, 0.002))
    assert solves[4].start is solves[3].end and solves[4].obstacle_displacements[0] == (0.0, 0.0, 0.002)
    ramp = plan(scene, 4)
    assert [s.load_factor for s in ramp] == [0.25, 0.5, 0.75, 1.0] and [s.time for s in ramp] == [1, 2, 3, 4]
    assert all(s.start == zero_state(scene) and s.end == scene_state(scene) for s in ramp)
    assert ramp[1].obstacle_displacements[0] == pytest.approx((0.0, 0.0, 0.001))
    static = Scene()
    assert plan(static) == [] and len(plan(static, 2)) == 2


@pytest.mark.parametrize("step, fragment", [
    (PathStep(substeps=0), "[[path.step]] 1 substeps = 0: must be an integer >= 1"),
    (PathStep(substeps=True), "[[path.step]] 1 substeps = True"),
    (PathStep(move={"plane": [0, 0, 1]}), "no obstacle named 'plane' (named obstacles: ball; give the "
                                           "[[obstacle]] a name to move it)"),
    (PathStep(move={"ball": [0, 0]}), "[[path.step]] 1 move of 'ball' = [0, 0]"),
    (PathStep(prescribed={"top": [0, 0, 1]}), "boundary 'top' is not in the scene's [prescribed] (right)"),
    (PathStep(prescribed={"right": [0, float("nan"), 1]}), "prescribed displacement on 'right'"),
    (PathStep(tractions={"roof": [0, 0, 1]}), "boundary 'roof' does not exist on the cuboid"),
    (PathStep(tractions={"top": [0, 0, 1e13]}), "must stay below 1e+12 GPa"),
    (PathStep(tractions={"top": [0, 0, "sin(x1, x2)"]}), "sin"),
    (PathStep(body_force=[0, 0, "1"]), "[[path.step]] 1 body_force = [0, 0, '1']"),
])
def test_bad_steps_named(scene, step, fragment):
    with pytest.raises(InputError) as err:
        dataclasses.replace(scene, path=[step]).validate()
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_step_loads_blend_in_place(scene):
    """Constants where every state is constant, a P1 Function where any has an expression; the blend
    (1 − w)·start + w·end, exactly the end at w = 1; the prescribed Constants are those the BCs hold."""
    comm = MPI.COMM_WORLD
    built = build_problem(scene.override(lev=0), comm, petsc_options_prefix="pathscene_")
    with built.problem:
        loads = built.loads
        assert isinstance(loads.tractions["top"], dolfinx.fem.Constant)
        assert isinstance(loads.tractions["sides"], dolfinx.fem.Function)
        assert np.array_equal(loads.tractions["top"].value, [0, 0, -2.0])  # built at the scene's values
        assert np.all(loads.tractions["sides"].x.array == 0.0)  # the scene has no traction on the sides
        solves = plan(scene)
        loads.apply(solves[0].start, solves[0].end, 0.25)
        assert np.allclose(loads.tractions["top"].value, [0, 0, -1.5])
        assert np.allclose(loads.body_force.value, [0, 0, 0])
        assert np.allclose(loads.prescribed["right"].value, [0.0005, 0, 0])
        V = loads.V
        x = V.tabulate_dof_coordinates()
        sides = loads.tractions["sides"].x.array.reshape(-1, 3)
        assert np.allclose(sides[:, 0], 0.05) and np.allclose(sides[:, 2], 0.25 * 2.0 * x[:, 0])
        # the DirichletBC holds the Constant: its value is what bc.set writes
        u = dolfinx.fem.Function(V)
        u.x.array[:] = np.nan
        for bc in built.bcs:
            bc.set(u.x.array)
        right = np.unique(np.concatenate([bc.dof_indices()[0] for bc in built.dirichlet_groups["right"]]) // 3)
        assert right.size == 0 or np.allclose(u.x.array.reshape(-1, 3)[right], [0.0005, 0, 0])
        loads.apply(solves[3].start, solves[3].end, 1.0)
        assert np.array_equal(loads.tractions["top"].value, [0, 0, -6.0])
        loads.apply(solves[4].start, solves[4].end, 1.0)
        assert np.array_equal(loads.tractions["top"].value, [0, 0, -2.0]) and np.all(
            loads.tractions["sides"].x.array == 0.0)


def test_a_field_follows_the_traction_not_the_state_object(scene):
    """A state's traction field is computed from its traction, whatever object carries it. CPython hands a
    freed object's id() to a later one: a cache keyed by id(state) gave plan()'s first step the freed
    initial state's zero field, and the blend came out zero in CI. Here one object carries two tractions in
    turn, the deterministic form of a new state at a freed one's address."""
    comm = MPI.COMM_WORLD
    built = build_problem(scene.override(lev=0), comm, petsc_options_prefix="pathscene_")
    with built.problem:
        loads = built.loads
        x1 = loads.V.tabulate_dof_coordinates()[:, 0]
        state = step_state(scene, PathStep(tractions={"sides": [0, 0, "x1"]}))
        for k in (1, 3):
            state.tractions["sides"] = step_state(scene, PathStep(tractions={"sides": [0, 0, f"{k}*x1"]})
                                                  ).tractions["sides"]
            loads.apply(state, state, 1.0)
            sides = loads.tractions["sides"].x.array.reshape(-1, 3)
            assert np.allclose(sides[:, 2], 2.0 * k * x1) and np.all(sides[:, :2] == 0.0), k


def test_static_scene_builds_the_same_load(mpi_tmp_path):
    """A scene without a path: the load form's coefficients hold the scene's values (no coefficient more)."""
    built = build_problem(Scene().override(lev=0), MPI.COMM_WORLD, petsc_options_prefix="pathstatic_")
    with built.problem:
        assert set(built.loads.tractions) == {"top", "right"}
        assert isinstance(built.loads, StepLoads)
        assert np.array_equal(built.loads.tractions["right"].value, [-0.17, -0.1, 0.0])


@pytest.mark.serial  # rank-local (docs/testing.md)
@pytest.mark.parametrize("s", [1e-6, 1.0, 1e3, 1e6])
def test_substeps_of_a_rotation_about_one_centre_in_any_length_unit(s):
    """A rotation's centres are one up to their coordinates' round-off, in whatever length unit: a ball rolled about
    (0.9, 0.5, 1.5)·s, written once as 0.9000000000000036·s, blends at s = 1e3 (the absolute 1e-12 refused it, exit
    2) — and centres that differ by 1e-9 of their size are two at s = 1e-6 (the same tolerance merged them)."""
    from fenics_coulomb.scenes.loads import blend_rotation

    axis = (0.0, 1.0, 0.0)
    a = (10.0, axis, (0.9 * s, 0.5 * s, 1.5 * s))
    b = (20.0, axis, (0.9000000000000036 * s, 0.5 * s, 1.5 * s))
    assert blend_rotation(a, b, 0.5) == (15.0, axis, b[2])
    with pytest.raises(InputError, match="different axes or centres"):
        blend_rotation(a, (20.0, axis, (0.9 * s * (1 + 1e-9), 0.5 * s, 1.5 * s)), 0.5)
