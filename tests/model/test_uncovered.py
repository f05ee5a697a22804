"""Slave nodes with no master surface beneath them (fenics_coulomb/model/pairs/uncovered.py).

The pressed blocks with the master surface tagged only where x < 1: the slave nodes over the rest of the lower
block's top have no partner, nothing keeps them out, and they sank 0.0098 into the lower block — converged, exit 0,
with a non-decisive master-node warning at most. Now `uncovered_penetration` is decisive: the solve fails its
physics checks naming the deepest node, and the depth is checked against a brute force of its own (the deformed
lower top's height under the node, from the lower body's displacement there)."""

from __future__ import annotations

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import pytest

from fenics_coulomb import ContactProblem
from fenics_coulomb.errors import SolverError
from fenics_coulomb.model.checks import displacement_scale, reported_warnings
from fenics_coulomb.model.pairs.projection import Surface
from fenics_coulomb.model.pairs import ContactPair
import fenics_coulomb.model.pairs.uncovered as uncovered
from test_two_body import LOWER_BOTTOM, MASTER, SLAVE, UPPER_TOP, elasticity, two_blocks

PART = 99  # the tag of the lower top's facets with x < 1: the master surface


def _lower_top_height(V, uh, points):
    """z of the deformed lower block's top above (x, y) of each point: 0 + u_z(x, y, 0) of the lower body (its
    lateral displacement, 1e-4 of the depth here, neglected; collective)."""
    msh = V.mesh
    everyone = np.concatenate(msh.comm.allgather(points.reshape(-1, 3)))  # every rank's points, on every rank
    q = np.column_stack([everyone[:, 0], everyone[:, 1], np.full(everyone.shape[0], -1e-12)])
    tree = dolfinx.geometry.bb_tree(msh, 3)
    cells = dolfinx.geometry.compute_colliding_cells(msh, dolfinx.geometry.compute_collisions_points(tree, q), q)
    found = np.diff(cells.offsets) > 0
    value = np.zeros(q.shape[0])
    if found.any():
        first = cells.array[cells.offsets[:-1][found]]
        value[found] = uh.eval(q[found], first)[:, 2]
    hits = found.astype(np.int32)
    msh.comm.Allreduce(MPI.IN_PLACE, hits, op=MPI.SUM)
    msh.comm.Allreduce(MPI.IN_PLACE, value, op=MPI.SUM)
    start = sum(msh.comm.allgather(points.shape[0])[:msh.comm.rank])
    return (value / np.maximum(hits, 1))[start:start + points.shape[0]]


@pytest.mark.parametrize("sliding", ["finite", "small"])
@pytest.mark.parametrize("method", ["node-to-surface", "mortar"])
def test_slave_nodes_beyond_the_master_surface_fail_the_checks(method, sliding):
    """Finite sliding: the solve fails its checks; small sliding (paired in X): a warning. The depth against the
    brute force either way."""
    comm = MPI.COMM_WORLD
    msh, ft = two_blocks(comm)
    mid = dolfinx.mesh.compute_midpoints(msh, 2, ft.indices)
    values = ft.values.copy()
    values[(ft.values == MASTER) & (mid[:, 0] < 1.0)] = PART
    tags = dolfinx.mesh.meshtags(msh, 2, ft.indices, values)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    top = dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -0.01]))
    bcs = [dolfinx.fem.dirichletbc(top, dolfinx.fem.locate_dofs_topological(V, 2, tags.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, tags.find(LOWER_BOTTOM)),
                                   V)]
    pair = ContactPair(tags, slave=SLAVE, master=PART, method=method)
    key = "uncovered_penetration" if sliding == "finite" else "uncovered_small_sliding"
    with ContactProblem(elasticity(V), None, bcs, contact_pairs=[pair], petsc_options_prefix="uncovered_",
                        sliding=sliding) as problem:
        if sliding == "finite":
            with pytest.raises(SolverError, match="uncovered_penetration") as failed:
                problem.solve()
            assert failed.value.reason == "physics_check"
            result = failed.value.result
        else:  # small sliding pairs in X: reported and warned, the model's answer kept
            _, result = problem.solve()
            assert any("small sliding pairs once" in w for w in reported_warnings(problem.checks(result), 1e-8))
        checks = problem.checks(result)
        depth = checks[key] * displacement_scale(problem.model, result.displacement)
        at = np.asarray(checks[f"{key}_at"])
        # brute force: every slave node over the untagged part (x > 1 + a facet: no master facet beneath it), its
        # depth below the deformed lower top
        uh = dolfinx.fem.Function(V)
        n = 3 * V.dofmap.index_map.size_local
        uh.x.array[:n] = result.displacement[:n]
        uh.x.scatter_forward()
        x = V.tabulate_dof_coordinates()
        slave = dolfinx.fem.locate_dofs_topological(V, 2, tags.find(SLAVE))
        slave = slave[slave < V.dofmap.index_map.size_local]
        y = x[slave] + uh.x.array.reshape(-1, 3)[slave]
        beyond = y[:, 0] > 1.0 + 0.5
        sunk = _lower_top_height(V, uh, y[beyond]) - y[beyond, 2]
        deepest = comm.allreduce(float(np.max(sunk, initial=0.0)), op=MPI.MAX)
        assert deepest > 5e-3  # the defect: sunk by about the press
        assert depth == pytest.approx(deepest, rel=1e-3)
        assert at[0] > 1.0 and -0.011 < at[2] < -5e-3


@pytest.mark.parametrize("cell", [dolfinx.mesh.CellType.tetrahedron, dolfinx.mesh.CellType.hexahedron])
def test_the_depth_ignores_symmetry_planes_only(cell):
    """A point on the unit cube's face x = 0, 0.01 below its top: 0 from that face, 0.01 inside when the face is a
    symmetry plane (every vertex held along x: the body goes on beyond it) — the shrink fit's bore nodes on the
    quarter model's planes ended 5.5e-4 inside the shaft with a depth of 0. A face held in another component, or
    held at some of its vertices only, still counts."""
    comm = MPI.COMM_WORLD
    msh = dolfinx.mesh.create_unit_cube(comm, 4, 4, 4, cell)
    msh.topology.create_connectivity(2, 3)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    x = V.tabulate_dof_coordinates()
    body = np.zeros(x.shape[0], dtype=np.int64)
    point = np.array([[0.0, 0.5, 0.99]]) if comm.rank == 0 else np.zeros((0, 3))
    on_plane = np.isclose(x[:, 0], 0.0)
    cases = {"free": (np.zeros((x.shape[0], 3), bool), 0.0), "mirror": (np.outer(on_plane, [1, 0, 0]) > 0, 0.01),
             "held along y": (np.outer(on_plane, [0, 1, 0]) > 0, 0.0),
             "held at half": (np.outer(on_plane & (x[:, 2] < 0.5), [1, 0, 0]) > 0, 0.0)}
    for name, (held, expected) in cases.items():
        depth = -uncovered.signed_distance(point, uncovered._boundary(V, x, body, 0, held))
        assert depth == pytest.approx([expected] if comm.rank == 0 else [], abs=1e-14), name


def _fan(w, n, k):
    """k + 1 triangles of the wall spanned by e_y and w, k of them meeting at the origin, oriented along n."""
    ey = np.array([0.0, 1.0, 0.0])
    ring = [-ey] + [w + y * ey for y in np.linspace(-1, 1, k)] + [ey] if k > 1 else [-ey, w, ey]
    X = np.array([[np.zeros(3), ring[i], ring[i + 1]] for i in range(len(ring) - 1)])
    normals = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
    return X, np.sign(normals @ n)


@pytest.mark.parametrize("fans", [(2, 2), (5, 2), (2, 5)])
def test_the_signed_distance_at_a_vertex_weighs_the_facets_by_their_angles(fans):
    """The root vertex of a 60° V-notch cut into a body, k triangles of one wall and m of the other meeting there;
    points 1e-3 inside whose closest point is the vertex. An unweighted sum of the normals let the wall with more
    triangles outvote the other (5 against 2: +9.5e-4, 'outside', depth 0); the angle-weighted pseudo-normal
    (Bærentzen and Aanæs) tells inside at any vertex: −|p| every time."""
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    nA, nB = np.array([-c, 0, s]), np.array([c, 0, s])
    XA, sA = _fan(np.array([s, 0, c]), nA, fans[0] - 1)
    XB, sB = _fan(np.array([-s, 0, c]), nB, fans[1] - 1)
    X = np.concatenate([XA, XB])
    surface = Surface(X, np.arange(3 * len(X)).reshape(-1, 3), np.concatenate([sA, sB]))
    for a, b in ((1.0, 1.0), (1.0, 0.3), (0.3, 1.0), (0.1, 1.0), (1.0, 0.1)):
        p = -1e-3 * (a * nA + b * nB)
        assert uncovered.signed_distance(p[None], surface)[0] == pytest.approx(-np.linalg.norm(p), rel=1e-12)


def test_the_signed_distance_on_a_slabs_mid_plane():
    """A point on the mid-plane of a slab 0 < z < 2h is equidistant from both faces: their normals cancelled
    (distance +h, 'outside'). Facets count as tied only where their closest points coincide: −h."""
    h = 1e-3
    square = lambda z: [[[0, 0, z], [1, 0, z], [1, 1, z]], [[0, 0, z], [1, 1, z], [0, 1, z]]]  # noqa: E731
    slab = Surface(np.array(square(0.0) + square(2 * h), dtype=float), np.arange(12).reshape(4, 3),
                   np.array([-1.0, -1.0, 1.0, 1.0]))
    for delta in (0.0, 1e-14, 1e-12, 1e-9):
        d = uncovered.signed_distance(np.array([[0.3, 0.4, h + delta]]), slab)[0]
        assert d == pytest.approx(-(h - delta), rel=1e-9)


def test_the_deepest_node_named_is_the_same_on_any_partition():
    """Mirror nodes whose depths differ by round-off (1e-14) and whose positions differ by 1e-13: the first in x₁,
    x₂, x₃ is named, on whichever rank each lies and whichever is deeper by round-off; a clearly deeper node wins."""
    comm = MPI.COMM_WORLD
    mirror = [(0.5 - 1e-13, 0.75, -0.004), (0.5, 0.25, -0.004)]
    for deeper in (0, 1):
        depth = np.array([0.004, 0.004])
        depth[deeper] *= 1 + 1e-14
        # the two nodes on the last and the first rank (one rank: both)
        mine = [k for k, rank in enumerate((comm.size - 1, 0)) if rank == comm.rank]
        value, at = uncovered.deepest_point(comm, depth[mine], np.asarray(mirror)[mine].reshape(-1, 3), 1.0)
        assert value == depth.max() and np.array_equal(at, mirror[1])
    depth = np.array([0.00401, 0.004])
    mine = [k for k, rank in enumerate((0, comm.size - 1)) if rank == comm.rank]
    value, at = uncovered.deepest_point(comm, depth[mine], np.asarray(mirror)[mine].reshape(-1, 3), 1.0)
    assert value == 0.00401 and np.array_equal(at, mirror[0])
    assert uncovered.deepest_point(comm, np.zeros(0), np.zeros((0, 3)), 1.0) == (0.0, None)
