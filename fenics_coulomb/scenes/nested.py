"""Nested iteration (full-multigrid style): solve a coarse problem, interpolate, a few Newton steps per level.

Given the same contact problem on a sequence of meshes, coarse to fine, the first is solved from the paper's
start u⁽⁰⁾ = 0 and every finer one from the previous level's solution interpolated onto its mesh
(:func:`~fenics_coulomb.problem.interpolate_displacement`, the same interpolation as ``--start``). The
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

import dolfinx.fem
import numpy as np

from fenics_coulomb.problem import ContactProblem
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scenes.cuboid import HEIGHT, LENGTH, WIDTH, GapFunction, box_coordinates, cells_per_direction

__all__ = ["NestedResult", "solve_nested", "GRID_TOLERANCE", "interpolate_cuboid"]

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
        :func:`~fenics_coulomb.problem.interpolate_displacement`); the same on every rank.
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
