"""Nested iteration (full-multigrid style): solve a coarse problem, interpolate, a few Newton steps per level.

Given the same contact problem on a sequence of meshes, coarse to fine, the first is solved from the paper's
start u⁽⁰⁾ = 0 and every finer one from the previous level's solution interpolated onto its mesh
(:func:`~fenics_coulomb.start_rule.interpolate_displacement`, the same interpolation as ``--start``). The
coarse levels only provide a start, so they are usually solved to a looser reduction (their own settings);
the finest level's settings decide the accuracy of the result. The stopping target does not depend on the start
(:mod:`fenics_coulomb.scd.stopping`), so every level is asked for what a direct solve would be: the better start
saves Newton steps instead of asking for a smaller residual.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import numpy as np

from fenics_coulomb.errors import SolverError
from fenics_coulomb.io.start import start_function
from fenics_coulomb.problem import ContactProblem
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scenes.builder import build_problem, cuboid_gap
from fenics_coulomb.scenes.cuboid import HEIGHT, LENGTH, WIDTH, GapFunction, box_coordinates, cells_per_direction
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.settings import COMMAND_PREFIX

__all__ = ["GRID_TOLERANCE", "NESTED_AUTO_MIN_LEV", "NESTED_COARSE_RTOL", "NESTED_LEVEL_STEP", "CoarseStart",
           "NestedResult", "coarse_level_options", "interpolate_cuboid", "nested_levels", "resolve_nested",
           "solve_coarse_levels", "solve_nested", "start_from_coarse"]

logger = logging.getLogger(__name__)


@dataclass
class NestedResult:
    """The results of every level of a nested solve, coarse to fine.

    Attributes:
        levels: One :class:`SolveResult` per problem.
    """

    levels: list[SolveResult] = field(default_factory=list)

    @property
    def newton_iterations(self) -> int:
        """Newton iterations over all levels."""
        return sum(r.iterations for r in self.levels)

    @property
    def krylov_iterations(self) -> int:
        """Krylov iterations over all levels."""
        return sum(r.krylov_iterations for r in self.levels)


def solve_nested(problems: Sequence[ContactProblem],
                 u0: dolfinx.fem.Function | None = None) -> tuple[dolfinx.fem.Function, SolveResult, NestedResult]:
    """Solve ``problems`` (coarse to fine) each from the previous one's solution (collective).

    Args:
        problems: The same contact problem on successively finer meshes (the finest last).
        u0: Start of the coarsest level (default: the paper's u⁽⁰⁾ = 0 of the shifted unknown).

    Returns:
        The finest level's displacement and result, and all levels' results.

    Raises:
        SolverError: from the first level that does not converge.
    """
    if not problems:
        raise ValueError("solve_nested needs at least one problem")
    nested = NestedResult()
    start = u0
    uh = None
    for level, problem in enumerate(problems):
        uh, result = problem.solve(start)
        nested.levels.append(result)
        if problem.model.comm.rank == 0:
            logger.info("nested level %d/%d: %d unknowns, %d Newton, %d Krylov", level + 1, len(problems),
                        problem.n, result.iterations, result.krylov_iterations)
        start = uh
    assert uh is not None
    return uh, nested.levels[-1], nested


#: A coarse node counts as a vertex of its box grid when its box coordinates are within this many cell widths
#: of one (round-off of create_box and of the gap map is ~1e-15).
GRID_TOLERANCE = 1e-6


def interpolate_cuboid(u_coarse: dolfinx.fem.Function, lev_coarse: int, V: dolfinx.fem.FunctionSpace,
                       gap: str | GapFunction) -> dolfinx.fem.Function | None:
    """Interpolate a displacement on the cuboid of level ``lev_coarse`` onto V, the cuboid of another level with
    the same gap, through the box both meshes are images of (collective).

    :func:`~fenics_coulomb.scenes.cuboid.create_cuboid` maps the vertices of a box grid, x3 ← d + t·(1 − d). On the
    box the coarse Q1 field is trilinear on every grid cell, so V's nodes, mapped back to the box
    (:func:`~fenics_coulomb.scenes.cuboid.box_coordinates`), take the trilinear interpolant of the coarse grid
    values: NumPy over all nodes at once, the coarse values gathered to every rank once (the coarse level is
    a fraction of the fine one). This is the physical-point interpolation where d is affine and differs from
    it by O(h²) elsewhere; a start of Newton's method needs no more. DOLFINx's non-matching interpolation
    (point location on the coarse mesh) gives the same start but took 9 s of a 50 s solve at lev 10.

    Returns:
        The interpolated Function, or None when the coarse mesh is not the box grid of ``lev_coarse`` (then use
        :func:`~fenics_coulomb.start_rule.interpolate_displacement`); the same on every rank.
    """
    comm = V.mesh.comm
    n = np.array(cells_per_direction(lev_coarse))
    h = np.array([LENGTH, WIDTH, HEIGHT]) / n
    Vc = u_coarse.function_space
    owned_c = Vc.dofmap.index_map.size_local
    grid = box_coordinates(Vc.tabulate_dof_coordinates()[:owned_c], gap) / h
    index = np.rint(grid).astype(np.int64)
    on_grid = bool(np.all(np.abs(grid - index) < GRID_TOLERANCE)) and bool(np.all((index >= 0) & (index <= n)))
    if not comm.allreduce(on_grid, op=MPI.LAND):
        return None
    shape = n + 1
    ids = index[:, 0] + shape[0] * (index[:, 1] + shape[1] * index[:, 2])
    values = np.asarray(u_coarse.x.array[: 3 * owned_c]).reshape(-1, 3)
    total = int(np.prod(shape))
    all_ids = np.concatenate(comm.allgather(ids))
    all_values = np.concatenate(comm.allgather(values))
    if all_ids.size != total or np.unique(all_ids).size != total:  # every grid vertex exactly once
        return None
    U = np.empty((total, 3))
    U[all_ids] = all_values

    owned = V.dofmap.index_map.size_local
    point = box_coordinates(V.tabulate_dof_coordinates()[:owned], gap) / h
    cell = np.clip(np.floor(point).astype(np.int64), 0, n - 1)
    xi = np.clip(point - cell, 0.0, 1.0)
    u = np.zeros((owned, 3))
    for corner in np.ndindex(2, 2, 2):
        c = np.array(corner)
        weight = np.prod(np.where(c == 1, xi, 1.0 - xi), axis=1)
        vertex = cell + c
        u += weight[:, None] * U[vertex[:, 0] + shape[0] * (vertex[:, 1] + shape[1] * vertex[:, 2])]
    result = dolfinx.fem.Function(V)
    result.x.array[: 3 * owned] = u.ravel()
    result.x.scatter_forward()
    return result


#: Residual reduction of the coarse levels of --nested. They only provide the start of the next level, but the
#: fine level needs fewer steps from an accurate one (2 ranks, d3/L2, lev 10 from lev 8, with the reduction then
#: relative to the paper's start: 1e-2 9 Newton / 126 Krylov, 66.0 s; 1e-4 8 / 96, 52.3 s; 1e-6 7 / 68, 45.9 s;
#: no gain below; benchmarks/nested.py, docs/nested). The stopping rule is now relative to ‖ŷ(ũ = 0)‖, which is
#: 53× smaller at lev 8 (25× at lev 6): 3e-5 asks for what 1e-6 asked then.
NESTED_COARSE_RTOL = 3e-5


#: --nested K solves the levels lev − NESTED_LEVEL_STEP·k, k = K, ..., 1 (h doubles from level to level).
NESTED_LEVEL_STEP = 2


#: Without --nested, the cuboid from this level on is solved with one coarser level (lev − 2) first: on 2 ranks
#: with the coarse reduction 1e-6 it saves 18-34 % of the time at lev 7-10 (d3/L2: lev 7 2.50 s against 3.25 s,
#: lev 10 46.8 s against 70.9 s; d1/L1 and d2/L2 at lev 8 alike; benchmarks/nested.py, docs/nested); lev 2-6 keep
#: the direct solve (the paper's Section 7 runs).
NESTED_AUTO_MIN_LEV = 7


def nested_levels(lev: int, levels: int) -> list[int]:
    """The coarser cuboid levels of ``--nested K``, coarse to fine: lev − 2K, ..., lev − 2 (each halves the mesh
    size h, as the levels of full multigrid do; two levels are a factor 2 in h)."""
    return [lev - NESTED_LEVEL_STEP * k for k in range(levels, 0, -1)]


@dataclass
class CoarseStart:
    """The last coarse level's solution of nested iteration, its level and every coarse level's result."""

    u: dolfinx.fem.Function
    lev: int
    results: list


def coarse_level_options(lev: int) -> dict[str, str]:
    """The user's ``-coulomb_*`` PETSc options for the coarse level ``lev`` of nested iteration (prefix
    ``coulomb_nested<lev>_``), without the prefix: every option given for the solve, except those the user gave
    for this level itself (``-coulomb_nested<lev>_*``, read from the database under its own prefix, win) and those
    for other coarse levels."""
    opts = PETSc.Options()
    given = {name[len(COMMAND_PREFIX):]: value for name, value in opts.getAll().items()
             if name.startswith(COMMAND_PREFIX) and not name.startswith(f"{COMMAND_PREFIX}nested")}
    return {key: value for key, value in given.items() if not opts.hasName(f"{COMMAND_PREFIX}nested{lev}_{key}")}


def solve_coarse_levels(scene: Scene, levels: int, comm: MPI.Comm) -> CoarseStart | None:
    """Solve the cuboid scene on its ``levels`` coarser levels (:func:`nested_levels`, coarse to fine, each from
    the previous solution, to NESTED_COARSE_RTOL) before the fine level is built, so that their memory is free
    again when it is; None (logged) when a coarse level does not converge: the fine level then starts as without
    nesting (collective). The user's ``-coulomb_*`` options apply to the coarse levels too
    (:func:`coarse_level_options`)."""
    coarse_levels = nested_levels(scene.body.lev, levels)
    coarse = [build_problem(scene.override(lev=lev, rtol=NESTED_COARSE_RTOL), comm,
                            petsc_options_prefix=f"{COMMAND_PREFIX}nested{lev}_",
                            petsc_options=coarse_level_options(lev)).problem
              for lev in coarse_levels]
    for problem in coarse:  # their options are the command's, whose unread ones the command names
        problem.solver.report_unread = False
    try:
        uh, _, nested = solve_nested(coarse, start_function(scene.start, coarse[0].V))
        opts = PETSc.Options()
        for key in {key for problem in coarse for key in problem.solver.options_read}:
            opts.hasName(f"{COMMAND_PREFIX}{key}")  # a copy a coarse level read: the command's option counts as read
    except SolverError as err:
        logger.warning("nested iteration: a coarse level did not converge (%s); lev %d starts without it", err,
                       scene.body.lev)
        return None
    finally:
        for problem in coarse:
            problem.destroy()
    u = dolfinx.fem.Function(uh.function_space)  # the problem's own Function went with it
    u.x.array[:] = uh.x.array
    logger.info("nested iteration: lev %s, %d Newton / %d Krylov iterations", ", ".join(map(str, coarse_levels)),
                sum(r.iterations for r in nested.levels), sum(r.krylov_iterations for r in nested.levels))
    return CoarseStart(u, coarse_levels[-1], nested.levels)


def start_from_coarse(start: CoarseStart, scene: Scene, V: dolfinx.fem.FunctionSpace) -> dolfinx.fem.Function:
    """The coarse solution on V: through the box grid (:func:`~fenics_coulomb.scenes.nested.interpolate_cuboid`), or,
    should the coarse mesh not be its level's grid, by DOLFINx's non-matching interpolation in ``solve``."""
    u = interpolate_cuboid(start.u, start.lev, V, cuboid_gap(scene))
    return u if u is not None else start.u


def resolve_nested(nested: int | None, scene: Scene) -> int:
    """``--nested`` as given, or by default 1 for a cuboid of level NESTED_AUTO_MIN_LEV or finer started from the
    paper's start or by the start rule ("auto", which takes the paper's start on the loaded cuboid), 0 otherwise
    (docs/scale: nested iteration pays from lev 7 on)."""
    if nested is not None:
        return nested
    return int(scene.body.shape == "cuboid" and scene.body.lev >= NESTED_AUTO_MIN_LEV
               and scene.start in ("auto", "zero"))
