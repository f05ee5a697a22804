"""Contact nodes with held components: symmetry planes and rollers through the contact zone (1 and 2 ranks).

A support that holds components tangential to the contact keeps its nodes in contact (their law acts on the free
components; fenics_coulomb/model/frames.py derives it). The brute force is the full model: a quarter (half) model
with symmetry rollers through the contact patch must give the full model's contact forces node by node — the
nodes on a symmetry plane carry half of the full model's force there, the node on two planes a quarter — and the
full model's total force divided by 4 (2) and its contact radius. With the old rule (every node with a held
component freed) the symmetry-plane nodes carry nothing and penetrate, and these comparisons fail by the force
those nodes carry (a fifth of the Hertz load on the planes at this mesh).
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem, Plane, Sphere
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.frames import HELD_NORMAL_TOL, held_frames

E, NU = 1000.0, 0.3
RADIUS, DEPTH = 2.0, 0.05
CELLS = 6  # per unit length


def lame(V, nu=NU):
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    return ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx


def box(comm, lo, hi):
    n = [max(1, round(CELLS * (b - a))) for a, b in zip(lo, hi)]
    msh = dolfinx.mesh.create_box(comm, [lo, hi], n, dolfinx.mesh.CellType.hexahedron)
    return msh, dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))


def facets(msh, axis, value):
    return dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[axis], value))


def component_bc(V, axis, value, where, dofs_filter=None):
    dofs = dolfinx.fem.locate_dofs_topological(V.sub(axis), 2, where)
    if dofs_filter is not None:
        dofs = dofs[dofs_filter(V.tabulate_dof_coordinates()[dofs // 3])]
    return dolfinx.fem.dirichletbc(PETSc.ScalarType(value), dofs, V.sub(axis))


def indent(comm, lo, hi, planes, friction, variant="4a"):
    """A rigid sphere (radius 2, centre above (1, 1)) pressed DEPTH into the top of the block [lo, hi] (bottom
    clamped; rollers u_axis = 0 on the faces x_axis = value of ``planes``): the report's contact nodes, total force,
    contact radius, the contact map's held nodes and the number of contact nodes."""
    msh, V = box(comm, lo, hi)
    top = facets(msh, 2, hi[2])
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(top).astype(np.int32), np.full(top.size, 1, np.int32))
    bottom = dolfinx.fem.locate_dofs_topological(V, 2, facets(msh, 2, 0.0))
    bcs = [dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), bottom, V)]
    bcs += [component_bc(V, axis, 0.0, facets(msh, axis, value)) for axis, value in planes]
    sphere = Sphere(center=(1.0, 1.0, hi[2] + RADIUS), radius=RADIUS, displacement=(0.0, 0.0, -DEPTH))
    with ContactProblem(lame(V), None, bcs, contact=(tags, [1]), friction=friction, obstacles=[sphere],
                        settings={"rtol": 1e-11, "variant": variant}, petsc_options_prefix="held_") as problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result)
        held = comm.allreduce(int(np.sum(problem.model.contact.held_components.any(axis=1))), op=MPI.SUM)
        radius = report.contact_radius(center=(1.0, 1.0, hi[2]), normal=(0.0, 0.0, 1.0))
        return report, radius, held, problem.p


@pytest.mark.parametrize(("friction", "variant"), [(0.0, "4a"), (0.3, "4a"), (0.3, "4b")])
def test_quarter_hertz_model_equals_the_full_model(friction, variant):
    """The quarter [1, 2]² × [0, 1] with rollers on x = 1 and y = 1 against the full [0, 2]² × [0, 1] (the same
    grid): every contact node's force equal to the full model's at the same point times its share (1, ½ on a
    plane, ¼ on the axis) to 1e-7 of the largest force; the normal total force × 4 and the contact radius equal; the
    plane nodes are contact nodes and carry force, none penetrates."""
    comm = MPI.COMM_WORLD
    full, full_radius, full_held, _ = indent(comm, [0.0, 0.0, 0.0], [2.0, 2.0, 1.0], [], friction)
    quarter, radius, held, p = indent(comm, [1.0, 1.0, 0.0], [2.0, 2.0, 1.0], [(0, 1.0), (1, 1.0)], friction,
                                      variant)
    assert full_held == 0 and held == 2 * CELLS + 1  # the top's nodes on the two planes: contact nodes
    assert p == (CELLS + 1) ** 2
    scale = np.max(np.abs(full.nodes.force))
    assert abs(4.0 * quarter.total_force[2] - full.total_force[2]) <= 1e-7 * scale  # (x1, x2: the quarters cancel)
    assert full.total_force[2] < 0 and np.isclose(radius, full_radius, rtol=1e-12) and radius > 0.25  # rings of nodes
    # node by node: the quarter's nodes are the full model's with x, y >= 1
    x = quarter.nodes.coordinates
    share = np.where(np.isclose(x[:, 0], 1.0), 0.5, 1.0) * np.where(np.isclose(x[:, 1], 1.0), 0.5, 1.0)
    mine = np.all(full.nodes.coordinates[:, :2] >= 1.0 - 1e-12, axis=1)
    assert np.allclose(full.nodes.coordinates[mine], x, rtol=0, atol=1e-12)
    expected = share[:, None] * full.nodes.force[mine]
    assert np.allclose(quarter.nodes.force, expected, rtol=0, atol=1e-7 * scale)
    on_planes = share < 1.0
    assert np.sum(quarter.nodes.normal_force[on_planes]) > 0.1 * np.sum(quarter.nodes.normal_force)
    # the held components carry no contact force; no node penetrates
    assert np.all(quarter.nodes.force[np.isclose(x[:, 0], 1.0), 0] == 0.0)
    assert np.all(quarter.nodes.force[np.isclose(x[:, 1], 1.0), 1] == 0.0)
    assert np.min(quarter.nodes.gap) >= -1e-9 * DEPTH


def push(comm, lo_y, friction):
    """A block [0, 1] × [lo_y, 1] × [0, 0.5] (ν = 0) on the plane x3 = 0 under its weight, pushed 0.01 along x1 by
    its face x1 = 0 (``V.sub(0)``, not its bottom edge). u2 is held on y = 0.5: by a roller on the face y = 0.5
    through the contact face (the half model, lo_y = 0.5), or on the top's line y = 0.5 (the full model, lo_y = 0:
    the rigid motions nothing else holds). The report and the state counts."""
    msh, V = box(comm, [0.0, lo_y, 0.0], [1.0, 1.0, 0.5])
    bottom = facets(msh, 2, 0.0)
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 1, np.int32))
    pushed = component_bc(V, 0, 0.01, facets(msh, 0, 0.0), lambda x: x[:, 2] > 1e-9)
    if lo_y == 0.5:
        hold = component_bc(V, 1, 0.0, facets(msh, 1, 0.5))
    else:
        line = dolfinx.mesh.locate_entities(msh, 1, lambda x: np.isclose(x[1], 0.5) & np.isclose(x[2], 0.5))
        msh.topology.create_connectivity(1, 3)
        dofs = dolfinx.fem.locate_dofs_topological(V.sub(1), 1, line)
        hold = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), dofs, V.sub(1))
    gravity = dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -1.0]))
    L = ufl.inner(gravity, ufl.TestFunction(V)) * ufl.dx
    with ContactProblem(lame(V, nu=0.0), L, [pushed, hold], contact=(tags, [1]), friction=friction,
                        obstacles=[Plane(point=(0, 0, 0), normal=(0, 0, 1))], settings={"rtol": 1e-12},
                        petsc_options_prefix="held_push_") as problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result, reactions={"push": pushed, "hold": hold})
        held = comm.allreduce(int(np.sum(problem.model.contact.held_components.any(axis=1))), op=MPI.SUM)
        return report, result.counts, held


def test_half_block_pushed_along_a_plane_with_its_bottom_edge_on_a_roller():
    """The half block [0.5, 1] in x2 (roller u2 = 0 on y = 0.5, its bottom edge on the contact face) against the
    full block [0, 1]: every node slides and the push is F × weight in both (1e-8); the roller's bottom-edge nodes
    are contact nodes carrying half the force of the full model's nodes on its mid-plane, the others the same force
    (1e-7 of the largest), the roller's x1 and x3 reactions are 0 and the half's push is half the full one's."""
    comm = MPI.COMM_WORLD
    friction = 0.3
    full, full_counts, full_held = push(comm, 0.0, friction)
    half, counts, held = push(comm, 0.5, friction)
    for report, c in ((full, full_counts), (half, counts)):
        weight = -report.applied_load[2]
        assert c["stick"] == 0 and c["open"] == 0 and c["slip"] > 0
        assert abs(report.reactions["push"][0] / weight - friction) <= 1e-8
    assert full_held == 0 and held == CELLS + 1 and counts["slip"] == (CELLS + 1) * (CELLS // 2 + 1)
    x = half.nodes.coordinates
    mine = full.nodes.coordinates[:, 1] >= 0.5 - 1e-12
    assert np.allclose(full.nodes.coordinates[mine], x, rtol=0, atol=1e-12)
    share = np.where(np.isclose(x[:, 1], 0.5), 0.5, 1.0)
    scale = np.max(np.abs(full.nodes.force))
    assert np.allclose(half.nodes.force, share[:, None] * full.nodes.force[mine], rtol=0, atol=1e-7 * scale)
    assert np.sum(half.nodes.normal_force[share < 1.0]) > 0.1 * np.sum(half.nodes.normal_force)
    assert abs(half.reactions["hold"][0]) <= 1e-9 * scale and abs(half.reactions["hold"][2]) <= 1e-9 * scale
    assert abs(2.0 * half.reactions["push"][0] - full.reactions["push"][0]) <= 1e-8 * full.reactions["push"][0]


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_held_frames_put_the_held_axes_first():
    """held_frames: the first held axis becomes t₁ (a second one ±t₂), the normal loses its held components and
    stays unit, the frames right-handed; a held direction along the normal is a conflict (frame unchanged), and a
    node without held components keeps its frame bit for bit."""
    from fenics_coulomb.model.frames import frames_from_normals

    n = np.array([[0.0, 0.6, 0.8], [1e-9, -0.6, 0.8], [0.0, 0.0, -1.0], [2e-6, 0.0, 0.9], [0.2, 0.3, 0.9],
                  [1.0, 1e-9, 0.0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    frames = frames_from_normals(n)
    held = np.array([[1, 0, 0], [1, 0, 0], [1, 1, 0], [1, 0, 0], [0, 0, 0], [0, 1, 1]], dtype=bool)
    out, conflict = held_frames(frames, held)
    assert conflict.tolist() == [False, False, False, True, False, False]
    assert abs(n[3, 0]) > HELD_NORMAL_TOL
    assert np.array_equal(out[4], frames[4]) and np.array_equal(out[3], frames[3])
    for i, axes in ((0, [0]), (1, [0]), (2, [0, 1]), (5, [1, 2])):
        R = out[i]
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-14) and np.isclose(np.linalg.det(R), 1.0)
        assert np.array_equal(R[:, 0], np.eye(3)[axes[0]])
        assert np.all(R[axes, 2] == 0.0) and np.dot(R[:, 2], n[i]) > 1.0 - 1e-3
        if len(axes) == 2:
            assert np.array_equal(np.abs(R[:, 1]), np.eye(3)[axes[1]])


@pytest.mark.parametrize("driven", [False, True])
def test_a_support_along_the_normal_leaves_its_nodes_to_the_support(driven):
    """A roller holding u3 (the plane's normal) on a side face, or a push u1 = 0.01 along the contact (driven):
    its bottom-edge nodes are no contact nodes (the support moves them; the friction of a driven slip is not
    modelled), the others are; the solve runs."""
    comm = MPI.COMM_WORLD
    msh, V = box(comm, [0.0, 0.0, 0.0], [1.0, 1.0, 0.5])
    bottom = facets(msh, 2, 0.0)
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 1, np.int32))
    top = dolfinx.fem.locate_dofs_topological(V, 2, facets(msh, 2, 0.5))
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.01], dtype=PETSc.ScalarType), top, V),
           component_bc(V, 0, 0.01, facets(msh, 0, 1.0)) if driven else component_bc(V, 2, 0.0, facets(msh, 0, 1.0))]
    with ContactProblem(lame(V), None, bcs, contact=(tags, [1]), friction=0.3, settings={"rtol": 1e-10},
                        petsc_options_prefix="held_normal_") as problem:
        assert problem.p == (CELLS + 1) ** 2 - (CELLS + 1)
        _, result = problem.solve()
        assert result.converged


def test_moving_an_obstacle_off_the_symmetry_plane_is_refused():
    """A sphere moved sideways across a symmetry roller through the contact: one line naming the node."""
    comm = MPI.COMM_WORLD
    msh, V = box(comm, [1.0, 0.0, 0.0], [2.0, 2.0, 1.0])
    top = facets(msh, 2, 1.0)
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(top).astype(np.int32), np.full(top.size, 1, np.int32))
    bottom = dolfinx.fem.locate_dofs_topological(V, 2, facets(msh, 2, 0.0))
    bcs = [dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), bottom, V),
           component_bc(V, 0, 0.0, facets(msh, 0, 1.0))]
    sphere = Sphere(center=(1.0, 1.0, 1.0 + RADIUS), radius=RADIUS, displacement=(0.0, 0.0, -DEPTH))
    with ContactProblem(lame(V), None, bcs, contact=(tags, [1]), friction=0.3, obstacles=[sphere],
                        petsc_options_prefix="held_move_", sliding="small") as problem:
        with pytest.raises(InputError, match=r"^contact node at \(1, .*holds its x1 component"):
            problem.move(0, (0.5, 0.0, -DEPTH))
            problem.solve()


def test_an_obstacle_dragged_across_a_symmetry_plane_is_refused():
    """A plane moved along the normal of a roller through the contact (its nodes would slip along the held
    direction): one line naming the node and the slip."""
    comm = MPI.COMM_WORLD
    msh, V = box(comm, [0.0, 0.5, 0.0], [1.0, 1.0, 0.5])
    bottom = facets(msh, 2, 0.0)
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 1, np.int32))
    top = dolfinx.fem.locate_dofs_topological(V, 2, facets(msh, 2, 0.5))
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.01], dtype=PETSc.ScalarType), top, V),
           component_bc(V, 1, 0.0, facets(msh, 1, 0.5))]
    plane = Plane(point=(0, 0, 0), normal=(0, 0, 1))
    with ContactProblem(lame(V), None, bcs, contact=(tags, [1]), friction=0.3, obstacles=[plane],
                        petsc_options_prefix="held_drag_") as problem:
        assert problem.p == (CELLS + 1) * (CELLS // 2 + 1)
        with pytest.raises(InputError, match=r"^contact node at \(.*, 0.5, .*\): its support holds component\(s\) x2 "
                           r"while it slips along them by \(0, -0.01, 0\)"):
            problem.move(0, (0.0, 0.01, 0.0))
            problem.solve()


def stacked(comm, half, method):
    """A block 0.5 × 0.5 × 0.25 (slave bottom) pressed 0.01 into a block 1 × 1 × 0.5 (master top; bottom clamped),
    F = 0.3; ``half``: the part x1 >= 0.5 of both with rollers u1 = 0 on x1 = 0.5 (the slave's bottom edge there
    holds u1). The report and the number of slave nodes with a held component."""
    from meshes.two_blocks import TAGS, two_blocks

    from fenics_coulomb import ContactPair

    x0, width, n_lower, n_upper = (0.5, 0.5, (4, 8, 2), (3, 6, 2)) if half else (0.0, 1.0, (8, 8, 2), (6, 6, 2))
    blocks = two_blocks(comm, lower=(width, 1.0, 0.5), n_lower=n_lower, upper_origin=(0.0, 0.25),
                        upper=(0.5 * width, 0.5, 0.25), n_upper=n_upper, gap=0.0)
    msh = blocks.mesh
    msh.geometry.x[:, 0] += x0
    upper = blocks.cell_tags.find(2)
    dofs_upper = np.unique(msh.geometry.dofmap[upper])
    if not half:  # the full upper block is centred: [0.25, 0.75]
        msh.geometry.x[dofs_upper, 0] += 0.25
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    ft = blocks.facet_tags
    bottom = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["lower_bottom"]))
    top = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["upper_top"]))
    bcs = [dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), bottom, V),
           dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.01], dtype=PETSc.ScalarType), top, V)]
    if half:
        bcs.append(component_bc(V, 0, 0.0, facets(msh, 0, 0.5)))
    pair = ContactPair(ft, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], friction=0.3, method=method)
    with ContactProblem(lame(V), None, bcs, contact_pairs=[pair], settings={"rtol": 1e-11},
                        petsc_options_prefix="held_pair_") as problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result)
        held = comm.allreduce(int(np.sum(problem.model.contact.held_components.any(axis=1))), op=MPI.SUM)
        return report, held


@pytest.mark.parametrize("method", ["mortar", "node-to-surface"])
def test_half_two_body_model_equals_the_full_model(method):
    """Two blocks (non-matching hexahedra), the half model with a symmetry roller through the slave's bottom edge
    against the full model: the slave nodes on the plane are contact nodes (Φ's x1 rows 0 there) carrying half
    the full model's force, the others the same, total normal force × 2. Mortar: every component to 1e-7 of the
    largest force. Node-to-surface: the normal components to 2e-5 (neither model is symmetric to better than
    1e-5: the slave nodes on x1 = 0.5, and on x2 = 0.5, lie on master edges, where the tie rule picks one facet's
    stencil — the full model's nodes on x1 = 0.5 carry x1 forces of 3e-4 of the largest force, the half model's
    0 — and the two nodes either side of x2 = 0.5 carry normal forces 1.0e-5 of the largest force apart, in either
    model, on either side, as the geometry iteration's two-state cycle there settles: 0.10563931 / 0.10563771
    in the half model on 2 ranks against 0.10563777 / 0.10563937 in the full one)."""
    comm = MPI.COMM_WORLD
    full, full_held = stacked(comm, False, method)
    half, held = stacked(comm, True, method)
    assert full_held == 0 and held == 6 + 1  # the slave bottom's nodes on x1 = 0.5
    scale = np.max(np.abs(full.nodes.force))
    bound, components = (1e-7, slice(None)) if method == "mortar" else (2e-5, slice(2, 3))
    assert abs(2.0 * half.total_force[2] - full.total_force[2]) <= bound * scale
    x = half.nodes.coordinates
    mine = full.nodes.coordinates[:, 0] >= 0.5 - 1e-12
    assert np.allclose(full.nodes.coordinates[mine], x, rtol=0, atol=1e-12)
    share = np.where(np.isclose(x[:, 0], 0.5), 0.5, 1.0)
    expected = share[:, None] * full.nodes.force[mine]
    assert np.allclose(half.nodes.force[:, components], expected[:, components], rtol=0, atol=bound * scale)
    assert np.sum(half.nodes.normal_force[share < 1.0]) > 0.05 * np.sum(half.nodes.normal_force)
    assert np.all(half.nodes.force[share < 1.0, 0] == 0.0)


@pytest.mark.compares_ranks
def test_a_two_state_cycle_keeps_the_same_state_on_any_ranks():
    """The half model's geometry iteration ends in a two-state cycle: a slave node across the master edge
    x2 = 0.5, its two solutions 1.9e-6 apart, mirror states whose energies differ only by the solves' noise
    (1.5e-11 to 5e-9 relative, which one is lower depending on the partition). The smaller energy kept 2 ranks'
    state 5.6e-4 of the largest force from 1 rank's; within CYCLE_ENERGY_TIE the smaller Σ u·CYCLE_DIRECTION
    decides, the same on every partition: the forces agree to 1e-7 of the largest."""
    def forces(comm):
        report, _ = stacked(comm, True, "node-to-surface")
        x, f = report.nodes.coordinates, report.nodes.force
        order = np.lexsort(np.round(x, 9).T[::-1])
        return x[order], f[order]

    x_many, f_many = forces(MPI.COMM_WORLD)
    x_one, f_one = forces(MPI.COMM_SELF)
    assert np.allclose(x_many, x_one, rtol=0, atol=1e-12)
    assert np.allclose(f_many, f_one, rtol=0, atol=1e-7 * np.max(np.abs(f_one)))
