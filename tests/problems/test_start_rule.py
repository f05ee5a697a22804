"""The start rule ``SolverSettings.start = "auto"`` (:meth:`ContactProblem.start_rule`): the paper's start where the
loads drive the body onto its obstacles, the undeformed body where an obstacle overlaps it; given starts kept.
1 and 2 ranks."""

from __future__ import annotations

import dataclasses

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

from fenics_coulomb import InputError, Sphere
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.settings import START_RULES, SolverSettings


def contact_share(problem) -> float:
    """‖ŷ_c(ũ = 0)‖ / ‖ŷ(ũ = 0)‖: the contact rows' part of the undeformed body's residual."""
    zero = problem.solver.undeformed()
    return problem.solver.contact_norm(zero.e) / zero.residual


def solve(scene: Scene) -> tuple[str, int, int, np.ndarray]:
    """Solve ``scene`` from its own start; the start taken, Newton and Krylov iterations, the contact force."""
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        _, result = problem.solve()
        assert result.converged
        return problem.last_start, result.iterations, result.krylov_iterations, np.array(result.contact_force)


def indenter(scene: Scene) -> Scene:
    """A sphere of radius 10 under the cuboid, touching its bottom at δ = 0, pushed 0.01 into it; no load."""
    sphere = Sphere(center=[1.0, 0.5, -10.0], radius=10.0, displacement=[0.0, 0.0, 0.01], name="indenter")
    return dataclasses.replace(scene.override(load_scale=0.0), obstacles=[sphere])


def test_loaded_cuboid_over_its_plane_starts_from_the_papers_start():
    """d3/L2 at ν = 0.499: the undeformed body's residual lies in the free rows (the loads), so "auto" takes the
    paper's start (every contact node on the plane), which needs fewer Newton steps than the undeformed body
    (from which the first Newton direction, the free elastic response, runs through the plane)."""
    scene = Scene().override(lev=3, poisson=0.499)
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        assert problem.settings.start == "auto"
        assert contact_share(problem) < 0.1
        assert problem.start_rule() == "zero"
    auto = solve(scene)
    undeformed = solve(scene.override(start="undeformed"))
    assert auto[0] == "zero" and undeformed[0] == "undeformed"
    assert auto[1] < undeformed[1] and auto[2] < undeformed[2], (auto[:3], undeformed[:3])
    # the same solution from either start (the stopping rule does not depend on it)
    assert np.linalg.norm(auto[3] - undeformed[3]) <= 1e-5 * np.linalg.norm(auto[3])


def test_sphere_indenting_a_body_at_rest_starts_undeformed():
    """A sphere pushed into the unloaded cuboid: ŷ(ũ = 0) lies in the contact rows (the overlap), so "auto" takes
    the undeformed body, which needs fewer Newton steps than the paper's start (that puts every bottom node onto
    the sphere, up to the largest gap away)."""
    scene = indenter(Scene().override(lev=2))
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        assert contact_share(problem) == pytest.approx(1.0)
        assert problem.start_rule() == "undeformed"
    auto = solve(scene)
    paper = solve(scene.override(start="zero"))
    assert auto[0] == "undeformed" and paper[0] == "zero"
    assert auto[1] < paper[1], (auto[:3], paper[:3])
    assert np.linalg.norm(auto[3] - paper[3]) <= 1e-5 * np.linalg.norm(auto[3])


def test_no_load_and_no_overlap_starts_at_the_solution():
    """Without loads and overlaps ũ = 0 is the solution: "auto" starts there and stops at once."""
    scene = Scene().override(lev=1, load_scale=0.0)
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        uh, result = problem.solve()
        assert problem.last_start == "undeformed" and result.converged and result.iterations == 0
        assert np.all(uh.x.array == 0.0)


@pytest.mark.parametrize("start", ["zero", "undeformed"])
def test_a_named_start_is_kept(start):
    """An explicit start is used whatever the rule would pick; a given u0 and a load path's previous step come
    before any rule."""
    scene = indenter(Scene().override(lev=1, start=start))
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        assert problem.settings.start == start and problem.start_rule() == start
        start_vector = problem.initial_displacement()
        shift = problem.model.shift.getArray(readonly=True)
        free = np.setdiff1d(np.arange(shift.size), problem.model.dirichlet_rows)
        expected = -shift[free] if start == "zero" else np.zeros(free.size)
        assert np.array_equal(start_vector[free], expected) and problem.last_start == start
        problem.initial_displacement(dolfinx.fem.Function(problem.V))
        assert problem.last_start == "given"
        problem.solve()
        problem.initial_displacement()
        assert problem.last_start == "previous"


def test_start_values_are_checked():
    assert START_RULES == ("auto", "zero", "undeformed") and SolverSettings().start == "auto"
    with pytest.raises(InputError, match="start 'paper': choose one of"):
        SolverSettings(start="paper").validate()
    with pytest.raises(InputError, match="start 'paper': 'auto', 'zero', 'undeformed' or a solution.xdmf"):
        Scene().override(start="paper")
