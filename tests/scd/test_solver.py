"""The SCD semismooth* Newton solver on solved scenes: physics, variants, ranks, an independent solver."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import numpy as np
import pytest
import ufl
from conftest import gather_by_coordinates, make_problem, read_solution
from reference import tresca_fixed_point

from fenics_coulomb import ContactProblem
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.scd.forcing import forcing_term, terminal_forcing
from fenics_coulomb.scd.resolvent import SLIP, STICK
from fenics_coulomb.settings import SolverSettings

TIGHT = dict(rtol=1e-12)


def solve(problem_factory, *case, start="zero", **settings):
    """Build a case with the given settings (rtol 1e-12 unless given) and solve it; return (model, result)."""
    problem = problem_factory(*case, start=start, **{**TIGHT, **settings})
    _, result = problem.solve(None if start == "zero" else zero_start(problem))
    return problem.model, result


def zero_start(problem):
    """ũ⁽⁰⁾ = 0 (the undeformed body) as a Function."""
    import dolfinx.fem

    return dolfinx.fem.Function(problem.V)


PHYSICS_TOL = {
    "equilibrium": 1e-9, "penetration": 1e-9, "negative_pressure": 1e-9, "complementarity": 1e-9,
    "cone": 1e-9, "slip_direction": 1e-6, "reaction_balance": 1e-9,
}


@pytest.mark.parametrize("variant", ["4a", "4b"])
@pytest.mark.parametrize("load", ["L1", "L2"])
@pytest.mark.parametrize("gap", ["d1", "d2", "d3"])
def test_physics(gap, load, variant, problem_factory):
    """Equilibrium, Signorini, Coulomb and global balance hold at the computed solution."""
    model, result = solve(problem_factory, 2, gap, load, variant=variant)
    assert result.converged
    checks = physics_residuals(model, result.displacement)
    for key, tol in PHYSICS_TOL.items():
        assert checks[key] < tol, (key, checks[key])
    counts = result.state_counts(MPI.COMM_WORLD)
    assert counts["slip"] > 0 and counts["stick"] > 0 and counts["open"] > 0
    assert sum(counts.values()) == model.p
    # the reported forces agree with A ũ − l̃ and obey the cone; sliding forces oppose the slip
    lam = result.normal_force
    assert np.all(lam >= 0.0)
    t = result.tangential_force
    assert np.all(np.hypot(t[:, 0], t[:, 1]) <= model.friction * lam * (1 + 1e-12) + 1e-15)
    slip = result.states == SLIP
    s = result.displacement[model.contact.local_dofs[slip, :2]]
    cos = np.einsum("ij,ij->i", t[slip], s) / (np.linalg.norm(t[slip], axis=1) * np.linalg.norm(s, axis=1))
    assert np.all(cos < -1 + 1e-6)
    stick = result.states == STICK
    assert np.allclose(result.displacement[model.contact.local_dofs[stick, 2]], -model.contact.gap[stick])


def test_variants_agree(problem_factory):
    """Newton steps 4a (S*Q) and 4b (SQ) reach the same solution (1e-8 relative)."""
    ua = solve(problem_factory, 3, "d3", "L2", variant="4a")[1].displacement
    ub = solve(problem_factory, 3, "d3", "L2", variant="4b")[1].displacement
    comm = MPI.COMM_WORLD
    diff = np.sqrt(comm.allreduce(np.sum((ua - ub) ** 2)))
    norm = np.sqrt(comm.allreduce(np.sum(ua**2)))
    assert diff <= 1e-8 * norm


def test_exact_newton_iterates_coincide(problem_factory):
    """With exact linear solves, 4a and 4b give the same iterates (x̂ − C_Lᵀŷ for L and L*), hence the same
    residual history; the final iterations converge superlinearly."""
    ra = solve(problem_factory, 2, "d3", "L2", variant="4a", pc="lu", tol=1e-13)[1]
    rb = solve(problem_factory, 2, "d3", "L2", variant="4b", pc="lu", tol=1e-13)[1]
    assert ra.iterations == rb.iterations
    ha, hb = np.array(ra.residual_history), np.array(rb.residual_history)
    assert np.allclose(ha[ha > 1e-9 * ha[0]], hb[ha > 1e-9 * ha[0]], rtol=1e-6)
    rates = ha[-3:] / ha[-4:-1]
    assert rates[-1] < 1e-2 and rates[-1] < rates[0]


@pytest.mark.compares_ranks
def test_serial_equals_parallel(problem_factory):
    """The solution on COMM_WORLD equals the one computed on one rank (1e-8 relative).

    Under ``mpirun -n 2`` every rank also solves on COMM_SELF; in a serial session the parallel run is a
    subprocess of the command line under ``mpirun -n 2``.
    """
    comm = MPI.COMM_WORLD
    lev, gap, load = 2, "d3", "L2"
    model, result = solve(problem_factory, lev, gap, load)
    x, u = gather_by_coordinates(model.V, result.displacement)
    if comm.size > 1:
        with make_problem(lev, gap, load, comm=MPI.COMM_SELF, **TIGHT) as single:
            _, ref = single.solve()
            xs, us = gather_by_coordinates(single.V, ref.displacement)
    else:
        mpirun = shutil.which("mpirun")
        assert mpirun is not None
        import tempfile

        with tempfile.TemporaryDirectory() as out:
            cmd = [mpirun, "-n", "2", sys.executable, "-m", "fenics_coulomb", "--lev", str(lev), "--gap", gap,
                   "--load", load, "--rtol", "1e-12", "--out", out, "--quiet"]
            env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX", "PRTE_"))}
            subprocess.run(cmd, check=True, env=env, capture_output=True, timeout=300)
            summary = json.loads(open(f"{out}/summary.json").read())
            assert summary["converged"] and summary["ranks"] == 2
            xs, us = read_solution(Path(out))
    assert np.allclose(x, xs, atol=1e-12)
    assert np.linalg.norm(u - us) <= 1e-8 * np.linalg.norm(u)


# on COMM_SELF with a dense reference: on 2 ranks each rank repeated the same solve and reference
@pytest.mark.serial
def test_matches_independent_solver():
    """A tiny scene (lev 0, 108 unknowns) against the Tresca fixed-point/FISTA solver on dense matrices."""
    with make_problem(0, "d3", "L2", comm=MPI.COMM_SELF, pc="lu", tol=1e-13, **TIGHT) as problem:
        _, result = problem.solve()
        model = problem.model
        assert result.converged
        A = model.A.convert("dense").getDenseArray().copy()
        load = model.load.getArray(readonly=True).copy()
        ref = tresca_fixed_point(A, load, model.contact.local_dofs, model.contact.gap, model.friction)
        assert np.linalg.norm(result.displacement - ref) <= 1e-7 * np.linalg.norm(ref)


@pytest.mark.parametrize("case", ["far_obstacle", "pulled_away"])
def test_no_contact_is_one_linear_solve(case, problem_factory):
    """If the body cannot reach the obstacle, one Newton step from ũ = 0 solves A ũ = l̃ exactly."""
    comm = MPI.COMM_WORLD
    if case == "far_obstacle":  # bends the cantilever by about 0.03 < 0.3
        case_args = dict(gap="0.3 + 0*x1", load="L1", load_scale=0.1)
    else:  # the top is pulled up
        case_args = dict(gap="d3", load="L2", load_scale=-1.0)
    model, result = solve(problem_factory, 2, start="undeformed", pc="lu", tol=1e-14, **case_args)
    assert result.converged and result.iterations == 1
    assert result.state_counts(comm) == {"open": model.p, "stick": 0, "slip": 0}
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix("test_linear_")
    ksp.setOperators(model.A)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    if comm.size > 1:
        ksp.getPC().setFactorSolverType("mumps")
    x = model.A.createVecRight()
    ksp.solve(model.load, x)
    ref = x.getArray(readonly=True)
    diff = np.sqrt(comm.allreduce(np.sum((result.displacement - ref) ** 2)))
    assert diff <= 1e-10 * x.norm()
    ksp.destroy()
    x.destroy()


def test_zero_load_is_immediate(problem_factory):
    """Zero load from ũ = 0: the residual is zero at the start (ũ = 0 is the solution)."""
    _, result = solve(problem_factory, 1, "d3", "L2", load_scale=0.0, start="undeformed")
    assert result.converged and result.iterations == 0
    assert np.all(result.displacement == 0.0)


# lev 6 (1.5 s a case) on one rank only: the 2-rank pass runs every case at levels 2–5
@pytest.mark.parametrize("lev", [2, 3, 4, 5, pytest.param(6, marks=pytest.mark.serial)])
@pytest.mark.parametrize("load", ["L1", "L2"])
@pytest.mark.parametrize("gap", ["d1", "d2", "d3"])
def test_section7_cases_converge(gap, load, lev, problem_factory):
    """All six cases converge from the paper's u⁽⁰⁾ = 0 with the default settings (tol 0.1, ILU)."""
    problem = problem_factory(lev, gap, load)
    model = problem.model
    _, result = problem.solve()
    assert result.converged
    rtol = SolverSettings().rtol
    assert result.residual_history[-1] <= rtol * result.residual_history[0]
    checks = physics_residuals(model, result.displacement)
    # the residual reduction rtol bounds the physics residuals up to the ratio ‖ŷ⁽⁰⁾‖/‖l̃‖ (< 1e3 here)
    assert checks["penetration"] < 1e3 * rtol and checks["cone"] < 1e3 * rtol and checks["equilibrium"] < 1e3 * rtol


def test_gamma_does_not_change_the_solution(problem_factory):
    """γ only steers the iteration: the paper's γ ≈ λ_max(A) and the default 0.01·λ_max give one solution."""
    r1 = solve(problem_factory, 3, "d2", "L1", gamma_scale=1.0)[1]
    r2 = solve(problem_factory, 3, "d2", "L1", gamma_scale=0.01)[1]
    assert r1.converged and r2.converged
    assert np.isclose(r1.gamma, 100 * r2.gamma)
    comm = MPI.COMM_WORLD
    diff = np.sqrt(comm.allreduce(np.sum((r1.displacement - r2.displacement) ** 2)))
    assert diff <= 1e-8 * np.sqrt(comm.allreduce(np.sum(r1.displacement**2)))
    assert r1.state_counts(comm) == r2.state_counts(comm)


@pytest.mark.parametrize("variant", ["4a", "4b"])
@pytest.mark.parametrize("pc", ["gamg", "hypre", "lu", "jacobi"])
def test_preconditioners_reach_the_same_solution(pc, variant, problem_factory):
    """Every selectable preconditioner solves the Newton systems to the same contact solution."""
    if pc == "hypre" and variant == "4b":
        with pytest.raises(Exception, match="hypre"):
            SolverSettings(pc=pc, variant=variant).validate()
        return
    ref = solve(problem_factory, 2, "d3", "L1", variant="4a")[1]
    result = solve(problem_factory, 2, "d3", "L1", pc=pc, variant=variant)[1]
    assert result.converged
    comm = MPI.COMM_WORLD
    diff = np.sqrt(comm.allreduce(np.sum((result.displacement - ref.displacement) ** 2)))
    assert diff <= 1e-8 * np.sqrt(comm.allreduce(np.sum(ref.displacement**2)))


@pytest.mark.parametrize("threshold, expected", [(10**9, "ilu"), (0, "gamg")])
def test_auto_preconditioner_follows_the_problem_size(threshold, expected, problem_factory, monkeypatch):
    """pc = auto takes ILU below AUTO_GAMG_UNKNOWNS unknowns and GAMG from there on, and says so."""
    import fenics_coulomb.scd.preconditioner as preconditioner

    monkeypatch.setattr(preconditioner, "AUTO_GAMG_UNKNOWNS", threshold)
    solver = problem_factory(2, "d3", "L1", pc="auto").solver
    assert solver.pc == expected
    parallel = MPI.COMM_WORLD.size > 1
    assert solver.ksp.getPC().getType() == {"ilu": "bjacobi" if parallel else "ilu", "gamg": "gamg"}[expected]


def test_gamg_is_set_up_once_on_the_stiffness_matrix(problem_factory):
    """gamg preconditions every Newton matrix with one hierarchy built on A (set up once: nothing is set up again),
    with one Chebyshev sweep per level unless the user asks otherwise, and leaves no option of its own behind."""
    opts = PETSc.Options()
    with make_problem(3, "d3", "L2", pc="gamg", rtol=1e-10) as problem:
        solver = problem.solver
        _, P = solver.ksp.getOperators()
        assert P.handle == problem.A.handle
        PETSc.Log.begin()
        events = {name: PETSc.Log.Event(name) for name in ("PCSetUp", "PCSetUp_GAMG+")}
        before = {name: event.getPerfInfo()["count"] for name, event in events.items()}
        _, result = problem.solve()
        assert result.converged and result.iterations >= 3
        counts = {name: event.getPerfInfo()["count"] - before[name] for name, event in events.items()}
        assert counts["PCSetUp_GAMG+"] == 1
        assert counts["PCSetUp"] == 1
        assert P.getNearNullSpace().handle != 0
        assert solver.ksp.getPC().getMGSmoother(1).getTolerances()[3] == 1
        assert not opts.hasName("coulomb_mg_levels_ksp_max_it")
    opts["coulomb_mg_levels_ksp_max_it"] = 3
    try:
        with make_problem(3, "d3", "L2", pc="gamg") as problem:
            problem.solve()
            assert problem.solver.ksp.getPC().getMGSmoother(1).getTolerances()[3] == 3
    finally:
        del opts["coulomb_mg_levels_ksp_max_it"]


def finest_prolongator_row_lengths(pc: PETSc.PC) -> int:
    """The largest number of entries in an owned row of GAMG's finest prolongator (collective)."""
    P = pc.getMGInterpolation(pc.getMGLevels() - 1)
    indptr, _, _ = P.getValuesCSR()
    return MPI.COMM_WORLD.allreduce(int(np.diff(indptr).max(initial=0)), op=MPI.MAX)


def pressed_block(cell: dolfinx.mesh.CellType) -> ContactProblem:
    """A block 1 × 1 × 0.5 of ``cell``s, 8 × 8 × 4, 0.01 above the plane x3 = 0, its top pushed down by 0.03."""
    comm = MPI.COMM_WORLD
    msh = dolfinx.mesh.create_box(comm, [np.array([0.0, 0.0, 0.01]), np.array([1.0, 1.0, 0.51])], [8, 8, 4], cell)
    msh.topology.create_connectivity(2, 3)
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.01))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 7, np.int32))
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.51))
    bc = dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.03]), dolfinx.fem.locate_dofs_topological(V, 2, top), V)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    mu, lmbda = 70.0 / 2.6, 70.0 * 0.3 / (1.3 * 0.4)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    a = (2.0 * mu * ufl.inner(eps(u), eps(v)) + lmbda * ufl.div(u) * ufl.div(v)) * ufl.dx
    return ContactProblem(a, None, bcs=[bc], contact=(tags, [7]), friction=0.3, settings={"pc": "gamg"},
                          petsc_options_prefix="coulomb_")


@pytest.mark.parametrize("cell, unsmoothed", [(dolfinx.mesh.CellType.hexahedron, True),
                                              (dolfinx.mesh.CellType.tetrahedron, False)])
def test_gamg_aggregation_is_unsmoothed_on_hexahedra_unless_the_user_asks(cell, unsmoothed):
    """On hexahedra the default hierarchy uses unsmoothed aggregation: every fine row of a prolongator lies in one
    aggregate and holds at most the six rigid-body modes' coefficients; tetrahedra keep PETSc's smoothed
    aggregation, whose rows spread over neighbouring aggregates (docs/gamg-sweeps, docs/pc-auto). The user's
    -coulomb_pc_gamg_agg_nsmooths wins either way. No option of the solver's own is left behind."""
    opts = PETSc.Options()
    with pressed_block(cell) as problem:
        _, result = problem.solve()
        assert result.converged and result.counts["stick"] + result.counts["slip"] > 0
        pc = problem.solver.ksp.getPC()
        assert pc.getMGLevels() >= 2
        assert (finest_prolongator_row_lengths(pc) <= 6) == unsmoothed
    assert not opts.hasName("coulomb_pc_gamg_agg_nsmooths")
    opts["coulomb_pc_gamg_agg_nsmooths"] = 0 if not unsmoothed else 1
    try:
        with pressed_block(cell) as problem:
            problem.solve()
            assert (finest_prolongator_row_lengths(problem.solver.ksp.getPC()) <= 6) != unsmoothed
        assert opts.getInt("coulomb_pc_gamg_agg_nsmooths") == (0 if not unsmoothed else 1)
    finally:
        del opts["coulomb_pc_gamg_agg_nsmooths"]


@pytest.mark.serial
@pytest.mark.parametrize(
    "tol, history, eta_prev, target, expected",
    [
        (0.1, [1.0], 0.1, 1e-12, 0.1),  # first step: tol
        (0.1, [1.0, 0.9], 0.1, 1e-12, 0.1),  # localizing (ratio near 1): capped by tol
        (0.1, [1.0, 0.1], 0.1, 1e-12, 0.9 * 0.01),  # fast decrease: 0.9·ratio²
        (0.1, [1.0, 1e-3], 0.1, 1e-12, 0.9 * 1e-6),
        (0.1, [1e-8, 1e-11], 1e-3, 1e-12, 0.5 * 1e-12 / 1e-11),  # last step: no over-solving
        (0.1, [1e-8, 1e-13], 1e-3, 1e-12, 0.1),  # already below the target: guard > tol, capped
        (0.9, [1.0, 0.1], 0.5, 1e-12, 0.9 * 0.25),  # safeguard 0.9·η₋² > 0.1 keeps η from dropping
        (0.9, [1.0, 0.1], 0.3, 1e-12, 0.9 * 0.01),  # safeguard 0.081 <= 0.1: not applied
    ],
)
def test_forcing_term(tol, history, eta_prev, target, expected):
    """The safeguarded Eisenstat–Walker term of Kelley (6.18)–(6.20), case by case."""
    assert forcing_term(tol, history, eta_prev, target) == pytest.approx(expected, rel=1e-12)


@pytest.mark.serial
@pytest.mark.parametrize(
    "residual, target, expected",
    [
        (1e-6, 1e-8, 0.5 * 1e-8 / 1e-6),  # one step to η = 0.5·target/‖ŷ‖ reaches the target: tightened
        (4e-7, 1e-8, 0.5 * 1e-8 / 4e-7),
        (1e-5, 1e-8, 0.1),  # η = 5e-4 below TERMINAL_MIN: more than one step away, tol
        (1e-8, 5e-8, 0.1),  # η = 2.5 >= tol: the fixed step reaches the target anyway
        (0.0, 1e-8, 0.1),  # no residual left: tol
    ],
)
def test_terminal_forcing(residual, target, expected):
    """The fixed rule tightened in the step that can reach the target (forcing.terminal_forcing), case by case at
    tol = 0.1."""
    assert terminal_forcing(0.1, residual, target) == pytest.approx(expected, rel=1e-12)


def test_adaptive_forcing_reaches_the_linear_solves(problem_factory):
    """With adaptive_tol every GMRES solve gets the term of forcing_term (tightening below tol in the tail)
    and meets it; with the fixed rule every solve gets tol. The reached residual is recomputed here from the
    Newton matrix, the right-hand side and the solution, independently of the KSP's own estimate."""
    for adaptive in (False, True):
        problem = problem_factory(3, "d3", "L2", rtol=1e-12, adaptive_tol=adaptive)
        solver = problem.solver
        seen: list[tuple[float, float]] = []

        def after_solve(ksp, b, x, seen=seen):
            r = b.duplicate()
            ksp.getOperators()[0].mult(x, r)
            r.aypx(-1.0, b)
            seen.append((ksp.getTolerances()[0], r.norm() / b.norm()))
            r.destroy()

        solver.ksp.setPostSolve(after_solve)
        _, result = problem.solve()
        assert result.converged and len(seen) == result.iterations == len(result.records)
        etas = np.array([eta for eta, _ in seen])
        reached = np.array([rel for _, rel in seen])
        assert np.allclose(etas, [rec.forcing for rec in result.records], rtol=1e-14)
        assert np.allclose(reached, [rec.linear_residual for rec in result.records], rtol=1e-6, atol=1e-14)
        assert np.all(reached <= etas * (1 + 1e-6))
        history = result.residual_history
        if adaptive:
            assert etas[0] == 0.1 and np.all(etas <= 0.1) and etas.min() < 1e-3
            target = result.target
            for k in range(1, result.iterations):
                assert etas[k] == pytest.approx(forcing_term(0.1, history[: k + 1], etas[k - 1], target), rel=1e-14)
        else:  # the fixed tol, tightened only in the step that can reach the target (forcing.terminal_forcing)
            assert np.array_equal(etas, [terminal_forcing(0.1, y, result.target) for y in history[:-1]])
            assert etas[0] == 0.1 and np.sum(etas < 0.1) <= 2


def test_the_fixed_rule_tightens_only_once_the_states_have_settled(problem_factory, monkeypatch):
    """The fixed rule's terminal tightening (forcing.terminal_forcing) is asked only when every node's contact state
    after the last step is that of the iterate before (the start counts; the first step as ever): while the states
    move, a step solved to η does not cut ‖ŷ‖ by η. The states are recorded where the solver computes them. Two
    cuboid cases at loose targets, where the tightening would have fired in steps whose states still moved (which
    steps those are depends on the iterates' round-off, so the counts are over both cases)."""
    import fenics_coulomb.scd.newton as newton

    seen: list[np.ndarray] = []
    original = newton.contact_states

    def recording(sets, friction):
        states = original(sets, friction)
        seen.append(states.copy())
        return states

    monkeypatch.setattr(newton, "contact_states", recording)
    comm = MPI.COMM_WORLD
    withheld = applied = 0
    for *level, rtol in [(2, "d3", "L2", 1e-4), (4, "d2", "L2", 1e-5)]:
        seen.clear()
        problem = problem_factory(*level, rtol=rtol)
        _, result = problem.solve()
        assert result.converged
        history, target, etas = result.residual_history, result.target, [rec.forcing for rec in result.records]
        states = seen[: result.iterations + 1]  # the start's, then after each step
        for k, eta in enumerate(etas):
            settled = k == 0 or comm.allreduce(bool(np.array_equal(states[k], states[k - 1])), op=MPI.LAND)
            tightened = terminal_forcing(0.1, history[k], target)
            assert eta == (tightened if settled else 0.1), (level, k, eta, settled, tightened)
            withheld += (not settled) and tightened < 0.1  # the earlier rule tightened here
            applied += settled and tightened < 0.1
    assert withheld >= 1 and applied >= 1  # both branches of the rule were taken


def test_adaptive_tolerance_reaches_the_same_solution(problem_factory):
    """Eisenstat–Walker forcing terms change the path, not the solution, and cut Newton iterations."""
    _, fixed = solve(problem_factory, 4, "d3", "L2", adaptive_tol=False)
    model, adaptive = solve(problem_factory, 4, "d3", "L2", adaptive_tol=True)
    assert adaptive.converged and adaptive.iterations <= fixed.iterations
    comm = MPI.COMM_WORLD
    diff = np.sqrt(comm.allreduce(np.sum((adaptive.displacement - fixed.displacement) ** 2)))
    assert diff <= 1e-8 * np.sqrt(comm.allreduce(np.sum(fixed.displacement**2)))
    checks = physics_residuals(model, adaptive.displacement)
    for name, tol in PHYSICS_TOL.items():
        assert checks[name] <= tol, (name, checks[name])
