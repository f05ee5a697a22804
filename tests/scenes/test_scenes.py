"""Scenes (TOML), safe gap expressions, the shortcuts, the non-box mesh and restarts from a file."""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from conftest import gather_by_coordinates, global_norm, make_problem, read_solution
from reference import tresca_fixed_point

from fenics_coulomb.model.checks import PHYSICS_PER_RTOL, physics_residuals
from fenics_coulomb.cli import EXIT_INPUT, main
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.errors import InputError
from fenics_coulomb.scenes.expression import parse_gap_expression
from fenics_coulomb.scenes.cuboid import gap_d3

ROOT = Path(__file__).resolve().parents[2]
SCENES = sorted((ROOT / "demos" / "scenes").glob("*.toml"))


def write(tmp: Path, name: str, text: str) -> Path:
    path = tmp / name
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    return path


@pytest.mark.serial  # rank-local (docs/testing.md)
@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_shipped_scenes_parse(path):
    scene = Scene.from_toml(path)
    assert scene.name == path.stem
    scene.solver.validate()


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_section7_scene_matches_paper_data():
    scene = Scene.from_toml(ROOT / "demos" / "scenes" / "d2_L1.toml")
    assert (scene.body.gap, scene.load.case, scene.friction.coefficient, scene.material.young,
            scene.material.poisson) == ("d2", "L1", 0.23, 70.0, 0.334)
    assert scene.traction_table() == {"top": (0.0, 0.0, -1.0), "right": (-0.2, 0.0, 0.0)}


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_expression_equals_numpy():
    f = parse_gap_expression("0.01 + 0.005*(sin(2*pi*x1) + cos(2*pi*x2))")
    x1, x2 = np.random.default_rng(0).random((2, 50))
    assert np.allclose(f(x1, x2), gap_d3(x1, x2), rtol=1e-15)
    g = parse_gap_expression("max(0.01 - 0.015*sqrt(0.5*(x1-1)**2 + 2*(x2-0.5)**2), 0.0025)")
    assert np.allclose(g(x1, x2), np.maximum(0.01 - 0.015 * np.hypot(np.sqrt(0.5) * (x1 - 1), np.sqrt(2) * (x2 - 0.5)),
                                             0.0025))
    assert np.all(parse_gap_expression("-(-0.5)")(x1, x2) == 0.5)


@pytest.mark.parametrize(
    "text",
    ["__import__('os').system('true')", "x1.__class__", "open('/etc/passwd')", "[x1, x2]", "lambda: 1",
     "x1 if x2 else 1", "x3 + 1", "sin(x=1)", "1 +", "", "'a' * 3", "x1 < 2", "(lambda: 0)()", "True + x1",
     "getattr(x1, 'shape')", "x1 @ x2", "{x1: 1}"],
)
def test_expression_rejects(text):
    with pytest.raises(InputError, match=r"gap expression|does not parse"):
        parse_gap_expression(text)


@pytest.mark.parametrize(
    "text, message",
    [
        ("[body]\nlev = \n", "does not parse"),
        ("[bodie]\nlev = 1\n", "unknown section"),
        ("[body]\nlevel = 1\n", "unknown key 'level'"),
        ("[body]\nlev = -2\n", "lev"),
        ("[body]\nclamped = ['nowhere']\n", "'nowhere'"),
        ("[tractions]\nfront = [0, 0, 1]\n", "'front'"),
        ("[tractions]\ntop = [0, 1]\n", "3 numbers"),
        ("[material]\nyoung = 'stiff'\n", "young"),
        ("[material]\npoisson = 0.5\n", "Poisson"),
        ("[friction]\ncoefficient = -0.1\n", "friction"),
        ("[load]\ncase = 'L3'\n", "L3"),
        ("[load]\ncase = 'L1'\n[tractions]\ntop = [0, 0, 1]\n", "either"),
        ("[body]\ngap = \"__import__('os')\"\n", "__import__"),
        ("[body]\nshape = 'mesh'\nmesh = 'missing.msh'\n", "missing.msh"),
        ("[solver]\npc = 'magic'\n", "magic"),
        ("[solver]\nstart = 'nowhere.xdmf'\n", "nowhere.xdmf"),
        # gmsh tags on the cuboid: ignored (exit 0), or per-body materials failing an assertion (exit 1)
        ("[body]\nlev = 1\n[boundaries]\nbottom = 7\n", r"\[boundaries\] \(bottom\) is for a mesh body"),
        ("[body]\nlev = 1\n[bodies]\nb = 1\n", r"\[bodies\] \(b\) is for a mesh body"),
        ("[body]\nlev = 1\n[bodies]\nb = 1\n[material.b]\nyoung = 200.0\npoisson = 0.3\n", "is for a mesh body"),
    ],
)
def test_bad_scene_files(text, message, mpi_tmp_path, capsys):
    path = write(mpi_tmp_path, "bad.toml", text)
    with pytest.raises(InputError, match=message):
        Scene.from_toml(path)
    assert main(["--scene", str(path), "--out", str(mpi_tmp_path / "o")]) == EXIT_INPUT
    if MPI.COMM_WORLD.rank == 0:
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "error:" in err[0]


def test_flags_override_scene(mpi_tmp_path):
    path = write(mpi_tmp_path, "s.toml", "[body]\nlev = 1\ngap = 'd1'\n[friction]\ncoefficient = 0.5\n")
    out = mpi_tmp_path / "o"
    assert main(["--scene", str(path), "--friction", "0.1", "--gap", "d2", "--out", str(out), "--quiet",
                 "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scene"]["friction"]["coefficient"] == 0.1 and summary["scene"]["body"]["gap"] == "d2"
    assert summary["scene"]["body"]["lev"] == 1 and summary["p"] == 6 * 4


# on COMM_SELF with a dense reference: on 2 ranks each rank repeats the same solve
@pytest.mark.serial
def test_frictionless_matches_signorini_reference():
    """F = 0 solves the Signorini problem: compared with a projected-gradient QP solve (one Tresca solve
    with zero slip bound), and no node sticks."""
    scene = Scene.from_toml(ROOT / "demos" / "scenes" / "wavy_frictionless.toml")
    with make_problem(scene=scene, comm=MPI.COMM_SELF, lev=0, pc="lu", tol=1e-13, rtol=1e-12) as problem:
        _, result = problem.solve()
        model = problem.model
        A = model.A.convert("dense").getDenseArray().copy()
        load = model.load.getArray(readonly=True).copy()
    assert result.converged and not np.any(result.states == 1)
    ref = tresca_fixed_point(A, load, model.contact.local_dofs, model.contact.gap, 0.0)
    assert np.linalg.norm(result.displacement - ref) <= 1e-7 * np.linalg.norm(ref)
    assert np.allclose(result.tangential_force, 0.0)


def test_no_contact_shortcut_equals_full_model(mpi_tmp_path):
    """The lifted scene: one linear solve (predictor) gives the full model's Newton solution."""
    path = ROOT / "demos" / "scenes" / "lifted.toml"
    out = mpi_tmp_path / "short"
    assert main(["--scene", str(path), "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] == 1 and summary["state_counts"]["open"] == summary["p"]
    with make_problem(scene=Scene.from_toml(path), rtol=1e-13, predictor=False) as problem:
        _, full = problem.solve()
        assert full.converged and not full.linear and full.iterations > 1
        x_full, u_full = gather_by_coordinates(problem.V, full.displacement)
    x, u = read_solution(out)
    assert np.allclose(x, x_full, atol=1e-9)
    # the linear solve runs to the reduction rtol (default 1e-7) of the residual: a relative error of that order
    assert np.linalg.norm(u - u_full) <= 10 * summary["rtol"] * np.linalg.norm(u_full)


def test_no_contact_boundary_is_one_linear_solve(mpi_tmp_path):
    path = write(mpi_tmp_path, "free.toml", "[body]\nlev = 1\ncontact = []\n[load]\ncase = 'L1'\n")
    out = mpi_tmp_path / "free"
    assert main(["--scene", str(path), "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["p"] == 0 and summary["newton_iterations"] == 1 and summary["converged"]


def test_non_box_mesh_physics():
    """The tetrahedral roller (meshes/roller.msh) against the plane: the physics checks hold."""
    scene = Scene.from_toml(ROOT / "demos" / "scenes" / "roller.toml")
    with make_problem(scene=scene, rtol=1e-12) as problem:
        _, result = problem.solve()
        checks = physics_residuals(problem.model, result.displacement)
    assert result.converged
    counts = result.counts
    assert counts["slip"] > 0 and counts["open"] > 0 and sum(counts.values()) == problem.p
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone",
                "reaction_balance"):
        assert checks[key] < 1e-8, (key, checks[key])
    assert checks["slip_direction"] < 1e-5


def test_start_from_coarser_solution(mpi_tmp_path):
    """--start FILE interpolates an earlier (coarser, non-matching) solution; the solve reaches the same
    solution as from zero, from a much smaller residual and in no more iterations."""
    coarse = mpi_tmp_path / "coarse"
    assert main(["--lev", "3", "--out", str(coarse), "--quiet", "--no-plots"]) == 0
    fine_zero = mpi_tmp_path / "fine0"
    fine_start = mpi_tmp_path / "fine1"
    assert main(["--lev", "4", "--out", str(fine_zero), "--quiet", "--no-plots"]) == 0
    assert main(["--lev", "4", "--start", str(coarse / "solution.xdmf"), "--out", str(fine_start), "--quiet",
                 "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    a = json.loads((fine_zero / "summary.json").read_text())
    b = json.loads((fine_start / "summary.json").read_text())
    assert a["state_counts"] == b["state_counts"]
    assert b["newton_iterations"] <= a["newton_iterations"]
    assert b["residual_history"][0] < 0.1 * a["residual_history"][0]


@pytest.mark.parametrize("accuracy", [1e-4, 1e-8])
def test_accuracy_instead_of_rtol(accuracy, problem_factory):
    """A scene may ask for a displacement accuracy; the solve meets it against a tight reference."""
    _, ref = problem_factory(3, "d3", "L2", rtol=1e-14, tol=1e-3).solve()
    problem = problem_factory(3, "d3", "L2", accuracy=accuracy)
    _, result = problem.solve()
    assert global_norm(result.displacement - ref.displacement) <= accuracy * global_norm(ref.displacement)
    assert problem.settings.reduction < accuracy


def test_accuracy_holds_where_the_residual_does_not_tell(mpi_tmp_path):
    """The two-body demo with hypre: at rtol = EPS/8 the residual rule alone left the displacement 1.4–1.9 EPS from
    the solution (the error per rtol of a pair with hypre reaches 19, docs/tradeoff/pairs.md); an accuracy is met
    against LU, since the iteration also asks the last Newton correction — the error of the iterate it corrects —
    to be below it."""
    import h5py

    scene = Path(__file__).resolve().parents[2] / "demos" / "scenes" / "two_bodies.toml"

    def displacement(args: list[str], name: str) -> np.ndarray:
        out = mpi_tmp_path / name
        assert main(["--scene", str(scene), "--sliding", "small", "--out", str(out), "--quiet", "--no-plots",
                     *args]) == 0
        MPI.COMM_WORLD.barrier()
        with h5py.File(out / "solution.h5", "r") as h5:
            return h5["Function/displacement"]["0"][:]

    reference = displacement(["--pc", "lu", "--rtol", "1e-12"], "lu")
    for accuracy in (1e-4, 1e-5):
        u = displacement(["--pc", "hypre", "--accuracy", str(accuracy)], f"hypre_{accuracy:g}")
        assert np.linalg.norm(u - reference) <= accuracy * np.linalg.norm(reference)
    # a loose linear tolerance: the correction that checks the accuracy is solved to 0.1 (at 0.7 it underestimated
    # the error and the answer ended 1.3 EPS away)
    u = displacement(["--pc", "hypre", "--tol", "0.7", "--accuracy", "1e-6"], "hypre_loose")
    assert np.linalg.norm(u - reference) <= 1e-6 * np.linalg.norm(reference)


def test_accuracy_holds_under_finite_sliding(mpi_tmp_path):
    """The cylinder roller (finite sliding over a cylinder): the geometry iteration settles when the data change by
    less than ε, which bounds the data, not u — a change of 6.7e-8 under ε = 1e-7 left u 7.8 EPS from LU's at EPS
    1e-5, whatever EPS. With an accuracy asked it also needs the change times the displacement per change measured
    at the updates to stay below half of it."""
    import h5py

    scene = Path(__file__).resolve().parents[2] / "demos" / "scenes" / "cylinder_roller.toml"

    def displacement(args: list[str], name: str) -> np.ndarray:
        out = mpi_tmp_path / name
        assert main(["--scene", str(scene), "--out", str(out), "--quiet", "--no-plots", *args]) == 0
        MPI.COMM_WORLD.barrier()
        with h5py.File(out / "solution.h5", "r") as h5:
            group = h5["Function/displacement"]
            return group[sorted(group, key=float)[-1]][:]

    reference = displacement(["--pc", "lu", "--rtol", "1e-13"], "lu")
    for accuracy in (1e-5, 1e-6):
        u = displacement(["--accuracy", str(accuracy)], f"acc_{accuracy:g}")
        assert np.linalg.norm(u - reference) <= accuracy * np.linalg.norm(reference)


def test_accuracy_holds_on_a_drag_path(mpi_tmp_path):
    """The cylinder dragged over the plate (demos/scenes/cylinder_drag_path.toml, its press and first drag: 6
    solves): at EPS 1e-6 its fourth solve ended 1.05 EPS from the LU path — the displacement per data change was
    measured from the loose first solve (13.3) and the accurate solve's remaining change settled, which then moved u
    by 79.8 per change. Measured between two full-accuracy solves only, every solve is within EPS (1 and 2 ranks)."""
    import h5py

    demo = Path(__file__).resolve().parents[2] / "demos" / "scenes" / "cylinder_drag_path.toml"
    text = demo.read_text()
    scene = mpi_tmp_path / "drag.toml"
    if MPI.COMM_WORLD.rank == 0:  # the press and the first drag (steps 1 and 2)
        cut = [i for i in range(len(text)) if text.startswith("[[path.step]]", i)][2]
        scene.write_text(text[:cut])
    MPI.COMM_WORLD.barrier()

    def displacements(args: list[str], name: str) -> list[np.ndarray]:
        out = mpi_tmp_path / name
        assert main(["--scene", str(scene), "--out", str(out), "--quiet", "--no-plots", *args]) == 0
        MPI.COMM_WORLD.barrier()
        with h5py.File(out / "solution.h5", "r") as h5:
            group = h5["Function/displacement"]
            return [group[k][:] for k in sorted(group, key=float)]

    reference = displacements(["--pc", "lu", "--rtol", "1e-13"], "lu")
    solved = displacements(["--accuracy", "1e-6"], "acc")
    assert len(solved) == len(reference) == 7
    for u, ref in zip(solved[1:], reference[1:], strict=True):
        assert np.linalg.norm(u - ref) <= 1e-6 * np.linalg.norm(ref)


@pytest.mark.parametrize("value", ["0", "1.5", "-1e-3", "nan"])
def test_bad_accuracy(value, mpi_tmp_path):
    assert main(["--lev", "0", f"--accuracy={value}", "--out", str(mpi_tmp_path)]) == EXIT_INPUT


def test_unreadable_mesh_file_is_input_error(mpi_tmp_path, capsys):
    """A mesh file gmsh cannot read ends every rank with exit 2 (rank 0 reads, the others must not hang)."""
    mesh = mpi_tmp_path / "garbage.msh"
    if MPI.COMM_WORLD.rank == 0:
        mesh.write_text("this is not a gmsh file\n")
    path = write(mpi_tmp_path, "m.toml", f"[body]\nshape = 'mesh'\nmesh = '{mesh}'\n[boundaries]\nleft = 1\n"
                 "bottom = 2\n[tractions]\nleft = [0, 0, 0]\n")
    assert main(["--scene", str(path), "--out", str(mpi_tmp_path / "o"), "--no-plots"]) == EXIT_INPUT
    if MPI.COMM_WORLD.rank == 0:
        assert "garbage.msh" in capsys.readouterr().err


def test_unreadable_start_file_is_input_error(mpi_tmp_path, capsys):
    start = mpi_tmp_path / "old.xdmf"
    if MPI.COMM_WORLD.rank == 0:
        start.write_text("<Xdmf/>")
        start.with_suffix(".h5").write_text("not HDF5")
    MPI.COMM_WORLD.barrier()
    assert main(["--lev", "1", "--start", str(start), "--out", str(mpi_tmp_path / "o"), "--no-plots"]) == EXIT_INPUT
    if MPI.COMM_WORLD.rank == 0:
        assert "--start" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["sphere_indentation", "surface_ball", "two_bodies"])
def test_shipped_demo_scenes_solve(name, mpi_tmp_path):
    """The sphere indentation, the surface obstacle and the two-body scene of demos/scenes/ run with the real
    command (issue 26):
    exit 0, contact, the forces balance the supports' reactions, and every reported physics check — the slip
    direction too, which no exit code decides — lies within the solve's bound (the two-body scene reported a slip
    direction of 0.011 from a sticking node whose 2e-8 slip was the solve's own error)."""
    import json

    from fenics_coulomb.cli import main

    out = mpi_tmp_path / name
    assert main(["--scene", str(ROOT / "demos" / "scenes" / f"{name}.toml"), "--out", str(out), "--quiet",
                 "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["state_counts"]["stick"] + summary["state_counts"]["slip"] > 0
    reactions = np.sum([v for v in summary["reactions"].values()], axis=0)
    pairs = summary.get("contact_pairs", [])
    obstacles = np.array(summary["contact_force"])  # the obstacles' force on the bodies (a pair's is internal)
    assert np.allclose(obstacles, np.sum([o["force"] for o in summary.get("obstacles", {}).values()] or [np.zeros(3)],
                                         0), rtol=1e-12, atol=1e-14)
    total = reactions + obstacles + np.array(summary["applied_load"])
    scale = max(np.linalg.norm(v) for v in [*summary["reactions"].values(), obstacles])
    assert summary["physics_checks"]["reaction_balance"] <= 1e-6
    assert scale > 0 and np.linalg.norm(total) <= 1e-6 * scale, total
    for pair in pairs:
        assert pair["balance"] < 1e-6
    assert summary["rtol"] == summary["settings"]["rtol"]  # not a solve's carried past it (finite sliding)
    bound = PHYSICS_PER_RTOL * summary["rtol"]
    for key, value in summary["physics_checks"].items():
        if key != "contact_resultant":
            assert 0 <= value <= bound, (key, value, bound)


def test_a_node_pressed_onto_a_facetted_vertex_takes_the_vertex_normal(mpi_tmp_path):
    """demos/scenes/surface_ball.toml: the block's top node under the STL ball's lowest vertex ends on it, where
    six facets meet. Its force is vertical (the scene is symmetric), so its normal force is the whole force and its
    tangential force nil. The reference geometry (the node 0.01 inside the ball) gave it one facet's normal, tilted
    by 5°, which the solve kept, no gap or slip having changed: a tangential force of 9 % of the normal force and a
    pressure 0.4 % low, another on 3 ranks at rtol 1e-12 (where the node's d = x − x_m of 1e-12 gave d/|d| — noise).
    Now the turned normal is a change of the geometry, and a node within its solve's accuracy of the vertex takes
    the tied facets' mean normal."""
    import json

    from fenics_coulomb.cli import main

    out = mpi_tmp_path / "ball"
    assert main(["--scene", str(ROOT / "demos" / "scenes" / "surface_ball.toml"), "--out", str(out), "--quiet",
                 "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    ball = summary["obstacles"]["ball"]
    force = np.linalg.norm(ball["force"])
    assert ball["contact_nodes"] == 1 and summary["geometry_updates"] >= 1
    assert ball["normal_force"] == pytest.approx(force, rel=1e-9)
    assert ball["tangential_force"] <= 1e-6 * force


def test_a_rolling_path_sticks_and_the_same_drag_slides(mpi_tmp_path):
    """demos/scenes/roller_rolling_path.toml (issue 26): the cylinder translated by R θ and turned by θ about its
    own axis sticks everywhere in its contact; without the rotation the same translation slides everywhere."""
    import json

    from fenics_coulomb.cli import main

    scene = ROOT / "demos" / "scenes" / "roller_rolling_path.toml"
    dragged = write(mpi_tmp_path, "dragged.toml", "\n".join(
        line for line in scene.read_text().splitlines() if not line.startswith("rotate")) + "\n")
    counts = {}
    for name, path in (("rolled", scene), ("dragged", dragged)):
        out = mpi_tmp_path / name
        assert main(["--scene", str(path), "--out", str(out), "--quiet", "--no-plots"]) == 0
        steps = json.loads((out / "summary.json").read_text())["steps"]
        counts[name] = [s["state_counts"] for s in steps[1:]]
        # each solve records each obstacle's rotation: none at the press, the substeps' blended angles after
        rotations = [s["obstacle_rotations"]["roller"] for s in steps]
        if name == "rolled":
            assert rotations[0] is None and [r[0] for r in rotations[1:]] == [0.5 * 1.1459155902616465,
                                                                               1.1459155902616465]
            assert all(r[1] == [0.0, 1.0, 0.0] and r[2] == [0.6, 0.5, 1.5] for r in rotations[1:])
        else:
            assert rotations == [None] * len(steps)
    assert all(c["slip"] == 0 and c["stick"] > 0 for c in counts["rolled"]), counts
    assert all(c["stick"] == 0 and c["slip"] > 0 for c in counts["dragged"]), counts


def test_rotations_that_cannot_be_blended_are_named(mpi_tmp_path, capsys):
    from fenics_coulomb.cli import EXIT_INPUT, main

    text = (ROOT / "demos" / "scenes" / "roller_rolling_path.toml").read_text().replace(
        "[[obstacle]]\nname", '[[obstacle]]\nrotation = [10.0, [1.0, 0.0, 0.0], [0.6, 0.5, 1.5]]\nname')
    scene = write(mpi_tmp_path, "bad.toml", text)
    assert main(["--scene", str(scene), "--out", str(mpi_tmp_path / "o"), "--quiet", "--no-plots"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert MPI.COMM_WORLD.rank != 0 or "substeps between rotations about different axes" in err, err


def test_an_stl_roller_rolls_then_skids(mpi_tmp_path):
    """demos/scenes/stl_roller_rolling.toml (issue 26): the roller from an STL file sticks while it rolls
    (translated by R θ and turned by θ) and slides when it skids (translated only); the skid's tangential force
    is bounded by F × the normal force and far above the rolling one."""
    import json

    from fenics_coulomb.cli import main

    out = mpi_tmp_path / "stl_rolling"
    # small sliding: the total force's ratio bound below assumes normals symmetric about the vertical over the patch;
    # with finite sliding the skidding patch is asymmetric and its normals add an x force (0.6 % of F·P measured)
    assert main(["--scene", str(ROOT / "demos" / "scenes" / "stl_roller_rolling.toml"), "--out", str(out),
                 "--quiet", "--no-plots", "--sliding", "small"]) == 0
    steps = json.loads((out / "summary.json").read_text())["steps"]
    counts = [s["state_counts"] for s in steps]
    force = np.array([s["contact_force"] for s in steps])
    assert all(c["slip"] == 0 and c["stick"] > 0 for c in counts[:3]), counts
    assert all(c["stick"] == 0 and c["slip"] > 0 for c in counts[3:]), counts
    ratio = np.abs(force[:, 0]) / np.abs(force[:, 2])
    assert np.all(ratio[3:] <= 0.5 + 1e-8) and ratio[3:].min() > 5 * ratio[:3].max()
