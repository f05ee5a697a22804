"""Nested iteration of the command line: the box-grid interpolation between cuboid levels (oracle: DOLFINx's
non-matching interpolation), the coarse levels it solves, its default, and a coarse level that fails."""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import numpy as np
import pytest
from conftest import global_norm

from fenics_coulomb.scenes.nested import (
    NESTED_AUTO_MIN_LEV,
    coarse_level_options,
    nested_levels,
    resolve_nested,
    solve_coarse_levels,
)
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.errors import SolverError
from fenics_coulomb.scenes.nested import interpolate_cuboid
from fenics_coulomb.start_rule import interpolate_displacement
from fenics_coulomb.scenes.cuboid import box_coordinates, create_cuboid


def affine_gap(x1, x2):
    """An affine gap profile: the cuboid is then exactly the trilinear image of its box grid."""
    return 0.01 + 0.004 * x1 - 0.002 * x2


def coarse_field(V: dolfinx.fem.FunctionSpace, seed: int = 7) -> dolfinx.fem.Function:
    """A rough Q1 field: random nodal values drawn from the node's global index (the same on any partition)."""
    u = dolfinx.fem.Function(V)
    owned = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:owned]
    # a deterministic pseudo-random function of the position (rank-independent)
    u.x.array[: 3 * owned] = np.sin(seed * (x @ np.array([[3.1, 1.7, 0.3], [2.3, 5.9, 1.1], [0.7, 4.3, 6.7]]))
                                    ** 2).ravel()
    u.x.scatter_forward()
    return u


@pytest.mark.parametrize(("coarse", "fine"), [(2, 4), (3, 5), (2, 3)])
def test_box_interpolation_equals_dolfinx_on_an_affine_cuboid(coarse, fine):
    """With an affine gap the box-grid interpolation is DOLFINx's physical-point interpolation (1e-12), for
    nested (h/2) and non-nested (lev 2 → 3) grids."""
    comm = MPI.COMM_WORLD
    Vc = dolfinx.fem.functionspace(create_cuboid(comm, coarse, affine_gap).mesh, ("Lagrange", 1, (3,)))
    Vf = dolfinx.fem.functionspace(create_cuboid(comm, fine, affine_gap).mesh, ("Lagrange", 1, (3,)))
    uc = coarse_field(Vc)
    fast = interpolate_cuboid(uc, coarse, Vf, affine_gap)
    assert fast is not None
    reference = interpolate_displacement(uc, Vf)
    owned = 3 * Vf.dofmap.index_map.size_local
    assert global_norm(fast.x.array[:owned] - reference) <= 1e-12 * global_norm(reference)
    # ghosts are up to date
    ghosts = fast.x.array.copy()
    fast.x.scatter_forward()
    assert np.array_equal(ghosts, fast.x.array)


def test_box_interpolation_on_the_paper_cuboid_is_close_to_dolfinx():
    """With the paper's wavy gap d3 the cells' trilinear geometry departs from the box map by O(h²) of the gap's
    curvature (h = 1/6: (2π)²·0.005·h²/8 ≈ 7e-4 in x3): on a smooth field the two interpolations differ by that
    little. The fine bottom nodes lie up to that far outside the coarse mesh; DOLFINx's point location took
    no cell for them with a padding of 1e-6 and left 0 (max difference 2.8): interpolate_displacement's padding
    is now a tenth of the coarse cells."""
    comm = MPI.COMM_WORLD
    Vc = dolfinx.fem.functionspace(create_cuboid(comm, 3, "d3").mesh, ("Lagrange", 1, (3,)))
    Vf = dolfinx.fem.functionspace(create_cuboid(comm, 5, "d3").mesh, ("Lagrange", 1, (3,)))
    uc = dolfinx.fem.Function(Vc)
    uc.interpolate(lambda x: np.vstack([np.sin(2 * x[0]) * x[2], x[1] * x[2] ** 2, np.cos(3 * x[2]) + x[0]]))
    fast = interpolate_cuboid(uc, 3, Vf, "d3")
    assert fast is not None
    owned = Vf.dofmap.index_map.size_local
    u = fast.x.array[: 3 * owned].reshape(-1, 3)
    reference = interpolate_displacement(uc, Vf).reshape(-1, 3)
    x = Vf.tabulate_dof_coordinates()[:owned]
    gap = comm.allreduce(float(np.abs(u - reference).max(initial=0.0)), op=MPI.MAX)
    assert 0.0 < gap <= 5e-3, gap
    # the exact field at the nodes: the box interpolant is within the Q1 interpolation error everywhere
    exact = np.column_stack([np.sin(2 * x[:, 0]) * x[:, 2], x[:, 1] * x[:, 2] ** 2, np.cos(3 * x[:, 2]) + x[:, 0]])
    error = comm.allreduce(float(np.abs(u - exact).max(initial=0.0)), op=MPI.MAX)
    assert error <= 0.05, error


def test_box_coordinates_invert_the_cuboid_map():
    """box_coordinates maps the cuboid's vertices back onto the box grid."""
    body = create_cuboid(MPI.COMM_WORLD, 3, "d3")
    box = box_coordinates(body.mesh.geometry.x, "d3")
    h = np.array([2.0 / 12, 1.0 / 6, 1.0 / 6])  # lev 3: 12 × 6 × 6
    assert np.allclose(box / h, np.rint(box / h), rtol=0, atol=1e-9)
    assert box[:, 2].min() >= -1e-15 and box[:, 2].max() <= 1.0 + 1e-15


def test_box_interpolation_refuses_another_grid():
    """A coarse mesh that is not the named level's grid gives None on every rank (the caller then interpolates
    generally)."""
    comm = MPI.COMM_WORLD
    Vc = dolfinx.fem.functionspace(create_cuboid(comm, 3, "d3").mesh, ("Lagrange", 1, (3,)))
    Vf = dolfinx.fem.functionspace(create_cuboid(comm, 4, "d3").mesh, ("Lagrange", 1, (3,)))
    assert interpolate_cuboid(coarse_field(Vc), 2, Vf, "d3") is None


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_nested_levels_and_default():
    """--nested K solves lev − 2K, ..., lev − 2; by default one coarser level from lev NESTED_AUTO_MIN_LEV on,
    only for the cuboid from the paper's start; a given value wins."""
    assert nested_levels(10, 1) == [8]
    assert nested_levels(10, 2) == [6, 8]
    assert nested_levels(5, 0) == []
    scene = Scene()
    assert resolve_nested(None, scene.override(lev=NESTED_AUTO_MIN_LEV)) == 1
    assert resolve_nested(None, scene.override(lev=NESTED_AUTO_MIN_LEV + 1)) == 1
    assert resolve_nested(None, scene.override(lev=NESTED_AUTO_MIN_LEV - 1)) == 0
    assert resolve_nested(None, scene.override(lev=NESTED_AUTO_MIN_LEV, start="undeformed")) == 0
    assert resolve_nested(0, scene.override(lev=NESTED_AUTO_MIN_LEV)) == 0
    assert resolve_nested(2, scene.override(lev=4)) == 2


def test_coarse_levels_solve_and_a_failure_falls_back(monkeypatch):
    """The coarse level is solved to NESTED_COARSE_RTOL on its own mesh; a coarse level that does not converge
    leaves the fine level to start as without nesting (None), instead of ending the run."""
    comm = MPI.COMM_WORLD
    scene = Scene().override(lev=4, gap="d3", load="L2")
    start = solve_coarse_levels(scene, 1, comm)
    assert start is not None and start.lev == 2 and len(start.results) == 1 and start.results[0].converged
    assert global_norm(start.u.x.array[: 3 * start.u.function_space.dofmap.index_map.size_local]) > 0.0

    import fenics_coulomb.scenes.nested

    def failing(*args, **kwargs):
        raise SolverError("no convergence (test)", "max_iterations")

    monkeypatch.setattr(fenics_coulomb.scenes.nested, "solve_nested", failing)
    assert solve_coarse_levels(scene, 1, comm) is None


def test_the_users_options_reach_the_coarse_levels():
    """-coulomb_* options (e.g. -coulomb_pc_gamg_agg_nsmooths) apply to the coarse levels as to the
    fine one, -coulomb_nested<lev>_* ones win for their level, and the database is left as the user gave it."""
    comm = MPI.COMM_WORLD
    scene = Scene().override(lev=4, gap="d3", load="L2", pc="ilu")
    opts = PETSc.Options()
    before = opts.getAll()

    def coarse_krylov() -> int:
        start = solve_coarse_levels(scene, 1, comm)
        assert start is not None and start.results[0].converged
        return start.results[0].krylov_iterations

    plain = coarse_krylov()
    opts["coulomb_pc_type"] = "jacobi"
    try:
        assert coarse_level_options(2) == {"pc_type": "jacobi"}
        jacobi = coarse_krylov()
        assert jacobi > plain
        opts["coulomb_nested2_pc_type"] = "bjacobi" if comm.size > 1 else "ilu"
        try:
            assert coarse_level_options(2) == {}
            assert coarse_krylov() == plain
        finally:
            del opts["coulomb_nested2_pc_type"]
    finally:
        del opts["coulomb_pc_type"]
    assert opts.getAll() == before
