"""The rigid approach (fenics_coulomb/model/rigid_approach.py): a body held by contact alone is brought onto its
obstacles along its free rigid motions before the first Newton step. A block on a plane, pressed by a traction and
held sideways by rollers (its vertical motion free), ran off at gaps 1e-3, 1e-5, 1e-8, 1e-10 (exit 3) and converged
at 1e-4 and 1e-6 by chance; a block over a cylinder with its tilt free as well took 25 Newton steps. 1 and 2 ranks."""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb.cli import EXIT_DIVERGED, main
from fenics_coulomb.model.rigid_approach import rigid_approach
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene

BLOCK = """
[body]
lev = {lev}
gap = "{gap} + 0.0*x1"
clamped = []
contact = ["bottom"]
[material]
young = 70.0
poisson = 0.0
[friction]
coefficient = {friction}
[tractions]
top = [{shear}, 0.0, {press}]
[roller]
{rollers}
{extra}
"""
SIDEWAYS = "left = [0]\nsides = [1]"
CYLINDER = """[[obstacle]]
name = "log"
type = "cylinder"
point = [0.7, 0.5, -0.501]
axis = [0.0, 1.0, 0.0]
radius = 0.5
"""


def scene_file(tmp: Path, name: str, gap: float = 0.0, friction: float = 0.0, press: float = -0.1,
               rollers: str = SIDEWAYS, extra: str = "", lev: int = 2, shear: float = 0.0) -> Path:
    path = tmp / f"{name}.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(BLOCK.format(gap=gap, friction=friction, press=press, rollers=rollers, extra=extra, lev=lev,
                                     shear=shear))
    MPI.COMM_WORLD.barrier()
    return path


def scene(*args: object, **kwargs: object) -> Scene:
    return Scene.from_toml(scene_file(*args, **kwargs))  # type: ignore[arg-type]


@pytest.mark.parametrize("gap", [0.0, 1e-10, 1e-3])
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_a_block_pressed_onto_a_plane_from_any_gap(mpi_tmp_path, gap, friction):
    """The approach is the block translated down by its gap (every free DOF, exactly); the solve then carries the
    load on the plane: 0.2 through every one of the 45 bottom nodes at 0.1 GPa, in 5 Newton steps."""
    with build_problem(scene(mpi_tmp_path, f"b{gap}{friction}", gap, friction), MPI.COMM_WORLD).problem as problem:
        model = problem.model
        approach = rigid_approach(model, model.coupling.motions)
        assert approach is not None
        assert np.allclose(approach.reshape(-1, 3), [0.0, 0.0, -gap], rtol=0.0, atol=1e-12 * max(gap, 1e-3))
        u, result = problem.solve()
        assert problem.last_start == "approach" and result.converged and result.iterations <= 6
        force = MPI.COMM_WORLD.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM)
        assert abs(force[2] - 0.2) <= 1e-7 and result.p == 45
        closed = MPI.COMM_WORLD.allreduce(int(np.count_nonzero(result.states != 0)), op=MPI.SUM)
        assert closed == 45
        report = problem.report(result)
        assert np.allclose(report.nodes.pressure, 0.1, rtol=1e-6)
        checks = problem.checks(result)
        assert checks["penetration"] < 1e-6 and checks["reaction_balance"] < 1e-6


def test_a_block_pulled_off_has_no_approach(mpi_tmp_path):
    """Pulled up, nothing blocks the free motion: the program is unbounded, no approach; the rule's start is kept."""
    with build_problem(scene(mpi_tmp_path, "lift", 1e-3, press=0.1), MPI.COMM_WORLD).problem as problem:
        model = problem.model
        assert rigid_approach(model, model.coupling.motions) is None
        problem.initial_displacement()
        assert problem.last_start in ("zero", "undeformed")


def test_a_tilt_left_free_over_a_cylinder(mpi_tmp_path):
    """Held in x1 on its top and in x2 on its sides, the block's vertical motion and its tilt about x2 are free; over a
    cylinder off its centre the approach lowers and tilts it onto the cylinder's top line, within the linearized
    gaps' curvature error; the solve (finite sliding: the gaps of the cylinder re-evaluated) gives the same answer as
    from the rule's start, in fewer steps (measured 8 against 18 Newton steps at lev 3; at lev 2 the rule's start
    fails: the linear solves break down on the free motions, exit 3)."""
    rollers = "top = [0]\nsides = [1]"
    held = scene(mpi_tmp_path, "tilt", 0.0, 0.2, press=-0.05, rollers=rollers, extra=CYLINDER, lev=3)
    with build_problem(held, MPI.COMM_WORLD).problem as problem:
        model = problem.model
        assert int(model.coupling.motions.free.sum()) == 2
        approach = rigid_approach(model, model.coupling.motions)
        assert approach is not None
        _, result = problem.solve()
        assert problem.last_start == "approach" and result.converged
        approached = (result.iterations, MPI.COMM_WORLD.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM))
    with build_problem(held.override(start="undeformed"), MPI.COMM_WORLD).problem as problem:
        problem.model.coupling.approach = lambda model: None  # the rule's start, as before the approach
        _, result = problem.solve()
        assert problem.last_start == "undeformed" and result.converged
        ruled = (result.iterations, MPI.COMM_WORLD.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM))
    assert approached[0] < ruled[0]
    assert np.linalg.norm(approached[1] - ruled[1]) <= 1e-6 * np.linalg.norm(ruled[1])


def test_no_load_along_the_free_motion_needs_no_contact(mpi_tmp_path):
    """Unloaded, the block at rest on its floor is the solution: 0 Newton steps (a round-off gap counted as touching
    must not make the start's residual non-zero: it did, and 10 steps ended at exit 3 on negative_pressure 1.03).
    Sheared along x only, which the left roller holds, the loads do no work along the free vertical motion: no
    contact force is needed, and the lost-support check (a load's resultant) must not fail it (it did: exit 3)."""
    with build_problem(scene(mpi_tmp_path, "rest", 0.0, 0.3, press=0.0), MPI.COMM_WORLD).problem as problem:
        u, result = problem.solve()
        assert result.converged and result.iterations == 0 and not np.any(u.x.array)
    with build_problem(scene(mpi_tmp_path, "shear", 0.0, 0.3, press=0.0, shear=0.05, lev=3),
                       MPI.COMM_WORLD).problem as problem:
        assert rigid_approach(problem.model, problem.model.coupling.motions) is None
        _, result = problem.solve()
        assert result.converged
        force = MPI.COMM_WORLD.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM)
        # the force the solve's accuracy leaves: with r the free vertical motion (A r = 0, rᵀl = 0), A u − l + z = Γe
        # gives rᵀz = rᵀΓe, |Σ pᵢ| <= √N ‖Γe‖ <= √N × the stopping target (N nodes), and |Σ tᵢ| <= F Σ pᵢ
        nodes = problem.V.dofmap.index_map.size_global
        assert np.linalg.norm(force) <= np.sqrt(1 + 0.3**2) * np.sqrt(nodes) * result.target
        assert problem.checks(result)["reaction_balance"] <= 1e-6


@pytest.mark.parametrize(("friction", "shear"), [(0.0, 0.0), (0.3, 0.02)])
def test_a_block_meshed_onto_its_floor_and_pressed_converges(mpi_tmp_path, friction, shear):
    """The real command. The block meshed onto its plane (its bottom nodes 2e-17–3.5e-16 above it), pressed, held only
    sideways: every node was open at ũ = 0, the Newton matrix singular along the vertical motion, and the solve ran off
    to |u| = 2.3e12 (exit 0, then exit 3 by the lost-support check). Now: the load on the plane, 0.1 GPa at each of the
    45 nodes; with friction and a sideways push as well."""
    path = scene_file(mpi_tmp_path, f"floor{friction}", 0.0, friction, shear=shear)
    out = mpi_tmp_path / f"floor{friction}"
    assert main(["--scene", str(path), "--out", str(out), "--no-plots", "--quiet"]) == 0
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    assert data["contact_nodes"] == 45 and data["newton_iterations"] <= 8
    assert abs(data["contact_force"][2] - 0.2) <= 1e-6 and data["physics_checks"]["reaction_balance"] <= 1e-6
    if shear == 0.0:
        assert abs(data["peak_pressure"] - 0.1) <= 1e-6
    else:  # the push shared by the left roller and the floor's friction
        assert data["state_counts"]["stick"] + data["state_counts"]["slip"] == 45


def test_a_body_no_contact_node_holds_is_no_exit_0(mpi_tmp_path, capsys):
    """The same block pulled up off the plane: nothing holds its vertical motion and the solve runs off along it. A
    converged state in which no contact node holds a body that contact alone holds would balance the load with the
    free motion's round-off (|u| = 2.3e12, reaction_balance 1.0, exit 0 once): a failure (exit 3) naming the free
    motions and the load."""
    path = scene_file(mpi_tmp_path, "lift", 0.0, press=0.1)
    assert main(["--scene", str(path), "--out", str(mpi_tmp_path / "lift"), "--no-plots"]) == EXIT_DIVERGED
    printed = capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        assert "rigid motion(s) of the body free and no contact node is closed" in printed.err


def test_a_push_along_a_motion_nothing_holds_is_no_exit_0(mpi_tmp_path, capsys):
    """Found by a review (present before the approach): the block on a frictionless floor, held only in x2, pushed
    sideways along x1 as well as down: nothing holds the x1 motion, the solve ran off to |u| = 4e10 and ended with
    exit 0, every residual small (the round-off of K·ũ standing in for the missing force; contact force x −3.8e-6
    against the 0.04 applied). Now the free motions' balance decides: exit 3, naming the cause."""
    path = scene_file(mpi_tmp_path, "runaway", 0.0, 0.0, shear=0.02, rollers="sides = [1]", lev=3)
    out = mpi_tmp_path / "runaway"
    assert main(["--scene", str(path), "--out", str(out), "--no-plots"]) == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    assert data["reason"] == "physics_check" and data["physics_checks"]["free_balance"] > 0.1
    printed = capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        assert "free_balance" in printed.err and "support that motion" in printed.err


def test_friction_holds_the_sideways_motion_from_a_gap(mpi_tmp_path):
    """Found by the same review: 1e-3 above the floor, F = 0.3, pushed sideways 0.02 and down 0.1 (friction holds the
    push): the program maximized the work along x1 too, which no gap blocks — unbounded, so no approach at all, and
    the solve ran off (exit 3). Only the motions that move a contact node along its normal make the approach now
    (here the vertical one): the push on the floor, the free motions balanced, sticking."""
    held = scene(mpi_tmp_path, "friction", 1e-3, 0.3, shear=0.02, rollers="sides = [1]")
    with build_problem(held, MPI.COMM_WORLD).problem as problem:
        approach = rigid_approach(problem.model, problem.model.coupling.motions)
        assert approach is not None
        assert np.allclose(approach.reshape(-1, 3), [0.0, 0.0, -1e-3], rtol=0.0, atol=1e-15)
        _, result = problem.solve()
        assert result.converged and problem.last_start == "approach"
        force = MPI.COMM_WORLD.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM)
        assert np.allclose(force, [-0.04, 0.0, 0.2], atol=1e-7)
        assert result.checks["free_balance"] < 1e-6


def test_a_path_that_unloads_and_presses_again(mpi_tmp_path):
    """Found by the same review: pressed, unloaded (the body back at its gap: ũ = 0), pressed again — the third step
    started from the second's solution without the approach and ran off (exit 3; the static press converges). A step
    that starts from the previous one is brought onto the obstacles too, when its body is off them."""
    path = scene_file(mpi_tmp_path, "repress", 1e-3, 0.3)
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(path.read_text() + '[[path.step]]\n[[path.step]]\ntractions = { top = [0.0, 0.0, 0.0] }\n'
                        '[[path.step]]\n')
    MPI.COMM_WORLD.barrier()
    out = mpi_tmp_path / "repress"
    assert main(["--scene", str(path), "--out", str(out), "--no-plots", "--quiet"]) == 0
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    assert abs(data["contact_force"][2] - 0.2) <= 1e-7 and data["contact_nodes"] == 45


BOX = """
[body]
shape = "mesh"
mesh = "{mesh}"
clamped = []
contact = ["bottom"]
[boundaries]
left = 1
right = 2
bottom = 3
top = 4
sides = 5
[material]
young = 70.0
poisson = 0.0
[friction]
coefficient = 0.2
[tractions]
top = [0.0, 0.0, -0.05]
[roller]
top = [0]
sides = [1]
[[obstacle]]
name = "log"
type = "cylinder"
point = [{px}, {py}, {pz}]
axis = [0.0, 1.0, 0.0]
radius = {radius}
"""


def box_scene(tmp: Path, s: float) -> Path:
    """The tilt case of :func:`test_a_tilt_left_free_over_a_cylinder` with every length times ``s``: a structured
    hexahedral box [0, 2s] × [0, s] × [0, s] (gmsh, the same mesh at any s) over the cylinder."""
    path, mesh = tmp / f"box_{s:g}.toml", tmp / f"box_{s:g}.msh"
    if MPI.COMM_WORLD.rank == 0:
        import gmsh

        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("box")
        gmsh.model.occ.addBox(0, 0, 0, 2 * s, s, s)
        gmsh.model.occ.synchronize()
        groups: dict[int, list[int]] = {k: [] for k in range(1, 6)}
        for _, tag in gmsh.model.getEntities(2):
            x, _, z = (c / s for c in gmsh.model.occ.getCenterOfMass(2, tag))
            groups[1 if x < 1e-6 else 2 if x > 2 - 1e-6 else 3 if z < 1e-6 else 4 if z > 1 - 1e-6 else 5].append(tag)
        for k, tags in groups.items():
            gmsh.model.addPhysicalGroup(2, tags, k)
        gmsh.model.addPhysicalGroup(3, [1], 1)
        for _, tag in gmsh.model.getEntities(1):
            ends = gmsh.model.getBoundary([(1, tag)], oriented=False)
            along = np.abs(np.subtract(*(gmsh.model.getValue(0, e[1], []) for e in ends)))
            gmsh.model.mesh.setTransfiniteCurve(tag, (12, 6, 6)[int(np.argmax(along))] + 1)
        for _, tag in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(tag)
            gmsh.model.mesh.setRecombine(2, tag)
        gmsh.model.mesh.setTransfiniteVolume(1)
        gmsh.model.mesh.setRecombine(3, 1)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(mesh))
        gmsh.finalize()
        path.write_text(BOX.format(mesh=mesh, px=0.7 * s, py=0.5 * s, pz=-0.501 * s, radius=0.5 * s))
    MPI.COMM_WORLD.barrier()
    return path


def test_the_approach_does_not_depend_on_the_length_unit(mpi_tmp_path):
    """The tilt over the cylinder with every length times 1e-3 (a body of millimetres in metres) is the same solve:
    the linear programs of the approach ran in raw units against HiGHS's absolute tolerances (1e-7), so the body got
    no approach (exit 3 after 23 Newton steps, no contact node ever closed); now u/s and the force/s² equal the
    unscaled ones, in the same Newton steps."""
    answers = []
    for s in (1.0, 1e-3):
        with build_problem(Scene.from_toml(box_scene(mpi_tmp_path, s)), MPI.COMM_WORLD).problem as problem:
            u, result = problem.solve()
            assert problem.last_start == "approach" and result.converged
            force = MPI.COMM_WORLD.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM)
            owned = u.function_space.dofmap.index_map.size_local
            x = np.concatenate(MPI.COMM_WORLD.allgather(u.function_space.tabulate_dof_coordinates()[:owned])) / s
            values = np.concatenate(MPI.COMM_WORLD.allgather(u.x.array[:3 * owned].reshape(-1, 3)))
            answers.append((result.iterations, force / s**2, values[np.lexsort(np.round(x, 9).T)] / s))
    (n1, f1, u1), (n2, f2, u2) = answers
    assert n1 == n2
    assert np.linalg.norm(f2 - f1) <= 1e-8 * np.linalg.norm(f1)
    assert np.abs(u2 - u1).max() <= 1e-8 * np.abs(u1).max()


def test_a_body_held_by_a_spring_is_no_free_body():
    """A spring in the bilinear form (``k·inner(u, v)·ds`` on one face, no Dirichlet condition) holds every rigid
    motion: the free motions were taken from the supports alone, and the solve failed its free_balance check
    (residual 0.481, "the loads push the body along a motion its supports leave free"). Now the stiffness decides:
    the block pressed onto the plane converges, with no free motion."""
    import dolfinx
    import dolfinx.mesh
    import ufl

    from fenics_coulomb import ContactProblem

    comm = MPI.COMM_WORLD
    msh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array([1.0, 1.0, 0.5])], [3, 3, 2],
                                  dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    facets = {k: dolfinx.mesh.locate_entities_boundary(msh, 2, f) for k, f in
              ((1, lambda x: np.isclose(x[2], 0.0)), (2, lambda x: np.isclose(x[0], 0.0)))}
    order = np.argsort(np.concatenate(list(facets.values())))
    tags = dolfinx.mesh.meshtags(msh, 2, np.concatenate(list(facets.values()))[order].astype(np.int32),
                                 np.concatenate([np.full(f.size, k, np.int32) for k, f in facets.items()])[order])
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    a = ufl.inner(ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))) * ufl.dx + 5.0 * ufl.inner(u, v) * ds(2)
    L = ufl.inner(ufl.as_vector((0.0, 0.0, -0.01)), v) * ufl.dx
    with ContactProblem(a, L, [], (tags, [1]), friction=0.3, petsc_options_prefix="spring_") as problem:
        assert problem.model.coupling.free_motions == 0
        _, result = problem.solve()
        assert result.converged
        assert problem.checks(result)["free_balance"] <= 1e-6
        assert problem.checks(result)["reaction_balance"] <= 1e-6  # the spring counts as a support
