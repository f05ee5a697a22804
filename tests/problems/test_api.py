"""The Python API: a user's own mesh, forms, boundary conditions and facet tags solved by ContactProblem."""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from conftest import gather_by_coordinates, global_norm, read_solution

from fenics_coulomb import ContactProblem, InputError
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.cli import main
from fenics_coulomb.scenes.partition import box_partitioner
from fenics_coulomb.scd.resolvent import STICK
from fenics_coulomb.model.dof_values import owned_values

PHYSICS_TOL = {"equilibrium": 1e-9, "penetration": 1e-9, "negative_pressure": 1e-9, "complementarity": 1e-9,
               "cone": 1e-9, "slip_direction": 1e-6, "reaction_balance": 1e-9}
LEFT, RIGHT, BOTTOM, TOP, SIDES = 1, 2, 3, 4, 5


def user_cuboid(comm: MPI.Comm, cells: list[int]):
    """A user's own mesh of the paper's cuboid with a cone-shaped bottom (d2), and its own facet tags, partitioned
    as the README asks (the deterministic box partitioner: two meshes made alike have the same partition, so the
    tests may compare the owned entries of their solutions; DOLFINx's default does not repeat on 2 ranks)."""
    corners = [np.zeros(3), np.array([2.0, 1.0, 1.0])]
    msh = dolfinx.mesh.create_box(comm, corners, cells, dolfinx.mesh.CellType.hexahedron,
                                  partitioner=box_partitioner(corners, cells))
    fdim = 2
    msh.topology.create_connectivity(fdim, 3)
    found = [(tag, dolfinx.mesh.locate_entities_boundary(msh, fdim, where)) for tag, where in [
        (LEFT, lambda x: np.isclose(x[0], 0.0)), (RIGHT, lambda x: np.isclose(x[0], 2.0)),
        (BOTTOM, lambda x: np.isclose(x[2], 0.0)), (TOP, lambda x: np.isclose(x[2], 1.0)),
        (SIDES, lambda x: np.isclose(x[1], 0.0) | np.isclose(x[1], 1.0))]]
    facets = np.hstack([f for _, f in found]).astype(np.int32)
    values = np.hstack([np.full(f.size, tag, dtype=np.int32) for tag, f in found])
    order = np.argsort(facets)
    tags = dolfinx.mesh.meshtags(msh, fdim, facets[order], values[order])
    # the bottom follows d2(x1, x2) = max(0.01 − 0.015·√(0.5(x1−1)² + 2(x2−0.5)²), 0.0025), evenly spaced to x3 = 1
    x = msh.geometry.x
    d = np.maximum(0.01 - 0.015 * np.sqrt(0.5 * (x[:, 0] - 1.0) ** 2 + 2.0 * (x[:, 1] - 0.5) ** 2), 0.0025)
    t = np.clip(x[:, 2], 0.0, 1.0)
    t[np.abs(t) < 1e-12] = 0.0
    x[:, 2] = d + t * (1.0 - d)
    return msh, tags


def lame_form(V, E: float = 70.0, nu: float = 0.334):
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))

    def eps(w):
        return ufl.sym(ufl.grad(w))

    dx = ufl.dx(metadata={"quadrature_degree": 2})
    return ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * dx


def orthotropic_form(V, E=(140.0, 10.0, 10.0), nu=(0.3, 0.3, 0.45), G=(5.0, 5.0, 3.5)):
    """Orthotropic material with the fibres along x1 (compliance S, stiffness C = S⁻¹ in Voigt notation)."""
    S = np.zeros((6, 6))
    E1, E2, E3 = E
    nu12, nu13, nu23 = nu
    S[:3, :3] = [[1 / E1, -nu12 / E1, -nu13 / E1], [-nu12 / E1, 1 / E2, -nu23 / E2], [-nu13 / E1, -nu23 / E2, 1 / E3]]
    S[3, 3], S[4, 4], S[5, 5] = 1 / G[2], 1 / G[1], 1 / G[0]  # 23, 13, 12
    C = ufl.as_matrix(np.linalg.inv(S).tolist())
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def voigt(w):
        e = ufl.sym(ufl.grad(w))
        return ufl.as_vector([e[0, 0], e[1, 1], e[2, 2], 2 * e[1, 2], 2 * e[0, 2], 2 * e[0, 1]])

    return ufl.inner(C * voigt(u), voigt(v)) * ufl.dx(metadata={"quadrature_degree": 2})


def user_problem(comm, form=lame_form, prefix="user_", friction=0.23, cells=(12, 6, 6), **kwargs) -> ContactProblem:
    """The paper's d2/L2 case, at lev 3 (12 × 6 × 6 hexahedra) by default, written by a user."""
    msh, tags = user_cuboid(comm, list(cells))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    v = ufl.TestFunction(V)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags)
    L = (ufl.inner(dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -1.0])), v) * ds(TOP)
         + ufl.inner(dolfinx.fem.Constant(msh, np.array([-0.17, -0.1, 0.0])), v) * ds(RIGHT))
    left = dolfinx.fem.locate_dofs_topological(V, 2, tags.find(LEFT))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), left, V)
    if callable(friction):
        friction = friction(V)
    return ContactProblem(form(V), L, bcs=[bc], contact=(tags, [BOTTOM]), friction=friction,
                          petsc_options_prefix=prefix, **kwargs)


def test_user_script_equals_cli(mpi_tmp_path):
    """d2/L2 at lev 3 built by a user (create_box, own bottom, own Lamé form and facet tags) equals the command
    line's result to 1e-10."""
    out = mpi_tmp_path / "cli"
    assert main(["--lev", "3", "--gap", "d2", "--load", "L2", "--rtol", "1e-12", "--out", str(out), "--quiet",
                 "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    xs, us = read_solution(out)
    with user_problem(MPI.COMM_WORLD, settings={"rtol": 1e-12}) as problem:
        uh, result = problem.solve()
        assert result.converged and problem.p == 12 * 7
        x, u = gather_by_coordinates(problem.V, uh.x.array)
    assert np.allclose(x, xs, atol=1e-12)
    assert np.linalg.norm(u - us) <= 1e-10 * np.linalg.norm(us)


def test_orthotropic_body_differs_and_passes_the_physics_checks():
    """An orthotropic material (stiff along x1, soft across) gives another solution that passes every check."""
    comm = MPI.COMM_WORLD
    with user_problem(comm, settings={"rtol": 1e-12}) as iso:
        u_iso = owned_values(iso.solve()[0])
    with user_problem(comm, form=orthotropic_form, settings={"rtol": 1e-12}) as ortho:
        uh, result = ortho.solve()
        u = owned_values(uh)
        checks = physics_residuals(ortho.model, u)
        counts = result.counts
    assert result.converged
    for key, tol in PHYSICS_TOL.items():
        assert checks[key] < tol, (key, checks[key])
    assert counts["stick"] + counts["slip"] > 0
    assert global_norm(u - u_iso) > 0.05 * global_norm(u_iso)
    # softer across the fibres: the top sinks further under the same pressure (x3 displacement larger)
    assert global_norm(u.reshape(-1, 3)[:, 2]) > global_norm(u_iso.reshape(-1, 3)[:, 2])


def pressed_block(comm, bcs_for, L_for=None, friction=0.3, settings=None):
    """A small block 1 × 1 × 0.5 at 0.01 above the plane, 4 × 4 × 2 cells, with the user's BCs."""
    msh = dolfinx.mesh.create_box(comm, [np.array([0.0, 0.0, 0.01]), np.array([1.0, 1.0, 0.51])], [4, 4, 2],
                                  dolfinx.mesh.CellType.hexahedron)
    msh.topology.create_connectivity(2, 3)
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.01))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 7, np.int32))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    bcs = bcs_for(V, msh)
    L = L_for(V, msh) if L_for else None
    return ContactProblem(lame_form(V), L, bcs=bcs, contact=(tags, [7]), friction=friction,
                          settings=settings or {"rtol": 1e-12}, petsc_options_prefix="pressed_")


def top_and_side_bcs(V, msh, push=-0.03, shear=0.004):
    """Top face moved by (shear, 0, push) in two single-component BCs; the side x2 = 0 a roller (u2 = 0)."""
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.51))
    side = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[1], 0.0))
    bcs = []
    for comp, value, facets in ((2, push, top), (0, shear, top), (1, 0.0, side)):
        dofs = dolfinx.fem.locate_dofs_topological(V.sub(comp), 2, facets)
        bcs.append(dolfinx.fem.dirichletbc(PETSc.ScalarType(value), dofs, V.sub(comp)))
    return bcs


def everywhere(comm: MPI.Comm, holds: bool) -> bool:
    """True when ``holds`` is true on every rank: a local check that fails on some ranks only fails the test on
    all of them, instead of leaving the others waiting in the next collective call."""
    return bool(comm.allreduce(bool(holds), op=MPI.LAND))


@pytest.mark.parametrize("pc", ["auto", "gamg"])
def test_nonzero_and_single_component_dirichlet(pc):
    """Prescribed non-zero values enter through lifting: the solution takes them bit for bit (also with GAMG,
    whose solves leave round-off in the Dirichlet rows), the free rows are in equilibrium by an assembly
    without boundary conditions, and the nodes of the roller side u2 = 0 through the bottom are contact nodes
    (u2 tangential to the contact) whose contact force has no u2 component."""
    comm = MPI.COMM_WORLD
    with pressed_block(comm, top_and_side_bcs, settings={"rtol": 1e-12, "pc": pc}) as problem:
        uh, result = problem.solve()
        assert result.converged and result.pc == (pc if pc != "auto" else result.pc)
        V = problem.V
        n_owned = 3 * V.dofmap.index_map.size_local
        u = uh.x.array[:n_owned].reshape(-1, 3)
        x = V.tabulate_dof_coordinates()[: n_owned // 3]
        top = np.isclose(x[:, 2], 0.51)
        assert everywhere(comm, np.all(u[top, 2] == PETSc.ScalarType(-0.03)))
        assert everywhere(comm, np.all(u[top, 0] == PETSc.ScalarType(0.004)))
        assert everywhere(comm, np.all(u[np.isclose(x[:, 1], 0.0), 1] == 0.0))
        # 5 × 5 bottom nodes, the 5 on the roller side included
        assert problem.p == 25
        cdofs = problem.model.contact.local_dofs
        on_roller = np.isclose(V.tabulate_dof_coordinates()[cdofs[:, 0] // 3, 1], 0.0)
        assert comm.allreduce(int(np.sum(on_roller)), op=MPI.SUM) == 5
        assert np.all(result.contact_force[on_roller, 1] == 0.0)
        # equilibrium of the free, non-contact rows with the unconstrained operator (no lifting involved)
        residual = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(ufl.action(problem.model.a_ufl, uh)))
        residual.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        r = residual.getArray(readonly=True).copy()
        residual.destroy()
        free = np.ones(r.size, bool)
        free[problem.model.dirichlet_rows] = False
        free[cdofs.ravel()] = False
        scale = comm.allreduce(float(np.abs(r).max()), op=MPI.MAX)
        assert comm.allreduce(float(np.abs(r[free]).max(initial=0.0)), op=MPI.MAX) < 1e-9 * scale
        # Signorini and Coulomb on the contact nodes: the pushed block touches, pressed and sheared
        checks = physics_residuals(problem.model, owned_values(uh))
        for key in ("penetration", "negative_pressure", "complementarity", "cone", "slip_direction"):
            assert checks[key] < 1e-8, (key, checks[key])
        assert result.counts["slip"] + result.counts["stick"] > 0
        lam = comm.allreduce(float(np.sum(result.normal_force)), op=MPI.SUM)
        assert lam > 0.0


def friction_field(expression):
    """A scalar P1 friction field F(x) for a user problem."""
    def make(V):
        F = dolfinx.fem.Function(dolfinx.fem.functionspace(V.mesh, ("Lagrange", 1)))
        F.interpolate(expression)
        return F
    return make


def test_friction_field():
    """A per-node friction field equal to a constant gives the constant's solution; a field with a
    frictionless half (x1 > 1) gives another solution that obeys the cone with its own coefficients and
    has no sticking node where F = 0."""
    comm = MPI.COMM_WORLD
    with user_problem(comm, settings={"rtol": 1e-12}) as scalar:
        u_scalar = owned_values(scalar.solve()[0])
    with user_problem(comm, friction=friction_field(lambda x: np.full(x.shape[1], 0.23)),
                      settings={"rtol": 1e-12}) as field:
        u_field = owned_values(field.solve()[0])
    assert global_norm(u_field - u_scalar) <= 1e-12 * global_norm(u_scalar)
    with user_problem(comm, friction=friction_field(lambda x: np.where(x[0] > 1.0 + 1e-9, 0.0, 0.5)),
                      settings={"rtol": 1e-12}) as half:
        uh, result = half.solve()
        assert result.converged
        F = half.model.friction
        x1 = half.model.contact.coordinates[:, 0]
        assert np.all(F[x1 > 1.0 + 1e-9] == 0.0) and np.all(F[x1 <= 1.0] == 0.5)
        assert not np.any(result.states[F == 0.0] == STICK)
        checks = physics_residuals(half.model, owned_values(uh))
        for key, tol in PHYSICS_TOL.items():
            assert checks[key] < tol, (key, checks[key])
        assert global_norm(owned_values(uh) - u_scalar) > 1e-3 * global_norm(u_scalar)


def test_options_prefix_and_cleanup():
    """Every PETSc object is under the prefix, petsc_options reach the KSP and are gone afterwards, the
    context manager destroys the problem; an empty prefix is refused."""
    comm = MPI.COMM_WORLD
    opts = PETSc.Options()
    before = set(opts.getAll())
    with user_problem(comm, prefix="mine_", petsc_options={"ksp_rtol": 0.05, "ksp_max_it": 500}) as problem:
        assert set(opts.getAll()) == before
        solver = problem.solver
        assert solver.ksp.getOptionsPrefix() == "mine_" and solver.M.getOptionsPrefix() == "mine_"
        assert problem.A.getOptionsPrefix() == "mine_A_"
        assert solver.tol == 0.05 and solver.ksp.getTolerances()[3] == 500
        _, result = problem.solve()
        assert result.converged and set(opts.getAll()) == before
        assert result.records[0].forcing == 0.05 and all(rec.forcing <= 0.05 for rec in result.records)
    assert problem._solver is None and problem._model is None
    with pytest.raises(InputError, match="prefix"):
        user_problem(comm, prefix="")


def test_start_from_a_coarser_function():
    """solve(u0) interpolates a Function from another mesh; it reaches the same solution from a smaller residual."""
    comm = MPI.COMM_WORLD
    with user_problem(comm, prefix="coarse_", cells=(6, 3, 3)) as coarse:
        u_coarse = coarse.solve()[0].copy()
    with user_problem(comm, settings={"rtol": 1e-12}) as fine:
        _, ref = fine.solve()
        u_ref = owned_values(fine.u)
    with user_problem(comm, settings={"rtol": 1e-12}) as fine:
        uh, result = fine.solve(u_coarse)
        assert result.converged
        assert result.residual_history[0] < 0.5 * ref.residual_history[0]
        assert global_norm(owned_values(uh) - u_ref) <= 1e-8 * global_norm(u_ref)


@pytest.fixture(scope="module")
def lifted_solves() -> dict[bool, dict]:
    """A body lifted off the plane, solved with and without the predictor: each case of the test below checks its
    own solve against the other's, so both are solved once for both cases (plain NumPy data, no PETSc object)."""
    comm = MPI.COMM_WORLD

    def lifted(V, msh):
        return top_and_side_bcs(V, msh, push=0.005, shear=0.0)

    solves = {}
    for predictor in (False, True):
        with pressed_block(comm, lifted, settings={"rtol": 1e-12, "predictor": predictor}) as problem:
            uh, result = problem.solve()
            solves[predictor] = {"converged": result.converged, "linear": result.linear, "p": problem.p,
                                 "counts": dict(result.counts), "u": owned_values(uh).copy()}
    return solves


@pytest.mark.parametrize("predictor", [False, True])
def test_predictor_and_no_contact_shortcut(predictor, lifted_solves):
    """With the predictor, a body lifted off the plane is solved by one linear solve (the same solution as the
    Newton method); without contact nodes the shortcut is taken unless switched off."""
    comm = MPI.COMM_WORLD
    own, other = lifted_solves[predictor], lifted_solves[not predictor]
    assert own["converged"] and own["linear"] == predictor
    assert own["counts"] == {"open": own["p"], "stick": 0, "slip": 0} and own["p"] > 0
    u = own["u"]
    assert global_norm(other["u"] - u) <= 1e-8 * global_norm(u)

    msh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.ones(3)], [2, 2, 2], dolfinx.mesh.CellType.hexahedron)
    msh.topology.create_connectivity(2, 3)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    left = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[0], 0.0))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(left).astype(np.int32), np.full(left.size, 1, np.int32))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, left), V)
    L = ufl.inner(dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -0.1])), ufl.TestFunction(V)) * ufl.dx
    # the contact boundary is the clamped face: every node has a constrained component, so no contact node
    with ContactProblem(lame_form(V), L, [bc], (tags, [1]), 0.3, settings={"no_contact_shortcut": not predictor},
                        petsc_options_prefix="free_") as free:
        _, result = free.solve()
        assert free.p == 0 and result.converged and result.linear == (not predictor)


def test_obstacle_plane_from_obstacles_module():
    """The obstacle is fenics_coulomb.model.obstacles.Plane (default x3 = 0): a plane lowered by h gives every gap + h;
    a tilted plane gives each node its signed distance (per-node frames); a non-obstacle is an InputError."""
    from fenics_coulomb import Plane

    comm = MPI.COMM_WORLD
    tilted = Plane(normal=(0.01, 0.0, 1.0))
    with user_problem(comm, cells=(4, 2, 2)) as default, \
            user_problem(comm, cells=(4, 2, 2), obstacles=Plane(point=(0.0, 0.0, -0.01))) as lowered, \
            user_problem(comm, cells=(4, 2, 2), obstacles=[tilted]) as tilted_problem:
        gap = default.model.contact.gap
        assert gap.size == 0 or np.allclose(lowered.model.contact.gap, gap + 0.01, rtol=0, atol=1e-15)
        x = tilted_problem.model.contact.coordinates
        nu = np.array([0.01, 0.0, 1.0]) / np.linalg.norm([0.01, 0.0, 1.0])
        assert np.allclose(tilted_problem.model.contact.gap, x @ nu, rtol=0, atol=1e-15)
        assert np.allclose(tilted_problem.model.contact.normals, nu, rtol=0, atol=1e-15)
    with pytest.raises(InputError, match="obstacles"):
        user_problem(comm, cells=(4, 2, 2), obstacles=["plane"])
    # the API took two obstacles of one name, and the report kept one of them (the scene refused it)
    twins = [Plane(point=[0, 0, -0.01], normal=[0, 0, 1], name="x"), Plane(point=[0, 0, 2], normal=[0, 0, -1],
                                                                            name="x")]
    with pytest.raises(InputError, match="obstacles 1 and 2 are both called 'x'"):
        user_problem(comm, cells=(4, 2, 2), obstacles=twins)
