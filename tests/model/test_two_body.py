"""Two elastic bodies in contact through contact pairs (issue 18): the change of variables u = M z.

Two disjoint blocks of one hexahedral mesh with non-matching resolutions: the lower block [0, 2]×[0, 1]×[−1, 0]
(its top is the master surface), the smaller upper block above it (its bottom is the slave surface). Checked: a
rigid master (every master-body node prescribed to δ) equals the one-body solve against the plane moved by δ (1e-8); two
deformable bodies agree with the independent Alart–Curnier solver in u with the coupling w = G u (1e-7), obey
the physics, and each body's force from its own residual is equal and opposite; a load path on a pair;
1 rank = 2 ranks with master facets on another rank than their slave nodes; bad input.
"""

from __future__ import annotations


from mpi4py import MPI

import dolfinx
import dolfinx.fem.petsc
import numpy as np
import pytest
import ufl
from conftest import gather_by_coordinates, global_norm

from fenics_coulomb import ContactProblem, Plane
from fenics_coulomb.model.checks import physics_residuals, unconstrained_residual
from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.model.pairs import ContactPair
from fenics_coulomb.model.pairs.forces import pair_forces
from fenics_coulomb.model.dof_values import owned_values

from meshes.two_blocks import TAGS  # noqa: E402
from meshes.two_blocks import two_blocks as two_block_mesh  # noqa: E402

MASTER, SLAVE, LOWER_BOTTOM, UPPER_TOP = (TAGS[k] for k in ("lower_top", "upper_bottom", "lower_bottom", "upper_top"))
TIGHT = {"rtol": 1e-12, "tol": 1e-12}
PHYSICS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction",
           "reaction_balance")


def two_blocks(comm: MPI.Comm, gap: float = 1e-3, lower=(5, 3, 2), upper=(4, 4, 2), partitioner=None,
               upper_origin=(0.2, 0.1), upper_size=(1.6, 0.8, 1.0)):
    """The lower block [0, 2]×[0, 1]×[−1, 0] and the upper block (default [0.2, 1.8]×[0.1, 0.9]×[g, 1 + g]) with
    non-matching resolutions (meshes/two_blocks.py): the mesh and its facet tags."""
    blocks = two_block_mesh(comm, lower=(2.0, 1.0, 1.0), n_lower=lower, upper_origin=upper_origin,
                            upper=upper_size, n_upper=upper, gap=gap, partitioner=partitioner)
    return blocks.mesh, blocks.facet_tags


def elasticity(V, E=70.0, nu=0.3, upper=None):
    """Isotropic Lamé form; ``upper`` = (E, ν) of the upper body (x3 > 0) if it differs."""
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    if upper is not None:
        above = ufl.SpatialCoordinate(V.mesh)[2] > 0.0
        E2, nu2 = upper
        mu = ufl.conditional(above, E2 / (2 * (1 + nu2)), mu)
        lmbda = ufl.conditional(above, E2 * nu2 / ((1 + nu2) * (1 - 2 * nu2)), lmbda)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    return ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx


def pressed_blocks(comm, top=(0.0015, 0.0, -0.004), **mesh_args):
    """Lower block (E = 70, ν = 0.2) clamped at its bottom, the softer upper block (E = 20, ν = 0.45) with its
    top moved by ``top`` (a Constant): their different lateral expansion makes the interface slip."""
    msh, ft = two_blocks(comm, **mesh_args)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    value = dolfinx.fem.Constant(msh, np.asarray(top, dtype=np.float64))
    bcs = [dolfinx.fem.dirichletbc(value, dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)]
    return V, ft, elasticity(V, 70.0, 0.2, upper=(20.0, 0.45)), bcs, value


def prescribed(V, bcs):
    """The prescribed DOFs (unrolled, local) and their values."""
    g = dolfinx.fem.Function(V)
    g.x.array[:] = np.nan
    for bc in bcs:
        bc.set(g.x.array)
    D = np.flatnonzero(~np.isnan(g.x.array))
    return D, g.x.array[D]


def owned(problem):
    return owned_values(problem.u)


def assert_physics(problem, result, label=""):
    checks = physics_residuals(problem.model, result.relative_displacement)
    for key in PHYSICS:
        assert checks[key] < 1e-8, (label, key, checks[key])


@pytest.mark.parametrize("method", ["mortar", "node-to-surface"])
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_rigid_master_equals_the_moved_plane(friction, method):
    """Every node of the lower (master) body prescribed to δ: the pair equals the one-body solve of the upper
    block against the plane x3 = 0 moved by δ, on the same mesh (1e-8): both discretizations reproduce a
    linear gap exactly (dual mortar: Σ_l Φ_jl = 1 and g̃_j / D_j is the gap of a flat pair)."""
    delta = np.array([0.0005, 0.0002, 0.0003])
    msh, ft = two_blocks(MPI.COMM_WORLD)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    a = elasticity(V)
    top = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP))
    lower = dolfinx.fem.locate_dofs_geometrical(V, lambda x: x[2] <= 1e-9)
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.004]), top, V),
           dolfinx.fem.dirichletbc(delta, lower, V)]
    with ContactProblem(a, None, bcs, contact_pairs=[ContactPair(ft, slave=SLAVE, master=MASTER, friction=friction,
                                                                 method=method)],
                        settings=TIGHT, petsc_options_prefix="pair_") as problem:
        _, result = problem.solve()
        assert result.converged and result.counts["open"] < problem.p
        assert_physics(problem, result)
        pair = owned(problem)
    plane = Plane(point=[0, 0, 0], normal=[0, 0, 1], displacement=delta)
    with ContactProblem(a, None, bcs, contact=(ft, [SLAVE]), friction=friction, obstacles=[plane], settings=TIGHT,
                        petsc_options_prefix="plane_") as problem:
        _, reference = problem.solve()
        one = owned(problem)
    assert global_norm(pair - one) <= 1e-8 * global_norm(one)
    if friction > 0:
        assert reference.counts["slip"] + reference.counts["stick"] > 0


def flat_coupling(V, gap: float, lower=(5, 3, 2), size=(2.0, 1.0)):
    """The pairing of the flat interface computed here, independently of fenics_coulomb.model.pairs (serial): every
    upper-bottom node x_s (height g) projects vertically onto the lower block's structured top grid, whose
    bilinear shape functions at (x, y) are the weights. Returns the slave blocks, G with (G u)_s = u_s − Σ φ u_j,
    and the gaps."""
    import scipy.sparse as sp

    x = V.tabulate_dof_coordinates()
    slave = np.flatnonzero(np.isclose(x[:, 2], gap))
    top = np.flatnonzero(np.isclose(x[:, 2], 0.0))
    h = np.array([size[0] / lower[0], size[1] / lower[1]])
    grid = np.full((lower[0] + 1, lower[1] + 1), -1)
    ij = np.rint(x[top, :2] / h).astype(int)
    grid[ij[:, 0], ij[:, 1]] = top
    f = x[slave, :2] / h
    cell = np.clip(np.floor(f).astype(int), 0, np.array(lower[:2]) - 1)
    xi, eta = (f - cell).T
    corners = [(0, 0, (1 - xi) * (1 - eta)), (1, 0, xi * (1 - eta)), (0, 1, (1 - xi) * eta), (1, 1, xi * eta)]
    m, n = slave.size, 3 * x.shape[0]
    rows, cols, data = [], [], []
    for c in range(3):
        rows.append(3 * np.arange(m) + c)
        cols.append(3 * slave + c)
        data.append(np.ones(m))
        for di, dj, w in corners:
            rows.append(3 * np.arange(m) + c)
            cols.append(3 * grid[cell[:, 0] + di, cell[:, 1] + dj] + c)
            data.append(-w)
    G = sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * m, n))
    return slave, G, np.full(m, gap)


@pytest.mark.serial
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_two_deformable_bodies_agree_with_brute_force(friction):
    """Both blocks deformable (non-matching resolutions), the upper one pushed down and sideways: the SCD solve in
    z and the Alart–Curnier solver in u (K without Dirichlet rows, the coupling w = G u from a pairing computed
    here by vertical projection onto the lower block's grid, :func:`flat_coupling`) agree (1e-7); the library's
    pairing is the same; the physics holds; the master reaction is −Σ φ f; each body's force from its own
    residual is equal and opposite."""
    import scipy.sparse as sp
    from brute_force import solve_contact

    V, ft, a, bcs, _ = pressed_blocks(MPI.COMM_SELF, lower=(5, 3, 2), upper=(4, 4, 3))
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=friction, method="node-to-surface")
    # the reference-configuration model the brute force shares (finite sliding: test_finite_sliding*.py)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="bf_",
                        sliding="small") as problem:
        uh, result = problem.solve()
        assert result.converged
        assert_physics(problem, result)
        model = problem.model
        ip, ix, vals = model.A_free.getValuesCSR()
        K = sp.csr_matrix((vals, ix, ip), shape=model.A_free.getSize())
        slave, G, gaps = flat_coupling(V, 1e-3)
        assert np.array_equal(slave, model.pairing.blocks)  # every slave node is a contact node
        assert np.allclose(model.pairing.gap, gaps, rtol=0, atol=1e-14)
        D, values = prescribed(V, bcs)
        sol = solve_contact(K, np.zeros(K.shape[0]), np.arange(3 * slave.size).reshape(-1, 3), gaps, friction,
                            coupling=G, dirichlet=(D, values))  # frames: n = e3, t = e1, e2
        u = owned(problem)
        assert np.linalg.norm(sol.u - u) <= 1e-7 * np.linalg.norm(u)
        force = sol.force  # Cartesian in the identity frames
        assert np.abs(force - result.contact_force).max() <= 1e-7 * np.abs(force).max()
        # the force on each body from its own residual K u − l (no Dirichlet node on either surface's free part)
        full = unconstrained_residual(model, u)
        slave_force = full[model.pairing.blocks].sum(axis=0)
        master_nodes = np.unique(model.pairing.master_blocks[model.pairing.master_blocks >= 0])
        master_force = full[master_nodes].sum(axis=0)
        assert np.allclose(slave_force, result.contact_force.sum(axis=0), rtol=0, atol=1e-10 * abs(slave_force[2]))
        assert np.linalg.norm(slave_force + master_force) <= 1e-8 * np.linalg.norm(slave_force)
        assert np.allclose(result.master_force.reshape(-1, 3)[master_nodes], full[master_nodes], rtol=0,
                           atol=1e-10 * abs(slave_force[2]))
        if friction > 0:
            assert abs(slave_force[0]) > 1e-3 * abs(slave_force[2])  # the shear is carried by friction


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_swapping_slave_and_master_on_matching_meshes(friction):
    """Matching planar meshes (the same footprint and resolution), no Dirichlet node on either surface, equal
    search distances: slave = upper bottom / master = lower top and the swapped pair give the same displacement
    (1e-8): the contact conditions on w = u_s − u_m and on −w with n → −n are the same."""
    results = []
    msh, ft = two_blocks(MPI.COMM_WORLD, lower=(4, 2, 2), upper=(4, 2, 2), upper_origin=(0.0, 0.0),
                         upper_size=(2.0, 1.0, 1.0))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    top = dolfinx.fem.Constant(msh, np.array([0.0008, 0.0, -0.004]))
    bcs = [dolfinx.fem.dirichletbc(top, dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)]
    a = elasticity(V, 70.0, 0.2, upper=(20.0, 0.45))
    for slave, master in ((SLAVE, MASTER), (MASTER, SLAVE)):
        pair = ContactPair(ft, slave=slave, master=master, friction=friction, search_distance=0.05)
        # the swap is an identity of the reference-configuration model: in the deformed one the equal footprints'
        # borders slide past each other differently
        with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT,
                            petsc_options_prefix="swap_", sliding="small") as problem:
            _, result = problem.solve()
            assert result.converged and problem.p == 15  # every node of the 5 × 3 interface
            assert_physics(problem, result, f"slave {slave}")
            results.append(owned(problem))
    assert global_norm(results[0] - results[1]) <= 1e-8 * global_norm(results[0])


def test_load_path_on_a_pair():
    """Press, then shear in two steps, then reverse: friction on the increment of the relative slip; each step
    obeys the physics on its increment; the reversal leaves a state that differs from the static solve."""
    V, ft, a, bcs, top = pressed_blocks(MPI.COMM_WORLD, top=(0.0, 0.0, -0.004))
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="tbpath_") as problem:
        for k, shear in enumerate([0.0, 0.0006, -0.0002]):
            top.value[0] = shear
            _, result = problem.solve()
            assert result.converged and problem.step == k + 1
            assert_physics(problem, result, f"step {k + 1}")
        path_end = owned(problem)
        problem.reset()
        problem.solve()
        static = owned(problem)
    assert global_norm(path_end - static) > 1e-4 * global_norm(static)


def test_one_rank_equals_two_ranks():
    """The pressed and sheared blocks on COMM_WORLD (GAMG) and on COMM_SELF (LU) agree at every node (1e-8); on
    several ranks some slave node's master facet has a node owned by another rank."""
    results = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        # each body on its own rank: every master facet on another rank than its slave nodes
        V, ft, a, bcs, _ = pressed_blocks(comm, partitioner="bodies" if comm.size > 1 else None)
        pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3)
        # GAMG with the bodies' near-nullspace (I − Φ) r_b on this communicator, ILU or LU alone
        settings = {**TIGHT, "pc": "gamg" if comm is MPI.COMM_WORLD else "lu"}
        with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=settings,
                            petsc_options_prefix=f"tb{comm.size}_") as problem:
            _, result = problem.solve()
            assert result.converged
            if comm.size > 1:
                imap = V.dofmap.index_map
                lo, hi = imap.local_range
                stencil = problem.model.pairing.master_blocks
                foreign = np.any((stencil >= 0) & ((stencil < lo) | (stencil >= hi)))
                assert comm.allreduce(bool(foreign), op=MPI.LOR)
            results.append(gather_by_coordinates(V, owned(problem), comm))
    (x0, u0), (x1, u1) = results
    assert np.allclose(x0, x1)
    assert np.abs(u0 - u1).max() <= 1e-8 * np.abs(u1).max()


@pytest.mark.serial
@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_pair_and_rigid_obstacle_agree_with_brute_force(friction):
    """A pair (upper on lower) and a rigid plane under the lower block (its bottom, 3e-5 above the plane, is the
    obstacles' contact boundary; the lower block is held by its clamped sides): the SCD solve and the
    Alart–Curnier solver with w = G u on the slave nodes and u itself on the obstacle's nodes (pairing computed
    here) agree (1e-7); the physics holds."""
    import scipy.sparse as sp
    from brute_force import solve_contact

    msh, ft = two_blocks(MPI.COMM_SELF)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    sides = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["lower_sides"]))
    top = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP))
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0008, 0.0, -0.004]), top, V),
           dolfinx.fem.dirichletbc(np.zeros(3), sides, V)]
    a = elasticity(V, 70.0, 0.2, upper=(20.0, 0.45))
    plane = Plane(point=[0.0, 0.0, -1.00003], normal=[0.0, 0.0, 1.0], name="floor")
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=friction, method="node-to-surface")
    # the reference-configuration model the brute force shares (finite sliding: test_finite_sliding*.py)
    with ContactProblem(a, None, bcs, contact=(ft, [LOWER_BOTTOM]), obstacles=[plane], friction=friction,
                        contact_pairs=[pair], settings=TIGHT, petsc_options_prefix="mixed_",
                        sliding="small") as problem:
        _, result = problem.solve()
        assert result.converged
        assert_physics(problem, result)
        model = problem.model
        paired = model.coupling.paired_mask(model.contact.size)
        assert np.any(paired) and np.any(~paired)
        ip, ix, vals = model.A_free.getValuesCSR()
        K = sp.csr_matrix((vals, ix, ip), shape=model.A_free.getSize())
        slave, G_pair, g_pair = flat_coupling(V, 1e-3)
        x = V.tabulate_dof_coordinates()
        rigid = np.setdiff1d(np.flatnonzero(np.isclose(x[:, 2], -1.0)), sides)  # blocks without a Dirichlet side
        E = sp.csr_matrix((np.ones(3 * rigid.size),
                           (np.arange(3 * rigid.size), (3 * rigid[:, None] + np.arange(3)).ravel())),
                          shape=(3 * rigid.size, K.shape[0]))
        G = sp.vstack([G_pair, E]).tocsr()
        gaps = np.concatenate([g_pair, x[rigid, 2] + 1.00003])
        assert np.array_equal(np.sort(np.concatenate([slave, rigid])), model.contact.blocks)
        D, values = prescribed(V, bcs)
        sol = solve_contact(K, np.zeros(K.shape[0]), np.arange(3 * gaps.size).reshape(-1, 3), gaps, friction,
                            coupling=G, dirichlet=(D, values))
        u = owned(problem)
        assert np.linalg.norm(sol.u - u) <= 1e-7 * np.linalg.norm(u)
        assert sol.force[slave.size:, 2].max() > 0  # the floor carries the lower block


def test_a_node_on_a_pair_and_an_obstacle_goes_to_the_smaller_gap():
    """The upper block's bottom is both the slave surface (gap 1e-3 to the lower block) and the contact boundary
    of a rigid plane: at 5e-4 below it the plane wins every node (the solve equals the one-body solve against
    the plane), at 5.5e-3 below (beyond the press of 4e-3) the pair wins every node (the solve equals the pair
    alone)."""
    V, ft, a, bcs, _ = pressed_blocks(MPI.COMM_WORLD, top=(0.0, 0.0, -0.004))
    pair = ContactPair(ft, slave=SLAVE, master=MASTER)
    for height, winner in ((5e-4, "plane"), (-4.5e-3, "pair")):
        plane = Plane(point=[0.0, 0.0, height], normal=[0.0, 0.0, 1.0])
        with ContactProblem(a, None, bcs, contact=(ft, [SLAVE]), obstacles=[plane], contact_pairs=[pair],
                            settings=TIGHT, petsc_options_prefix="both_") as problem:
            _, result = problem.solve()
            mask = problem.model.coupling.paired_mask(problem.model.contact.size)
            paired = MPI.COMM_WORLD.allreduce(int(np.sum(mask)), op=MPI.SUM)
            assert problem.p == 25 and paired == (25 if winner == "pair" else 0)
            assert result.checks["shared_penetration"] == 0.0
            both = owned(problem)
        kwargs = dict(contact_pairs=[pair]) if winner == "pair" else dict(contact=(ft, [SLAVE]), obstacles=[plane])
        with ContactProblem(a, None, bcs, settings=TIGHT, petsc_options_prefix="one_", **kwargs) as problem:
            problem.solve()
            alone = owned(problem)
        assert global_norm(both - alone) <= 1e-10 * global_norm(alone), winner


@pytest.mark.parametrize("sliding", ["small", "finite"])
def test_a_node_that_must_meet_a_pair_and_an_obstacle_is_no_exit_0(sliding):
    """The plane 5e-4 below the lower block's top (1.5e-3 below the slave surface, inside the partner body): the
    pair wins (the smaller gap), the press takes the slave nodes through the plane, where a node would have to meet
    both constraints. The smaller |g| kept the pair in every configuration and the solve passed with the nodes
    2.2e-3 inside the plane (exit 0); now small sliding fails its physics check shared_penetration, finite sliding
    alternates between the two (the smaller signed gap in each configuration) and fails naming it."""
    from fenics_coulomb.errors import SolverError

    V, ft, a, bcs, _ = pressed_blocks(MPI.COMM_WORLD, top=(0.0, 0.0, -0.004))
    pair = ContactPair(ft, slave=SLAVE, master=MASTER)
    plane = Plane(point=[0.0, 0.0, -5e-4], normal=[0.0, 0.0, 1.0])
    with ContactProblem(a, None, bcs, contact=(ft, [SLAVE]), obstacles=[plane], contact_pairs=[pair],
                        settings=TIGHT, sliding=sliding, petsc_options_prefix="inside_") as problem:
        with pytest.raises(SolverError, match="shared_penetration residual") as failure:
            problem.solve()
        assert failure.value.reason == ("physics_check" if sliding == "small" else "geometry")
        # independently: the deepest slave node (X3 = 1e-3) below the plane x3 = −5e-4 in the last iterate; small
        # sliding gives every slave node to the pair, so each one that ends below the plane counts
        if sliding == "small":
            X, u = gather_by_coordinates(problem.V, problem.u.x.array)
            slave = np.isclose(X[:, 2], 1e-3)
            depth = problem.model.coupling.shared_depth(problem.model, failure.value.result.displacement)
            assert np.max(-5e-4 - (X[slave, 2] + u[slave, 2])) == pytest.approx(depth, rel=1e-9)


def side_by_side(gap: float, sliding: str):
    """Two blocks side by side on a rigid floor x3 = −2 (the two-block mesh turned by 90° about x2), the upper
    block's face x1 = gap the slave of the lower's face x1 = 0, squeezed by −0.004 along x1 and pressed down by
    gravity: the slave face's bottom-edge nodes are floor contact nodes too (contact boundary: both bottoms)."""
    msh, ft = two_blocks(MPI.COMM_WORLD, gap=gap, lower=(4, 4, 2), upper=(3, 4, 2), upper_origin=(0.0, 0.0),
                         upper_size=(2.0, 1.0, 1.0))
    x = msh.geometry.x
    X = x.copy()
    x[:, 0], x[:, 2] = X[:, 2], -X[:, 0]  # stacked → side by side, both bottoms on x3 = −2
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    v = ufl.TestFunction(V)
    L = ufl.inner(dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -1.0])), v) * ufl.dx
    fixed = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM))  # now x1 = −1
    pushed = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP))  # now x1 = 1 + gap
    bcs = [dolfinx.fem.dirichletbc(np.zeros(3), fixed, V),
           dolfinx.fem.dirichletbc(np.array([-0.004, 0.0, 0.0]), pushed, V)]
    floor = Plane(point=[0, 0, -2.0], normal=[0, 0, 1], name="floor")
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3, method="node-to-surface")
    sides = [TAGS["lower_sides"], TAGS["upper_sides"]]
    return ContactProblem(elasticity(V), L, bcs, contact=(ft, sides), friction=0.3, obstacles=[floor],
                          contact_pairs=[pair], sliding=sliding, petsc_options_prefix="side_")


def test_nodes_on_a_pair_and_a_floor_are_checked_both_ways():
    """The slave face's bottom edge on the floor, the blocks 1e-3 apart: the floor (gap 0) wins those nodes, and
    their pair constraint — unenforced — is now measured (shared_penetration: 0 before, however deep); touching
    (gap 0: the pair wins the tie), the floor's is, and the solve fails instead of ending with exit 0 and the edge
    nodes inside the floor."""
    with side_by_side(1e-3, "small") as problem:
        uh, result = problem.solve()
        assert problem.model.coupling.shared_nodes() > 0
        depth = problem.model.coupling.shared_depth(problem.model, result.displacement)
        assert 1e-5 < depth < 1e-3  # the edge nodes end ~1e-4 inside the lower block's face
        assert result.checks["shared_penetration"] > 0.0
        # independently: small sliding pairs in X, where each floor-edge node of the slave face (X1 = 1e-3,
        # X3 = −2) lies straight across from a master node (X1 = 0): its linearized gap is 1e-3 + u1(slave) −
        # u1(master) (normal +e1), the deepest the check's value
        X, u = gather_by_coordinates(problem.V, uh.x.array)
        edge = np.isclose(X[:, 2], -2.0)
        slave, master = edge & np.isclose(X[:, 0], 1e-3), edge & np.isclose(X[:, 0], 0.0)
        assert np.allclose(X[slave, 1], X[master, 1], rtol=0, atol=1e-12)  # sorted: partner by partner
        assert np.max(-(1e-3 + u[slave, 0] - u[master, 0])) == pytest.approx(depth, rel=1e-9)
    with side_by_side(0.0, "small") as problem:
        with pytest.raises(SolverError, match="shared_penetration residual"):
            problem.solve()


def test_free_slave_nodes_that_penetrate_are_counted():
    """A search distance below the initial gap leaves every slave node free (a warning, no contact node): pressed
    down, they penetrate the master surface, the check after the solve counts them and the solve fails its
    physics checks (free_penetration: no exit 0 with the bodies interpenetrating); with the default search
    distance none does."""
    from fenics_coulomb.errors import SolverError

    V, ft, a, bcs, _ = pressed_blocks(MPI.COMM_WORLD, top=(0.0, 0.0, -0.004))
    short = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.0, search_distance=1e-4)
    with ContactProblem(a, None, bcs, contact_pairs=[short], petsc_options_prefix="free_") as problem:
        with pytest.raises(SolverError, match="free_penetration") as failure:
            problem.solve()
        result = failure.value.result
        assert problem.p == 0 and result.reason == "physics_check"
        free = problem.model.pairing.free
        assert MPI.COMM_WORLD.allreduce(free["blocks"].size) == 25  # the 5 × 5 slave nodes, all over the master
        assert problem.model.free_slave_penetrations(result.displacement) == 25
    with ContactProblem(a, None, bcs, contact_pairs=[ContactPair(ft, slave=SLAVE, master=MASTER)],
                        petsc_options_prefix="free_") as problem:
        _, result = problem.solve()
        assert problem.p == 25
        assert problem.model.free_slave_penetrations(result.displacement) == 0


def test_bad_input():
    """A body without supports, pairs together with obstacles: InputError naming the problem."""
    msh, ft = two_blocks(MPI.COMM_WORLD)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    a = elasticity(V)
    bottom = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER)
    with pytest.raises(InputError, match="body 1 .* rigid motions"):
        ContactProblem(a, None, [bottom], contact_pairs=[pair], petsc_options_prefix="bad_")
    with pytest.raises(InputError, match="give the contact boundary of the obstacles"):
        ContactProblem(a, None, [bottom], contact_pairs=[pair], obstacles=[Plane(point=[0, 0, 0], normal=[0, 0, 1])],
                       petsc_options_prefix="bad_")


def _held_blocks(traction: float):
    """The two blocks, the lower bottom clamped, the upper top held in x1 and x2 only and loaded by the traction
    (0, 0, ``traction``): the form, the load, the clamp and the two component supports, and the facet tags."""
    msh, ft = two_blocks(MPI.COMM_WORLD, gap=0.0)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)
    top = ft.find(UPPER_TOP)
    held = [dolfinx.fem.dirichletbc(0.0, dolfinx.fem.locate_dofs_topological(V.sub(k), 2, top), V.sub(k))
            for k in (0, 1)]
    ds = ufl.Measure("ds", domain=msh, subdomain_data=ft)
    L = ufl.inner(dolfinx.fem.Constant(msh, np.array([0.0, 0.0, traction])), ufl.TestFunction(V)) * ds(UPPER_TOP)
    return elasticity(V), L, clamp, held, ft


@pytest.mark.parametrize("friction", [0.0, 0.3])
def test_a_body_held_along_the_contact_normal_by_contact_alone(friction):
    """The upper block held only in x1 and x2 on its top face (its motion along x3 left free) and pressed by a
    traction q on the clamped lower block: accepted; the pair carries the load, P = q·area, the contact
    balance and physics hold. Held in x1 only (x2 and the rotation about x3 free: tangential, which contact
    cannot hold) it is refused, naming the body."""
    q = 0.05
    a, L, clamp, held, ft = _held_blocks(-q)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=friction)
    with ContactProblem(a, L, [clamp, *held], contact_pairs=[pair], settings=TIGHT,
                        petsc_options_prefix="held_by_contact_") as problem:
        _, result = problem.solve()
        assert result.converged
        assert_physics(problem, result)
        (forces,) = pair_forces(problem.model, result, [pair])
        load = q * 1.6 * 0.8  # the traction on the upper top
        assert abs(forces["force_on_slave_body"][2] - load) <= 1e-8 * load  # the lower block pushes it up by q·area
        assert forces["balance"] < 1e-8
    with pytest.raises(InputError, match="body 1 .* rigid motions"):
        ContactProblem(a, L, [clamp, held[0]], contact_pairs=[pair], petsc_options_prefix="held_by_contact_")


def test_a_body_held_by_contact_alone_that_lifts_off_is_named():
    """The upper block of the test above pulled UP by its top traction: nothing holds its motion along x3 once
    it lifts off, and the solve fails (max_it) with a message naming the body, its centroid and the pair —
    on every rank, with the pair's closed nodes in the last iterate. Pressed down, the same problem converges
    (the previous test)."""
    a, L, clamp, held, ft = _held_blocks(0.05)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3, name="blocks")
    with ContactProblem(a, L, [clamp, *held], contact_pairs=[pair], settings={**TIGHT, "max_it": 8},
                        petsc_options_prefix="lifted_off_") as problem:
        with pytest.raises(SolverError) as failure:
            problem.solve()
    message = str(failure.value)
    assert failure.value.reason in ("max_iterations", "ksp_breakdown", "line_search")  # 1 rank / 2 ranks differ
    assert "body 1 (centroid (" in message and "is held by contact alone (contact pair 'blocks' 1)" in message
    assert "lift it off" in message and "nothing holds its rigid motion" in message


def _grams(midpoints, normals):
    """G_c and G_r of check_rigid_support for facets (midpoints about the centroid, unit normals)."""
    from fenics_coulomb.model.nullspace import rigid_modes_at

    modes = rigid_modes_at(midpoints)
    seen = np.einsum("fi,fia->fa", normals, modes)
    return np.einsum("fa,fb->ab", seen, seen), np.einsum("fia,fib->ab", modes, modes)


@pytest.mark.serial
@pytest.mark.parametrize("sectors", [12, 16, 64])
def test_held_fraction_of_a_shaft_turning_in_its_bore(sectors):
    """A faceted cylinder (triangles, their centroids and normals): the rotation about the axis, free in the
    continuum, has a normal fraction below HELD_FRACTION from 12 facets around (∝ (h/R)²); the translations
    across the axis are held (fraction ~ 1/2: radial on half the circumference); a flat face's normal
    translation 1, its turn about the normal 0."""
    from fenics_coulomb.model.pairs.two_body import HELD_FRACTION, held_fraction

    theta = np.linspace(0.0, 2 * np.pi, sectors + 1)
    z = np.array([-0.4, 0.4])
    points, normals = [], []
    for k in range(sectors):  # each quadrilateral strip split into two triangles
        a = [np.array([0.3 * np.cos(t), 0.3 * np.sin(t), h]) for t in theta[k:k + 2] for h in z]
        for tri in ((a[0], a[2], a[3]), (a[0], a[3], a[1])):
            n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
            points.append(np.mean(tri, axis=0))
            normals.append(n / np.linalg.norm(n))
    Gc, Gr = _grams(np.array(points), np.array(normals))
    rotation = np.eye(6)[:, [5]]
    translations = np.eye(6)[:, [0, 1]]
    assert held_fraction(rotation, Gc, Gr) < HELD_FRACTION
    assert held_fraction(translations, Gc, Gr) > HELD_FRACTION
    flat = np.array([[x, y, 0.0] for x in np.linspace(-0.4, 0.4, 5) for y in np.linspace(-0.4, 0.4, 5)])
    Gc, Gr = _grams(flat, np.tile([0.0, 0.0, 1.0], (flat.shape[0], 1)))
    assert held_fraction(np.eye(6)[:, [2]], Gc, Gr) == pytest.approx(1.0)
    assert held_fraction(np.eye(6)[:, [5]], Gc, Gr) == pytest.approx(0.0, abs=1e-15)  # turning on a flat face
