"""The discrete model's sizes and geometry (Section 7): p and n for lev 0..8, gap, shift, load."""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb.errors import InputError
from fenics_coulomb.scenes.cuboid import GAP_PROFILES, cells_per_direction, create_cuboid, expected_sizes


@pytest.mark.parametrize("lev", range(9))
def test_sizes(lev, problem_factory):
    """p = n_x1·(n_x2+1) contact nodes and n = 3·n_x1·(n_x2+1)·(n_x3+1) unknowns (global counts)."""
    n1, n2, n3 = cells_per_direction(lev)
    assert (n1, n2, n3) == (int(np.ceil(4 * 2 ** (lev / 2) - 1e-9)), int(np.ceil(2 * 2 ** (lev / 2) - 1e-9)),
                            int(np.ceil(2 * 2 ** (lev / 2) - 1e-9)))
    model = problem_factory(lev, "d1", "L1").model
    assert model.p == n1 * (n2 + 1)
    assert model.n == 3 * n1 * (n2 + 1) * (n3 + 1)
    assert (model.p, model.n) == expected_sizes(lev)
    # every contact node is owned by exactly one rank
    comm = MPI.COMM_WORLD
    owned = np.concatenate(comm.allgather(model.contact.global_dofs[:, 0]))
    assert owned.size == np.unique(owned).size == model.p


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_known_sizes():
    """Two levels worked by hand: lev 0 is 4x2x2 cells, lev 1 is 6x3x3 (⌈5.66⌉ = 6, ⌈2.83⌉ = 3)."""
    assert cells_per_direction(0) == (4, 2, 2)
    assert cells_per_direction(1) == (6, 3, 3)
    assert expected_sizes(0) == (12, 108)
    assert expected_sizes(2) == (40, 600)


@pytest.mark.parametrize("gap", sorted(GAP_PROFILES))
def test_bottom_follows_gap(gap, problem_factory):
    """Contact nodes sit at height d(x1, x2); the shift d holds α in the normal component only."""
    model = problem_factory(2, gap, "L1").model
    c = model.contact
    d = GAP_PROFILES[gap](c.coordinates[:, 0], c.coordinates[:, 1])
    assert np.allclose(c.gap, d, rtol=0, atol=1e-14)
    assert np.all(c.coordinates[:, 0] > 0.0)  # the clamped face x1 = 0 has no contact nodes
    shift = model.shift.getArray(readonly=True)
    assert np.allclose(shift[c.local_dofs[:, 2]], d)
    mask = np.ones(shift.size, bool)
    mask[c.local_dofs[:, 2]] = False
    assert np.all(shift[mask] == 0.0)
    # uniform spacing between d and 1: top nodes at x3 = 1
    x = model.V.mesh.geometry.x
    assert np.isclose(x[:, 2].max(initial=1.0), 1.0)


def test_shifted_load(problem_factory):
    """l = l̃ + A d, so that A u − l = A ũ − l̃ for u = ũ + d (the paper prints l̃ − A d)."""
    model = problem_factory(1, "d3", "L2").model
    A = model.A
    rng = np.random.default_rng(1 + MPI.COMM_WORLD.rank)
    ut, r1 = A.createVecs()
    ut.array[:] = rng.standard_normal(ut.getLocalSize())
    ut.array[model.dirichlet_rows] = 0.0
    A.mult(ut, r1)
    r1.axpy(-1.0, model.load)  # A ũ − l̃
    u, r2 = A.createVecs()
    ut.copy(u)
    u.axpy(1.0, model.shift)
    A.mult(u, r2)
    r2.axpy(-1.0, model.rhs)  # A u − l
    assert np.allclose(r1.array, r2.array, rtol=0, atol=1e-12 * r1.norm())
    for v in (ut, r1, u, r2):
        v.destroy()


def test_total_load(problem_factory):
    """The applied resultant of L2 is P_T·|top| + P_R·|right|; on Ω(d2) the right face x1 = 2 spans
    d2(2, x2) = 0.0025 < x3 < 1, so |right| = 0.9975 and |top| = 2."""
    model = problem_factory(1, "d2", "L2").model
    assert np.allclose(model.total_load(), [-0.17 * 0.9975, -0.1 * 0.9975, -1.0 * 2.0], rtol=1e-12)


@pytest.mark.parametrize(
    "lev, gap, match", [(-1, "d1", "lev"), (1, "d9", "d9"), (1, lambda x1, x2: -0.1 + 0 * x1, "outside")]
)
def test_bad_scene(lev, gap, match):
    with pytest.raises(InputError, match=match):
        create_cuboid(MPI.COMM_WORLD, lev, gap)


def test_nearly_incompressible_bodies_get_their_defaults(mpi_tmp_path):
    """ν >= 0.48 without rtol given: rtol 1e-8 (docs/robustness); what the user gives (in the scene or as a flag)
    is kept; ν = 0.3 keeps the rtol; the start is the solver's rule either way."""
    import json

    from fenics_coulomb.cli import main
    from fenics_coulomb.scenes.scene import NEARLY_INCOMPRESSIBLE_RTOL, Scene

    soft = Scene().override(poisson=0.49).with_scene_defaults()
    assert soft.start == "auto" and soft.solver.rtol == NEARLY_INCOMPRESSIBLE_RTOL
    given = Scene().override(poisson=0.49, rtol=1e-6, start="zero").with_scene_defaults()
    assert given.start == "zero" and given.solver.rtol == 1e-6
    plain = Scene().override(poisson=0.3).with_scene_defaults()
    assert plain.start == "auto" and plain.solver.rtol == Scene().solver.rtol
    out = mpi_tmp_path / "soft"
    assert main(["--lev", "1", "--poisson", "0.49", "--out", str(out), "--quiet", "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["rtol"] == NEARLY_INCOMPRESSIBLE_RTOL and summary["scene"]["start"] == "auto"
    assert summary["settings"]["start"] == "auto"


def test_the_scene_start_is_the_solvers_start_rule():
    """A scene's start is no longer chosen by its kind: a sphere scene and the paper's cuboid both keep "auto"
    (the rule of ContactProblem.start_rule), a named rule reaches the solver's settings, a start file does not
    (it is the solve's u0)."""
    from mpi4py import MPI

    from fenics_coulomb.scenes.builder import build_problem
    from fenics_coulomb.scenes.scene import FLAGS, Scene

    ROOT = Path(__file__).resolve().parents[2]
    sphere = Scene.from_toml(ROOT / "demos" / "scenes" / "sphere_indentation.toml")
    assert sphere.start == "auto" and sphere.with_scene_defaults().start == "auto"
    assert sphere.override(start="zero").with_scene_defaults().start == "zero"
    assert sphere.with_scene_defaults().solver.rtol == sphere.solver.rtol
    assert Scene.from_toml(ROOT / "demos" / "scenes" / "d3_L2.toml").start == "zero"  # named in the file
    assert FLAGS["start"] == (None, "start")
    for start in ("auto", "zero", "undeformed"):
        with build_problem(Scene().override(lev=1, start=start), MPI.COMM_WORLD).problem as problem:
            assert problem.settings.start == start
