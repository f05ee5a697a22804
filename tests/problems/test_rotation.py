"""Rigid rotations of obstacles (issue 26): a cylinder rolling on a block sticks where the same cylinder dragged
without rotation slides; the slip follows the obstacle's material points; 1 = 2 ranks (the MPI pass), reruns
identical.

Rolling: step k translates the cylinder (radius R, axis along x2) by R θ_k along x1 and turns it by θ_k about
its own axis (rotation about x2 through its scene axis point, then the translation): the material point of the
cylinder at the contact moves by R(θ − sin θ) along x1 and R(1 − cos θ) along x3 in a step of θ, O(θ³) and
O(θ²): the contact's interior does not slip. Dragged: the same translation without the rotation moves that point
by R θ: it slides wherever |t| reaches F λ."""

from __future__ import annotations

import math

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem, ContactState, Cylinder, InputError, box_partitioner

R, DEPTH, THETA = 0.5, 0.004, 0.01  # radius, indentation, rotation per step (rad)
AXIS_POINT = (0.6, 0.5, 0.5 + R)


def block_problem(comm: MPI.Comm, prefix: str) -> ContactProblem:
    corners, n = [[0, 0, 0], [2, 1, 0.5]], [40, 8, 10]  # the deterministic partition: reruns repeat bit for bit
    msh = dolfinx.mesh.create_box(comm, corners, n, dolfinx.mesh.CellType.hexahedron,
                                  partitioner=box_partitioner(corners, n, dolfinx.mesh.GhostMode.none))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(top).astype(np.int32), np.full(top.size, 1, np.int32))
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, bottom), V)
    mu, lmbda = 70.0 / 2.6, 70.0 * 0.3 / (1.3 * 0.4)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    a = ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx
    roller = Cylinder(point=AXIS_POINT, axis=(0, 1, 0), radius=R, displacement=(0, 0, -DEPTH), name="roller")
    return ContactProblem(a, None, bcs=[clamp], contact=(tags, [1]), friction=0.5, obstacles=[roller],
                          settings={"rtol": 1e-10},
                          petsc_options_prefix=prefix)


def run(comm: MPI.Comm, rolling: bool, steps: int = 3, prefix: str = "roll_") -> list:
    out = []
    with block_problem(comm, prefix) as problem:
        _, result = problem.solve()  # press
        for k in range(1, steps + 1):
            rotation = [math.degrees(k * THETA), [0.0, 1.0, 0.0], list(AXIS_POINT)] if rolling else None
            problem.move("roller", (R * k * THETA, 0.0, -DEPTH), rotation=rotation)
            _, result = problem.solve()
            assert result.converged
            report = problem.report(result)
            out.append((report, result))
    return out


def interior(report, step: int) -> np.ndarray:
    """The contact nodes away from the ends of the roller (0.2 < x2 < 0.8): the contact line's interior."""
    nodes = report.nodes
    return nodes.closed & (nodes.coordinates[:, 1] > 0.2) & (nodes.coordinates[:, 1] < 0.8)


def test_rolling_sticks_where_dragging_slides():
    comm = MPI.COMM_WORLD
    rolled, dragged = run(comm, True), run(comm, False, prefix="drag_")
    for (roll, _), (drag, _) in zip(rolled, dragged, strict=True):
        inner_roll = interior(roll, 0)
        inner_drag = interior(drag, 0)
        assert inner_roll.sum() >= 4 and inner_drag.sum() >= 4
        assert np.all(roll.nodes.state[inner_roll] == ContactState.STICK)
        assert np.mean(drag.nodes.state[inner_drag] == ContactState.SLIP) > 0.9
        # dragged: the obstacle drags the body along +x1 with |t| = F λ on the sliding nodes
        assert drag.nodes.force[inner_drag, 0].sum() > 0
    # the rolled contact's total tangential force stays small against the dragged one
    assert abs(rolled[-1][0].total_force[0]) < 0.2 * abs(dragged[-1][0].total_force[0])


def test_rotation_about_the_own_axis_changes_no_geometry_and_reruns_repeat():
    comm = MPI.COMM_WORLD
    a = run(comm, True, steps=1, prefix="rep1_")
    b = run(comm, True, steps=1, prefix="rep2_")
    assert np.array_equal(a[-1][1].displacement, b[-1][1].displacement)
    c = Cylinder(point=AXIS_POINT, axis=(0, 1, 0), radius=R)
    x = np.array([[0.5, 0.3, 0.49], [0.7, 0.6, 0.5]])
    g0, n0, F0 = c.evaluate(x)
    g1, n1, F1 = c.rotated([25.0, [0, 1, 0], list(AXIS_POINT)]).evaluate(x)
    assert np.allclose(g0, g1, atol=1e-15) and np.allclose(n0, n1, atol=1e-15) and np.allclose(F0, F1, atol=1e-15)


@pytest.mark.parametrize("rotation, fragment", [
    ([30.0, [0, 0, 0], [0, 0, 0]], "rotation axis"),
    (["a", [0, 1, 0], [0, 0, 0]], "angle must be a number"),
    ([float("nan"), [0, 1, 0], [0, 0, 0]], "must be finite"),
    ([30.0, [0, 1, 0]], "give [angle_deg"),
])
def test_bad_rotations_are_named(rotation, fragment):
    with pytest.raises(InputError, match=fragment.replace("[", r"\[")):
        Cylinder(point=AXIS_POINT, axis=(0, 1, 0), radius=R).rotated(rotation)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_the_material_motion_against_the_explicit_rigid_map():
    """Obstacle.motion (the slip's obstacle part) against an independent construction: a point at angle φ on the
    cylinder's circle (x1, x3 about the axis point) goes to angle φ + θ: (R sin(φ + θ), −R cos(φ + θ)) with
    trigonometry instead of Rodrigues, composed from step k−1 (θ₁, δ₁) to step k (θ₂, δ₂); and a sphere turned
    about an outside point has the gaps of the sphere whose centre was turned (frames: rotated normals)."""
    c = np.array(AXIS_POINT)
    base = Cylinder(point=AXIS_POINT, axis=(0, 1, 0), radius=R)
    t1, t2, d1, d2 = 0.3, 0.75, np.array([0.1, 0.0, -0.01]), np.array([0.25, 0.0, -0.02])
    before = base.moved(d1).rotated([math.degrees(t1), [0, 1, 0], list(c)])
    after = base.moved(d2).rotated([math.degrees(t2), [0, 1, 0], list(c)])
    phi = np.linspace(-1.0, 1.0, 7)

    def on_circle(angle, delta):  # rotation about +x2 turns (x1, x3) = (sin, −cos) forward: x1' = x1 cos + x3 sin
        return np.column_stack([c[0] + R * np.sin(angle), np.full(angle.size, c[1]), c[2] - R * np.cos(angle)]) + delta

    # a right-handed rotation by θ about +x2 maps (sin φ, −cos φ) to (sin φ cos θ − cos φ sin θ, ...) = angle φ − θ
    p = on_circle(phi - t1, d1)
    expected = on_circle(phi - t2, d2) - p
    assert np.allclose(after.motion(before, p), expected, rtol=0, atol=1e-14)
    # without rotations: the translation difference, exactly
    assert np.array_equal(base.moved(d2).motion(base.moved(d1), p), np.broadcast_to(d2 - d1, p.shape))
    # a sphere turned about an outside point = the sphere moved to the turned centre
    from fenics_coulomb import Sphere

    sc, pivot, angle = np.array([0.2, 0.4, 1.1]), np.array([1.0, -0.3, 0.5]), 40.0
    turned = Sphere(center=tuple(sc), radius=0.3).rotated([angle, [0, 0, 1], list(pivot)])
    a = math.radians(angle)
    Rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    moved = Sphere(center=tuple(Rz @ (sc - pivot) + pivot), radius=0.3)
    x = np.random.default_rng(5).uniform(-1, 2, size=(20, 3))
    g1, n1, F1 = turned.evaluate(x)
    g2, n2, _ = moved.evaluate(x)
    assert np.allclose(g1, g2, atol=1e-13) and np.allclose(n1, n2, atol=1e-13)
    assert np.allclose(F1[:, :, 2], n1) and np.allclose(np.linalg.det(F1), 1.0)


def test_a_turning_floor_under_a_contact_pair():
    """A contact pair (the upper block pressed onto the lower) and a plane floor under the lower block (held by
    its clamped sides) that turns by 0.3° about the vertical axis through the block's centre: the floor's part of
    each floor node's slip offset is the turn of its material point, R(θ)(p − c) + c − p (trigonometry, p the
    node's point of the floor); the solve obeys the physics and the floor drags the block's bottom around the
    axis (positive torque)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "model"))
    from test_two_body import LOWER_BOTTOM, MASTER, SLAVE, TAGS, UPPER_TOP, elasticity, two_blocks

    from conftest import PHYSICS, assert_physics

    from fenics_coulomb import ContactPair, Plane

    comm = MPI.COMM_WORLD
    msh, ft = two_blocks(comm)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    sides = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["lower_sides"]))
    top = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP))
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.004]), top, V),
           dolfinx.fem.dirichletbc(np.zeros(3), sides, V)]
    a = elasticity(V, 70.0, 0.2, upper=(20.0, 0.45))
    theta, centre = 0.3, np.array([1.0, 0.5, -1.00003])
    floor = Plane(point=[0.0, 0.0, -1.00003], normal=[0.0, 0.0, 1.0], name="floor",
                  rotation=[theta, [0.0, 0.0, 1.0], centre.tolist()])
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3)
    with ContactProblem(a, None, bcs, contact=(ft, [LOWER_BOTTOM]), obstacles=[floor], friction=0.3,
                        contact_pairs=[pair], settings={"rtol": 1e-12}, petsc_options_prefix="turn_") as problem:
        _, result = problem.solve()
        model = problem.model
        assert result.converged
        assert_physics(model, result.relative_displacement, keys=PHYSICS[:-1])
        rigid = ~model.coupling.paired_mask(model.contact.size)
        x = model.contact.coordinates[rigid]
        p = np.column_stack([x[:, 0], x[:, 1], np.full(x.shape[0], centre[2])])
        c, s = math.cos(math.radians(theta)), math.sin(math.radians(theta))
        d = p - centre
        moved = np.column_stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1], d[:, 2]]) + centre - p
        T = model.contact.frames[rigid][:, :, :2]  # tangent columns
        assert np.allclose(model.local_shift[rigid, :2], -np.einsum("kil,ki->kl", T, moved), rtol=0, atol=1e-15)
        f = result.contact_force[rigid]
        torque = comm.allreduce(float(np.sum((x[:, 0] - centre[0]) * f[:, 1] - (x[:, 1] - centre[1]) * f[:, 0])),
                                op=MPI.SUM)
        floor_force = comm.allreduce(float(np.sum(f[:, 2])), op=MPI.SUM)
    assert floor_force > 0 and torque > 1e-3 * floor_force


TURNTABLE = """
[body]
shape = "cuboid"
lev = 2
gap = "0.0*x1"
clamped = []
contact = ["bottom"]
[material]
young = 70.0
poisson = 0.3
[friction]
coefficient = 0.3
[tractions]
[prescribed]
top = [0.0, 0.0, -0.01]
[[obstacle]]
name = "table"
type = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[path.step]]
[[path.step]]
{slide}
substeps = 2
[[path.step]]
{slide}
rotate = {{ table = [1.0, [0.0, 0.0, 1.0], [1.8, 0.5, 0.0]] }}
"""


def test_a_table_turned_under_a_slid_block_turns_the_material_points_where_the_block_is(mpi_tmp_path):
    """The same relative motion twice: the block slid 0.8 along x1 over a plane table, then the table turned by 1°
    about the slid block's centre; or the table slid −0.8 under the block, then turned about the same point. Each
    bottom node's slip is the motion of the table's material point beneath the node where the node IS (finite
    sliding): the two paths give the same contact force (2.5e-5 of the normal force at lev 3). Evaluated at the
    reference positions, the slid block's material points were 0.8 off, and its sideways force 0.2492 against
    0.0200 (60 % of F·P, exit 0)."""
    import json

    from fenics_coulomb.cli import main

    comm = MPI.COMM_WORLD
    forces = []
    for name, slide in (("block", 'prescribed = { top = [0.8, 0.0, -0.01] }'),
                        ("table", 'move = { table = [-0.8, 0.0, 0.0] }')):
        path = mpi_tmp_path / f"{name}.toml"
        if comm.rank == 0:
            path.write_text(TURNTABLE.format(slide=slide))
        comm.barrier()
        out = mpi_tmp_path / name
        assert main(["--scene", str(path), "--out", str(out), "--no-plots", "--quiet"]) == 0
        comm.barrier()
        forces.append(np.asarray(json.loads((out / "summary.json").read_text())["contact_force"]))
    block, table = forces
    assert block[2] > 0.1 and abs(block[1]) > 0.01 * block[2]
    assert np.allclose(block, table, rtol=0, atol=1e-4 * block[2])
