"""Hostile input against the obstacles, the load paths and the entry points: each case ends with exit 2 and one
line naming the value (every rank, before any collective call), exit 3 with the earlier results kept, or the right
answer — never a traceback, a hang or exit 0 on a wrong answer.

The in-process tests run on 1 rank (pytest) and on 2 ranks (mpirun -n 2 ... pytest).
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np
import pytest

from fenics_coulomb import InputError, Surface
from fenics_coulomb.cli import EXIT_DIVERGED, EXIT_INPUT, main
from fenics_coulomb.model.checks import DECISIVE_CHECKS

ROOT = Path(__file__).resolve().parents[2]
from meshes.surfaces import icosphere, rectangle, write_stl  # noqa: E402

PROG = "python3 -m fenics_coulomb: error:"
#: The cuboid [0, 2] x [0, 1] x [0, 1] held at its bottom, its top the contact boundary, no load.
BLOCK = '[body]\nlev = 2\ngap = "0.0*x1"\nclamped = ["bottom"]\ncontact = ["top"]\n[tractions]\n'


def shared(path: Path, content: str | np.ndarray) -> Path:
    """A file written by rank 0 (text, or triangles as ASCII STL), seen by every rank."""
    if MPI.COMM_WORLD.rank == 0:
        if isinstance(content, str):
            path.write_text(content)
        else:
            write_stl(path, content)
    MPI.COMM_WORLD.barrier()
    return path


def run(*args: str) -> int:
    status = main([*args, "--no-plots", "--quiet"])
    MPI.COMM_WORLD.barrier()
    return status


def one_line(capsys, *fragments: str) -> str:
    """Rank 0 printed exactly one error line naming every fragment; the other ranks nothing."""
    lines = capsys.readouterr().err.strip().splitlines()
    if MPI.COMM_WORLD.rank == 0:
        assert len(lines) == 1 and lines[0].startswith(PROG), lines
        for fragment in fragments:
            assert fragment in lines[0], (fragment, lines)
        return lines[0]
    assert lines == [], lines
    return ""


def last_displacement(out: Path, k: int = -1) -> np.ndarray:
    """The displacement of the k-th grid of a result set, rows in the order of the coordinates."""
    with h5py.File(out / "solution.h5", "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        names = sorted(h5["Function/displacement"], key=int)
        u = h5[f"Function/displacement/{names[k]}"][:]
    return u[np.lexsort(np.round(x, 12).T[::-1])]


# -- obstacles the contact nodes cannot see -----------------------------------------------------------------
OBSTACLES = {
    # a closed STL ball (radius 0.2) buried inside the block: every contact node open, u = 0
    "buried ball": ('type = "surface"\nfile = "buried.stl"\n', "its deepest part lies inside the body"),
    # the ball above the block pushed 2 down in one step: it ends below the block, the contact force upward
    "ball pushed through": ('type = "surface"\nfile = "ball.stl"\ndisplacement = [0, 0, -2.0]\n',
                            "its deepest part would pass through the body"),
    # a sphere moved 2000 down: sampled at the old rate the centre stepped over the block
    "long move": ('type = "sphere"\ncenter = [1, 0.5, 1.5]\nradius = 0.3\ndisplacement = [0, 0, -2000.0]\n',
                  "its centre would pass through the body"),
    # the ball turned half a turn about a point inside the block: translation 0, so only the rotation moves it
    "turned through": ('name = "b"\ntype = "surface"\nfile = "ball.stl"\n[[path.step]]\n[[path.step]]\n'
                       'rotate = { b = [180, [0, 1, 0], [1, 0.5, 0.5]] }\n', "from rotation none to [180"),
    "sphere turned through": ('name = "b"\ntype = "sphere"\ncenter = [1, 0.5, 1.5]\nradius = 0.3\n'
                              '[[path.step]]\n[[path.step]]\nrotate = { b = [180, [0, 1, 0], [1, 0.5, 0.5]] }\n',
                              "its centre would pass through the body"),
    # a sphere 1e200 away: the gaps overflowed the residual (NaN) and the stress statistics raised (exit 1)
    "far away": ('type = "sphere"\ncenter = [1e200, 1e200, 1e200]\nradius = 1.0\n', "farther than 1e+12 times it"),
    # solid sides given as the body's side: "no contact", u = 0
    "plane facing away": ('type = "plane"\npoint = [0, 0, 1.0]\nnormal = [0, 0, 1]\ndisplacement = [0, 0, -0.01]\n',
                          "every node of the body lies inside the obstacle"),
    "open surface facing away": ('type = "surface"\nfile = "up.stl"\ndisplacement = [0, 0, -0.01]\n',
                                 "side = 'outward' makes the body's side solid"),
}


@pytest.mark.parametrize("case", sorted(OBSTACLES))
def test_obstacles_the_contact_nodes_cannot_see_exit_2(mpi_tmp_path, capsys, case):
    """Each solved to "no contact" or to a force of the wrong sign with exit 0."""
    obstacle, fragment = OBSTACLES[case]
    shared(mpi_tmp_path / "ball.stl", icosphere(0.3, (1.0, 0.5, 1.5), level=2))
    shared(mpi_tmp_path / "buried.stl", icosphere(0.2, (1.0, 0.5, 0.5), level=2))
    shared(mpi_tmp_path / "up.stl", rectangle((-1.0, -1.0), (3.0, 2.0), z=1.0))
    scene = shared(mpi_tmp_path / "o.toml", BLOCK + "[[obstacle]]\n" + obstacle)
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "o")) == EXIT_INPUT
    one_line(capsys, "obstacle 1", fragment)
    if "[[path.step]]" in obstacle:  # refused at step 2: step 1 was solved, and is kept
        summary = json.loads((mpi_tmp_path / "o" / "summary.json").read_text())
        assert summary["path"]["completed"] == 1 and [s["converged"] for s in summary["steps"]] == [True]
    else:
        assert not (mpi_tmp_path / "o").exists()


#: The block free but for its right face, which a path slides by 0.9 along x1; a ball above it.
SLID_BLOCK = ('[body]\nlev = 2\ngap = "0.0*x1"\nclamped = []\ncontact = ["{contact}"]\n[tractions]\n'
              '[prescribed]\nright = [0.0, 0.0, 0.0]\n[[obstacle]]\nname = "ball"\ntype = "sphere"\n'
              'center = {center}\nradius = {radius}\n[[path.step]]\nprescribed = {{ right = [0.9, 0.0, 0.0] }}\n'
              '[[path.step]]\nprescribed = {{ right = [0.9, 0.0, 0.0] }}\nmove = {{ ball = {move} }}\n')


def test_an_obstacle_moved_through_the_slid_body_keeps_the_steps_before(mpi_tmp_path, capsys):
    """Finite sliding: the ball moved down through the block where step 1 slid it (x1 in [0.9, 2.9]), not where
    it was (the reference block ends at x1 = 2 < 2.5): the reference check passed it and it ended buried in the
    block with exit 0 and no contact. Now exit 2 naming the step and the obstacle, step 1 written."""
    scene = shared(mpi_tmp_path / "t.toml", SLID_BLOCK.format(contact="top", center="[2.5, 0.5, 1.5]",
                                                              radius=0.2, move="[0.0, 0.0, -1.0]"))
    out = mpi_tmp_path / "t"
    assert run("--scene", str(scene), "--out", str(out)) == EXIT_INPUT
    one_line(capsys, "bad input at step 2", "would pass through the body", "the 1 solve(s) before it")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["path"]["completed"] == 1 and len(summary["steps"]) == 1 and summary["steps"][0]["converged"]


def test_an_obstacle_clear_of_the_slid_body_is_not_refused(mpi_tmp_path):
    """The ball brought down beside the block's left face where step 1 slid it (x1 = 0.9), 0.01 into it: the
    reference block (x1 from 0) had it buried (exit 2); now it presses the face along +x1 (and drags it down by
    friction, F = 0.23, as it comes down)."""
    scene = shared(mpi_tmp_path / "t.toml", SLID_BLOCK.format(contact="left", center="[0.3, 0.5, 2.0]",
                                                              radius=0.4, move="[0.21, 0.0, -1.5]"))
    out = mpi_tmp_path / "t"
    assert run("--scene", str(scene), "--out", str(out)) == 0
    summary = json.loads((out / "summary.json").read_text())
    force = summary["contact_force"]
    assert summary["contact_nodes"] >= 1 and force[0] > 0.05 and abs(force[1]) < 1e-4 * force[0]
    assert force[2] < 0.0  # the cone at the node is among the physics checks of exit 0


def test_a_closed_surface_pressed_in_still_solves(mpi_tmp_path):
    """The core check leaves a real indentation alone: the ball pressed 0.05 into the block (a sixth of its
    radius) solves, with a downward contact force."""
    shared(mpi_tmp_path / "ball.stl", icosphere(0.3, (1.0, 0.5, 1.3), level=2))
    scene = shared(mpi_tmp_path / "p.toml", BLOCK + '[[obstacle]]\ntype = "surface"\nfile = "ball.stl"\n'
                   'displacement = [0, 0, -0.05]\n')
    out = mpi_tmp_path / "p"
    assert run("--scene", str(scene), "--out", str(out)) == 0
    force = json.loads((out / "summary.json").read_text())["contact_force"]
    assert force[2] < 0.0 and abs(force[2]) > 10 * max(abs(force[0]), abs(force[1]))


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_the_surface_cache_follows_the_file_not_its_name(tmp_path, monkeypatch):
    """Triangles were cached by the file's name: a rewritten file, or another file of the same relative name after
    a change of directory, silently gave the old geometry. An obstacle keeps the geometry it was created with."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    write_stl(tmp_path / "a" / "s.stl", rectangle((0.0, 0.0), (1.0, 1.0), z=0.0))
    write_stl(tmp_path / "b" / "s.stl", rectangle((0.0, 0.0), (1.0, 1.0), z=2.0))
    point = np.array([[0.5, 0.5, 3.0]])
    monkeypatch.chdir(tmp_path / "a")
    first = Surface(file="s.stl")
    assert first.signed_distance(point)[0] == pytest.approx(3.0)
    monkeypatch.chdir(tmp_path / "b")
    assert Surface(file="s.stl").signed_distance(point)[0] == pytest.approx(1.0)
    assert first.moved([0.0, 0.0, 0.5]).signed_distance(point)[0] == pytest.approx(2.5)  # still a's triangles
    write_stl(tmp_path / "b" / "s.stl", rectangle((0.0, 0.0), (1.0, 1.0), z=2.5), binary=True)
    os.utime(tmp_path / "b" / "s.stl", ns=(1, 1))
    assert Surface(file="s.stl").signed_distance(point)[0] == pytest.approx(0.5)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_closed_surfaces_have_a_core_open_ones_none(tmp_path):
    ball = Surface(file=str(write_stl(tmp_path / "ball.stl", icosphere(0.5, (1.0, 0.5, 1.5), level=2))))
    core = ball.core(np.zeros(3), np.ones(3), 2)
    assert ball.closed and core.shape[0] > 0
    assert np.linalg.norm(core - [1.0, 0.5, 1.5], axis=1).max() <= 0.25 * 0.5 + 0.05  # depth >= 3/4 R
    cavity = Surface(file=str(tmp_path / "ball.stl"), side="inward")
    assert not cavity.closed and cavity.core(np.zeros(3), np.ones(3), 2).shape == (0, 3)
    patch = Surface(file=str(write_stl(tmp_path / "patch.stl", rectangle((0.0, 0.0), (1.0, 1.0)))))
    assert not patch.closed


# -- resuming a path ----------------------------------------------------------------------------------------
ROLLING = BLOCK.replace("lev = 2", "lev = 2") + """[friction]
coefficient = 0.5
[[obstacle]]
name = "roller"
type = "cylinder"
point = [0.5, 0.5, 1.5]
axis = [0.0, 1.0, 0.0]
radius = 0.5
displacement = [0.0, 0.0, -0.01]
[solver]
rtol = 1e-12
[[path.step]]
move = { roller = [0.01, 0.0, -0.01] }
rotate = { roller = [1.1459155902616465, [0.0, 1.0, 0.0], [0.5, 0.5, 1.5]] }
[[path.step]]
move = { roller = [0.02, 0.0, -0.01] }
rotate = { roller = [2.291831180523293, [0.0, 1.0, 0.0], [0.5, 0.5, 1.5]] }
[[path.step]]
move = { roller = [0.025, 0.0, -0.01] }
rotate = { roller = [4.0, [0.0, 1.0, 0.0], [0.5, 0.5, 1.5]] }
"""


def test_a_resumed_rotating_path_is_the_uninterrupted_path(mpi_tmp_path):
    """--start-step K with a rotating obstacle resumed with the whole rotation as the step's increment (the roller's
    friction force reversed); now the placement of step K, its rotation included, is the previous placement."""
    scene = shared(mpi_tmp_path / "roll.toml", ROLLING)
    full, resumed = mpi_tmp_path / "full", mpi_tmp_path / "resumed"
    assert run("--scene", str(scene), "--out", str(full)) == 0
    for k in (1, 2):
        assert run("--scene", str(scene), "--start", str(full / "solution.xdmf"), "--start-step", str(k),
                   "--out", str(resumed)) == 0
        for j in range(3 - k):  # the resumed set holds steps k+1..3; the full one t = 0 first
            a, b = last_displacement(resumed, j), last_displacement(full, k + 1 + j)
            assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max(), (k, j)
        steps = json.loads((resumed / "summary.json").read_text())["steps"]
        reference = json.loads((full / "summary.json").read_text())["steps"][k:]
        for s, r in zip(steps, reference, strict=True):
            assert np.allclose(s["contact_force"], r["contact_force"], rtol=1e-9, atol=1e-14)


PAIR_PATH = """[body]
shape = "mesh"
mesh = "{mesh}"
clamped = ["block_bottom"]
[boundaries]
block_top = 1
block_bottom = 2
block_sides = 3
curved = 4
flat = 5
[bodies]
block = 1
hemisphere = 2
[prescribed]
flat = [0.0, 0.0, -0.01]
[tractions]
[[contact_pair]]
slave = "curved"
master = "block_top"
friction = 0.3
[solver]
rtol = 1e-12
[[path.step]]
[[path.step]]
prescribed = { flat = [0.004, 0.0, -0.02] }
"""


def test_a_path_of_contact_pairs_without_an_obstacle_resumes(mpi_tmp_path):
    """Resuming a path of two bodies with no rigid obstacle was refused (shape (0,) against (0, 3))."""
    from meshes import hemisphere_on_block

    mesh = mpi_tmp_path / "hob.msh"
    if MPI.COMM_WORLD.rank == 0:
        hemisphere_on_block.build(contact=0.25, path=mesh, size=1.0)
    MPI.COMM_WORLD.barrier()
    scene = shared(mpi_tmp_path / "pair.toml", PAIR_PATH.replace("{mesh}", str(mesh)))
    full, resumed = mpi_tmp_path / "full", mpi_tmp_path / "resumed"
    assert run("--scene", str(scene), "--out", str(full)) == 0
    assert run("--scene", str(scene), "--start", str(full / "solution.xdmf"), "--start-step", "1",
               "--out", str(resumed)) == 0
    a, b = last_displacement(resumed), last_displacement(full)
    assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max()


# -- --accuracy and --rtol ----------------------------------------------------------------------------------
def test_accuracy_and_rtol_together_exit_2(mpi_tmp_path, capsys):
    """--accuracy silently replaced an explicit --rtol."""
    assert run("--lev", "0", "--rtol", "1e-5", "--accuracy", "1e-3", "--out", str(mpi_tmp_path / "o")) == EXIT_INPUT
    one_line(capsys, "--rtol 1e-05 and --accuracy 0.001: give one")
    scene = shared(mpi_tmp_path / "s.toml", "[solver]\nrtol = 1e-6\naccuracy = 1e-4\n")
    assert run("--scene", str(scene), "--lev", "0", "--out", str(mpi_tmp_path / "o")) == EXIT_INPUT
    one_line(capsys, "error: rtol = 1e-06 and accuracy = 0.0001: give one")  # SolverSettings' own message
    # a flag replaces the scene's other one, said in one line
    scene = shared(mpi_tmp_path / "r.toml", "[solver]\naccuracy = 1e-4\n")
    assert main(["--scene", str(scene), "--lev", "0", "--rtol", "1e-9", "--out", str(mpi_tmp_path / "o"),
                 "--no-plots"]) == 0
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert "--rtol 1e-09 replaces the scene's accuracy = 0.0001" in err
        summary = json.loads((mpi_tmp_path / "o" / "summary.json").read_text())
        assert summary["settings"]["accuracy"] is None and summary["settings"]["rtol"] == 1e-9


def test_a_loose_accuracy_is_not_checks_passed(mpi_tmp_path, capsys):
    """--accuracy 0.9 left a penetration of 3.4 % beside "checks passed" (the bound grew with rtol): the checks'
    bound is at most 1 %, the solve is not converged (exit 3) and says why: a decisive check beyond 1 % (which one
    depends on where the loose iteration stops: the penetration, or the equilibrium residual, 2.3 %)."""
    out = mpi_tmp_path / "loose"
    assert main(["--lev", "3", "--accuracy", "0.9", "--out", str(out), "--no-plots"]) == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert "the physics checks fail" in err and "too loose" in err, err
        summary = json.loads((out / "summary.json").read_text())
        checks = summary["physics_checks"]
        assert summary["converged"] is False and max(checks.get(key, 0.0) for key in DECISIVE_CHECKS) > 1e-2


# -- the API's entry points ----------------------------------------------------------------------------------
def _block(comm: MPI.Comm):
    import dolfinx.mesh

    msh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array([1.0, 1.0, 0.5])], [3, 3, 2])
    msh.topology.create_connectivity(2, 3)
    return msh


def _forms(msh):
    import dolfinx.fem
    import dolfinx.mesh
    import ufl

    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = ufl.inner(ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))) * ufl.dx
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    facets = np.concatenate([bottom, top])
    order = np.argsort(facets)
    tags = dolfinx.mesh.meshtags(msh, 2, facets[order].astype(np.int32),
                                 np.concatenate([np.full(bottom.size, 1),
                                                 np.full(top.size, 2)])[order].astype(np.int32))
    bc = dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.01]), dolfinx.fem.locate_dofs_topological(V, 2, top), V)
    return V, a, tags, bc


def test_api_entry_points_name_bad_arguments(mpi_tmp_path):
    """Each was a raw exception (ValueError, AttributeError, TypeError, PETSc error 86, AssertionError after
    destroy()) or was accepted silently (a report of another problem's result, a reaction of another mesh's BC,
    a NaN centre)."""
    from fenics_coulomb import ContactProblem, write_results

    comm = MPI.COMM_WORLD
    msh, other_msh = _block(comm), _block(comm)
    V, a, tags, bc = _forms(msh)
    V2, a2, tags2, bc2 = _forms(other_msh)

    def make(**kwargs):
        args = dict(bcs=[bc], contact=(tags, [1]), friction=0.3, petsc_options_prefix="hard_")
        args.update(kwargs)
        return ContactProblem(a, None, **args)

    with pytest.raises(InputError, match=r"bcs = DirichletBC: give a list"):
        make(bcs=bc)
    with pytest.raises(InputError, match=r"settings = \[1\]: give a SolverSettings"):
        make(settings=[1])
    with pytest.raises(InputError, match=r"petsc_options = \['ksp_type'\]: give a dict"):
        make(petsc_options=["ksp_type"])
    with pytest.raises(InputError, match="petsc_options: PETSc options 'ksp_type nonsense' cannot be used"):
        make(petsc_options={"ksp_type": "nonsense"})
    with pytest.raises(InputError, match="petsc_options: PETSc options 'pc_type bogus' cannot be used"):
        make(petsc_options={"pc_type": "bogus"})
    with pytest.raises(InputError, match=r"marker 7 is carried by no facet of the facet tags \(their values: "
                                         r"\[1, 2\]\)"):
        make(contact=(tags, [7]))  # every rank's values, also on a rank that holds only one of them
    problem = make()
    other = ContactProblem(a2, None, bcs=[bc2], contact=(tags2, [1]), petsc_options_prefix="hard2_")
    _, result = problem.solve()
    _, foreign = other.solve()
    with pytest.raises(InputError, match="move: plane: displacement = 'down': must be 3 finite numbers"):
        problem.move(0, "down")
    with pytest.raises(InputError, match="report: result = 'x'"):
        problem.report("x")
    with pytest.raises(InputError, match="report: the result is not one of this problem's solve"):
        problem.report(foreign)
    with pytest.raises(InputError, match=r"reactions\['b'\]: a boundary condition of another function space"):
        problem.report(result, reactions={"b": bc2})
    report = problem.report(result, reactions={"top": bc})
    assert report.reactions["top"][2] < 0.0  # the support pushes the block down onto the plane
    with pytest.raises(InputError, match=r"contact_radius: center = \[nan, 0, 0\]: must be 3 finite numbers"):
        report.contact_radius(center=[np.nan, 0, 0])
    with pytest.raises(InputError, match=r"contact_radius: normal = \[0, 0, 0\]: a zero vector"):
        report.contact_radius(center=[0, 0, 0], normal=[0, 0, 0])
    for use in (lambda: problem.reset("x"), lambda: problem.solve("x")):
        with pytest.raises(InputError, match="displacement = 'x': give a dolfinx.fem.Function"):
            use()
    with pytest.raises(InputError, match="reset: obstacle_displacements = 'x'"):
        problem.reset(obstacle_displacements="x")
    with pytest.raises(InputError, match="contact: markers = 1: give a list"):
        make(contact=(tags, 1))
    with pytest.raises(InputError, match="write_results: problem = NoneType"):
        write_results(mpi_tmp_path / "o", None, result)
    with pytest.raises(InputError, match="write_results: the result is not one of this problem's solve"):
        write_results(mpi_tmp_path / "o", problem, foreign)
    with pytest.raises(InputError, match="write_results: plots = 'no': give True or False"):
        write_results(mpi_tmp_path / "o", problem, result, plots="no")
    with pytest.raises(InputError, match="write_results: label = 3: give the figures' title"):
        write_results(mpi_tmp_path / "o", problem, result, label=3)
    assert not (mpi_tmp_path / "o").exists()
    with pytest.raises(InputError, match="petsc_options: PETSc options 'pc_type bogus' cannot be used"):
        problem.set_solver(petsc_options={"pc_type": "bogus"})
    assert problem.solve()[1].converged  # the solver was kept
    other.destroy()
    problem.destroy()
    for use in (problem.solve, lambda: problem.report(result), lambda: problem.move(0, [0.0, 0.0, 0.0]),
                lambda: problem.A, lambda: problem.reset()):
        with pytest.raises(RuntimeError, match="the problem was destroyed"):
            use()


@contextlib.contextmanager
def _callers_gmsh_session():
    """A gmsh session of the caller's, quiet, with its current model "mine" holding a unit box (finalized after)."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("mine")
        gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        yield gmsh
    finally:
        gmsh.finalize()


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_surface_from_msh_leaves_the_callers_gmsh_session(tmp_path):
    """Surface("x.msh") finalized the caller's gmsh session (and replaced its model)."""
    with _callers_gmsh_session() as gmsh:
        gmsh.model.mesh.generate(2)
        gmsh.write(str(tmp_path / "box.msh"))
        surface = Surface(file=str(tmp_path / "box.msh"))
        assert gmsh.isInitialized() and gmsh.model.getCurrent() == "mine"
        assert len(gmsh.model.getEntities(3)) == 1
        assert surface.signed_distance(np.array([[0.5, 0.5, 2.0]]))[0] == pytest.approx(1.0)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_read_gmsh_takes_a_path_and_leaves_the_callers_gmsh_session():
    """read_gmsh(Path(...)) was refused ("'PosixPath' object has no attribute 'encode'") and ended the caller's gmsh
    session; now a Path reads, and an open session keeps its model and terminal option."""
    from fenics_coulomb import read_gmsh

    with _callers_gmsh_session() as gmsh:
        msh, tags = read_gmsh(ROOT / "meshes" / "roller.msh", MPI.COMM_SELF)
        assert msh.topology.index_map(3).size_global > 0 and tags.values.size > 0
        assert gmsh.isInitialized() and gmsh.model.getCurrent() == "mine" and gmsh.model.list() == ["", "mine"]
        assert len(gmsh.model.getEntities(3)) == 1 and gmsh.option.getNumber("General.Terminal") == 0
    msh, _ = read_gmsh(ROOT / "meshes" / "roller.msh", MPI.COMM_SELF)  # without a session: its own, ended after
    assert not gmsh.isInitialized()


def _gmsh_block(path: Path, gaps: bool) -> None:
    """A block [0, 1] x [0, 1] x [0, 0.5] as MSH 2.2 (bottom 1, top 2, volume 1); ``gaps``: node numbers doubled."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addBox(0, 0, 0, 1, 1, 0.5)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [1], 1)
        faces = {round(gmsh.model.occ.getCenterOfMass(2, s)[2], 6): s for _, s in gmsh.model.getEntities(2)}
        gmsh.model.addPhysicalGroup(2, [faces[0.0]], 1)
        gmsh.model.addPhysicalGroup(2, [faces[0.5]], 2)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    if not gaps:
        return
    head, rest = path.read_text().split("$Nodes\n", 1)
    nodes, tail = rest.split("$EndNodes\n", 1)
    lines = nodes.splitlines()
    nodes = [lines[0]] + [" ".join([str(2 * int(w[0])), *w[1:]]) for w in map(str.split, lines[1:])]
    between, rest = tail.split("$Elements\n", 1)
    elements, end = rest.split("$EndElements\n", 1)
    lines = elements.splitlines()
    out = [lines[0]]
    for w in map(str.split, lines[1:]):
        k = 3 + int(w[2])
        out.append(" ".join(w[:k] + [str(2 * int(v)) for v in w[k:]]))
    path.write_text(head + "$Nodes\n" + "\n".join(nodes) + "\n$EndNodes\n" + between + "$Elements\n"
                    + "\n".join(out) + "\n$EndElements\n" + end)


def test_a_msh_file_with_gaps_in_its_node_numbers_is_read(mpi_tmp_path):
    """MSH 2.2 allows gaps in the node numbers; DOLFINx's reader assumed 1..n (an AssertionError, exit 1). The
    same block numbered with gaps gives the same solution."""
    if MPI.COMM_WORLD.rank == 0:
        _gmsh_block(mpi_tmp_path / "plain.msh", gaps=False)
        _gmsh_block(mpi_tmp_path / "gaps.msh", gaps=True)
    MPI.COMM_WORLD.barrier()
    results = []
    for name in ("plain", "gaps"):
        scene = shared(mpi_tmp_path / f"{name}.toml", f'[body]\nshape = "mesh"\nmesh = "{name}.msh"\n'
                       'clamped = []\ncontact = ["bottom"]\n[boundaries]\nbottom = 1\ntop = 2\n[tractions]\n'
                       '[prescribed]\ntop = [0.0, 0.0, -0.01]\n[[obstacle]]\ntype = "plane"\n'
                       'point = [0, 0, -0.005]\nnormal = [0, 0, 1]\n[solver]\nrtol = 1e-12\n')
        assert run("--scene", str(scene), "--out", str(mpi_tmp_path / name)) == 0
        results.append(json.loads((mpi_tmp_path / name / "summary.json").read_text()))
    assert results[0]["contact_force"][2] > 0.0
    assert np.allclose(results[0]["contact_force"], results[1]["contact_force"], rtol=0, atol=1e-9)


# -- a full disk while writing -------------------------------------------------------------------------------
def test_a_full_disk_before_the_hdf5_write_is_exit_4_in_one_line(mpi_tmp_path, capsys, monkeypatch):
    """HDF5 meeting a full disk or a file-size limit mid-write crashed when it closed the broken dataset (SIGSEGV,
    exit 59) and left .NAME.partial-*: the room is checked before HDF5 writes (the real limit:
    tests/cli/test_reliability.py's RLIMIT_FSIZE run). Here the file system reports one free block on every rank."""
    out = mpi_tmp_path / "out"
    assert run("--lev", "0", "--out", str(out)) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real = os.statvfs

    class Full:
        def __init__(self, path):
            stat = real(path)
            self.f_frsize, self.f_bavail = stat.f_frsize, 1

    monkeypatch.setattr(os, "statvfs", Full)
    capsys.readouterr()
    assert run("--lev", "1", "--out", str(out)) == 4
    one_line(capsys, "solution.h5: No space left on device", "earlier results are kept")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in mpi_tmp_path.iterdir()) == ["out"]


#: The cuboid pushed by its left face (0.01 along x1) and pressed from the top (0.01 down), the contact boundary
#: its bottom and right faces, frictionless; {obstacles} below.
CORNER = """
[body]
lev = 2
gap = "0.0*x1"
clamped = []
contact = {contact}
[material]
young = 70.0
poisson = 0.3
[friction]
coefficient = 0.0
[tractions]
[prescribed]
top = ["free", "free", -0.01]
left = [{left}, "free", "free"]
[[obstacle]]
name = "floor"
type = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[obstacle]]
name = "wall"
type = "plane"
point = [2.0, 0.0, 0.0]
normal = [-1.0, 0.0, 0.0]
"""


@pytest.mark.parametrize("sliding", ["small", "finite"])
def test_a_node_between_two_obstacles_is_no_exit_0(mpi_tmp_path, sliding):
    """The bottom-right edge rests on the floor and the wall at once, and a contact node meets one obstacle's
    constraint: small sliding gave exit 0 with those nodes 3.3e-3 below the floor (35 % of the press; the wall had
    taken them), finite sliding exit 3 on an unsettled geometry. Now both exit 3, the written checks naming the
    corner (obstacle_penetration)."""
    scene = shared(mpi_tmp_path / "corner.toml", CORNER.format(contact='["bottom", "right"]', left=0.01))
    out = mpi_tmp_path / sliding
    assert run("--scene", str(scene), "--sliding", sliding, "--out", str(out)) == EXIT_DIVERGED
    if sliding == "small":
        data = json.loads((out / "summary.json").read_text())
        assert data["reason"] == "physics_check" and data["physics_checks"]["obstacle_penetration"] > 0.1


def test_contact_boundary_nodes_a_support_drives_into_an_obstacle(mpi_tmp_path, capsys):
    """The left face held in every component at 0.02 down, the floor its contact boundary: its bottom edge is no
    contact node and its prescribed position lies 0.02 inside the floor (exit 0 with the nodes there, penetration
    reported 2e-15): now exit 2 naming the node. Held in x1 only (pushed 0.01 against the wall), the top-right edge
    moves along the wall at a held value, is no contact node and ends 2.3e-3 inside it: reported
    (support_penetration) and warned."""
    driven = CORNER.replace('left = [{left}, "free", "free"]', 'left = [0.0, 0.0, -0.02]').replace(
        'top = ["free", "free", -0.01]', "")
    scene = shared(mpi_tmp_path / "driven.toml", driven.format(contact='["bottom"]'))
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "driven")) == EXIT_INPUT
    one_line(capsys, "the supports hold the contact-boundary node at (", "0.02 inside obstacle", "floor")
    floor = '[[obstacle]]\nname = "floor"\ntype = "plane"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n'
    edge = CORNER.format(contact='["right"]', left=0.01).replace(floor, "") + "[roller]\nbottom = [1, 2]\n"
    assert "floor" not in edge
    scene = shared(mpi_tmp_path / "edge.toml", edge)
    out = mpi_tmp_path / "edge"
    assert main(["--scene", str(scene), "--out", str(out), "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    assert data["physics_checks"]["support_penetration"] > 0.1
    printed = capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        assert "that a support holds" in printed.out + printed.err


def test_a_body_moved_through_a_ball_in_one_solve_is_no_exit_0(mpi_tmp_path, capsys):
    """The block's top moved 0.8 along x1 in one static solve, a ball (r 0.3) 0.5 beyond its right face: the block
    passes over the ball, no contact node ever meets it, and the solve gave exit 0 with the ball inside the body
    (23 nodes around it, the ball's centre 0.3 inside the right face). The obstacle's core is now located in the
    deformed body after the solve: exit 3 naming the ball and the cure (substeps)."""
    scene = shared(mpi_tmp_path / "over.toml", """
[body]
lev = 2
gap = "0.0*x1"
clamped = []
contact = ["bottom", "right", "sides", "left"]
[friction]
coefficient = 0.0
[tractions]
[prescribed]
top = [0.8, 0.0, 0.0]
[[obstacle]]
name = "ball"
type = "sphere"
center = [2.5, 0.5, 0.5]
radius = 0.3
""")
    out = mpi_tmp_path / "over"
    assert main(["--scene", str(scene), "--out", str(out), "--no-plots", "--quiet"]) == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    assert data["reason"] == "physics_check" and not data["converged"]
    printed = capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        assert "sphere 'ball'): its centre lies inside the deformed body" in printed.err
        assert "give the motion in substeps" in printed.err


def test_an_unloaded_step_passes_the_checks(mpi_tmp_path):
    """A block pressed onto the plane, then unloaded: ũ = 0 meets the stopping rule, and a bottom node 4.5e-17 below
    the plane (the mesh generator's round-off) made obstacle_penetration 2.6 of a displacement scale that is itself
    round-off (exit 3, blaming a second obstacle). Round-off below a surface counts as touching, as the placement
    counts it; the unloaded step's written balance is not a 100 % imbalance of forces that are all round-off."""
    scene = shared(mpi_tmp_path / "unload.toml", '[body]\nlev = 2\ngap = "0.0*x1"\nclamped = ["left"]\n'
                   'contact = ["bottom"]\n[tractions]\ntop = [0, 0, -0.1]\n[[path.step]]\n[[path.step]]\n'
                   'tractions = { top = [0, 0, 0] }\n')
    out = mpi_tmp_path / "unload"
    assert run("--scene", str(scene), "--out", str(out)) == 0
    data = json.loads((out / "summary.json").read_text())
    assert data["physics_checks"]["obstacle_penetration"] == 0.0 and data["physics_checks"]["reaction_balance"] < 1e-6


@pytest.mark.parametrize(("tables", "fragment"), [
    ('clamped = ["left"]\n[roller]\nleft = [0]\n', "boundary 'left' is in [body] clamped and in [roller]"),
    ('clamped = ["bottom"]\n[prescribed]\ntop = [0, 0, -0.01]\n[roller]\ntop = [0]\n',
     "boundary 'top' is in [prescribed] and in [roller]"),
    ('clamped = ["left", "top"]\n[prescribed]\ntop = [0, 0, -0.01]\n', "boundary 'top' is in [body] clamped and in"),
])
def test_a_boundary_in_two_support_tables_exit_2(mpi_tmp_path, capsys, tables, fragment):
    """A boundary named in two support tables kept one table's conditions and reaction: a clamped face also a roller
    reported no reaction (balance 0.37 off), a clamped face also prescribed lost its press. Now exit 2."""
    scene = shared(mpi_tmp_path / "dup.toml", "[body]\nlev = 1\n" + tables)
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "dup")) == EXIT_INPUT
    one_line(capsys, fragment)


def test_supports_and_names_that_hide_a_penetration_or_a_force(mpi_tmp_path, capsys):
    """A face held at 0.02 down in x2 and x3 only (x1 free) drives its bottom edge into the floor whatever x1 does:
    exit 0 with a warning before, exit 2 now (the plane's normal is a held component). An obstacle called 'pair 1'
    beside an unnamed contact pair shared path.csv's columns with it and lost its own: exit 2."""
    scene = shared(mpi_tmp_path / "free.toml", '[body]\nlev = 2\ngap = "0.0*x1"\nclamped = []\ncontact = ["bottom"]\n'
                   '[friction]\ncoefficient = 0.3\n[tractions]\n[prescribed]\nleft = ["free", 0.0, -0.02]\n')
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "free")) == EXIT_INPUT
    one_line(capsys, "the supports hold the contact-boundary node at (", "0.02 inside obstacle")
    mesh = ROOT / "meshes" / "slide_off.msh"
    text = (ROOT / "demos" / "scenes" / "slide_off.toml").read_text().replace("../../meshes/slide_off.msh", str(mesh))
    text = text[: text.index("[[path.step]]")].replace('clamped = ["lower_bottom"]', 'clamped = ["lower_bottom"]\n'
                                                       'contact = ["lower_sides"]')
    text += '[[obstacle]]\nname = "pair 1"\ntype = "plane"\npoint = [0.0, 0.0, -1.0]\nnormal = [0.0, 0.0, 1.0]\n'
    scene = shared(mpi_tmp_path / "clash.toml", text)
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "clash")) == EXIT_INPUT
    one_line(capsys, "obstacle 1 is called 'pair 1', the name of a contact pair")


def test_a_body_moved_past_a_ball_in_one_solve_is_no_exit_0(mpi_tmp_path, capsys):
    """The block's top moved 3.0 along x1 in one static solve past a ball 0.5 beyond its right face: at the end the
    ball lies behind the block (every node 0.2 outside it), exit 0 before; the ball's centre swept back along the
    body's motion passes through it: exit 3."""
    scene = shared(mpi_tmp_path / "past.toml", '[body]\nlev = 2\ngap = "0.0*x1"\nclamped = []\n'
                   'contact = ["bottom", "right", "sides", "left"]\n[friction]\ncoefficient = 0.0\n[tractions]\n'
                   '[prescribed]\ntop = [3.0, 0.0, 0.0]\n[[obstacle]]\nname = "ball"\ntype = "sphere"\n'
                   'center = [2.5, 0.5, 0.5]\nradius = 0.3\n')
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "past")) == EXIT_DIVERGED
    printed = capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        assert "or passed through it as the body moved" in printed.err
