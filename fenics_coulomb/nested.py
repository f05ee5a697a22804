"""Nested iteration (full-multigrid style): solve a coarse problem, interpolate, a few Newton steps per level.

Given the same contact problem on a sequence of meshes, coarse to fine, the first is solved from the paper's
start u⁽⁰⁾ = 0 and every finer one from the previous level's solution interpolated onto its mesh
(:func:`~fenics_coulomb.problem.interpolate_displacement`, the same interpolation as ``--start``). The
coarse levels only provide a start, so they are usually solved to a looser reduction (their own settings);
the finest level's settings decide the accuracy of the result. Every level after the first stops at rtol
times the residual of the paper's start on its mesh (``paper_target``), as a direct solve would: the better
start then saves Newton steps instead of asking for a smaller residual.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import dolfinx.fem

from fenics_coulomb.problem import ContactProblem
from fenics_coulomb.records import SolveResult

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
        uh, result = problem.solve(start, paper_target=level > 0)
        nested.levels.append(result)
        if problem.model.comm.rank == 0:
            logger.info("nested level %d/%d: %d unknowns, %d Newton, %d Krylov", level + 1, len(problems),
                        problem.n, result.iterations, result.krylov_iterations)
        start = uh
    assert uh is not None
    return uh, nested.levels[-1], nested
