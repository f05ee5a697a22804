"""The one writer of a solve's result set: fields, convergence history, summary.json and (optionally) figures.

The command line and the Python API write the same files the same way::

    from fenics_coulomb import write_results
    data = write_results("out/press", problem, result, reactions={"bottom": clamp})

Files: ``solution.xdmf`` + ``solution.h5`` (the displacement and every contact field, :mod:`.xdmf`), ``view.py``
(``pvpython view.py``: the body warped and coloured by contact state beside the obstacles, :mod:`.view`),
``obstacles.xdmf`` + ``obstacles.h5`` (the rigid obstacles' surfaces as placed, when there are obstacles,
:mod:`.obstacle_surfaces`),
``convergence.csv`` (one row per Newton iteration), ``summary.json`` (the result's summary, the total contact
force, the applied load, the reactions of the named supports, per-pair forces, software versions) and, with
``plots=True``, the PNG figures. The directory is written whole or not at all (:class:`.results.ResultDirectory`);
a result that did not converge goes to ``PATH.not-converged`` when PATH holds a converged set.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

from fenics_coulomb.errors import InputError
from fenics_coulomb.io.obstacle_surfaces import ObstacleSeries, body_box
from fenics_coulomb.io.results import ResultDirectory
from fenics_coulomb.io.summary import summary, write_convergence_csv, write_summary
from fenics_coulomb.io.view import contact_bodies, largest_force_normal, warp_scale, write_view_script
from fenics_coulomb.io.xdmf import write_xdmf
from fenics_coulomb.model.checks import boundary_reactions, total_contact_force
from fenics_coulomb.report import reaction_groups
from fenics_coulomb.scd.records import SolveResult

if TYPE_CHECKING:
    from fenics_coulomb.problem import ContactProblem

__all__ = ["write_result_set", "write_results"]


def write_result_set(directory: Path, problem: ContactProblem, result: SolveResult, *, label: str = "",
                     plots: bool = False, reactions: Mapping[str, Any] | None = None,
                     extra: Mapping[str, Any] | None = None, timings: Mapping[str, float] | None = None,
                     started: float | None = None) -> dict[str, Any]:
    """Write the result set of ``result`` into the (temporary) ``directory`` (collective); return summary.json's
    data.

    Args:
        directory: Where the files go (a :class:`~fenics_coulomb.io.results.ResultDirectory`'s temporary set).
        problem: The solved problem.
        result: Its result.
        label: The figures' title.
        plots: Write the PNG figures too.
        reactions: Named supports whose reactions summary.json reports: name → DirichletBC or local node blocks.
        extra: More summary.json entries.
        timings: More phases for ``timings_s`` (this rank's seconds; the maximum over the ranks is written).
        started: ``time.perf_counter()`` when writing began: ``timings_s["output"]`` is measured from it.
    """
    model = problem.model
    comm = model.comm
    write_xdmf(directory / "solution.xdmf", model, result)
    write_convergence_csv(directory / "convergence.csv", result, comm)
    write_view_script(directory / "view.py", warp_scale(model, [result.displacement]),
                      largest_force_normal(model, result.contact_force), comm, contact_bodies(model))
    files = ["solution.xdmf", "solution.h5", "convergence.csv", "view.py"]
    if model.obstacles:
        ObstacleSeries(directory / "obstacles.xdmf", model.obstacles, body_box(model.V.mesh.geometry.x, comm),
                       comm).write(0.0, model.obstacles)
        files += ["obstacles.xdmf", "obstacles.h5"]
    if plots:
        from fenics_coulomb.io.figures import write_figures

        files += write_figures(directory, model, result, label)
    data = summary(model, result, dict(extra or {}))
    data["reactions"] = boundary_reactions(model, result.displacement, reaction_groups(model.V, reactions or {}),
                                           result.master_force, result.contact_force)
    data["contact_force"] = total_contact_force(model, result.contact_force)
    data["applied_load"] = [float(c) for c in model.total_load()]
    for key, value in (timings or {}).items():
        data["timings_s"][key] = comm.allreduce(float(value), op=MPI.MAX)
    if started is not None:
        data["timings_s"]["output"] = comm.allreduce(time.perf_counter() - started, op=MPI.MAX)
    data["files"] = [*files, "summary.json"]
    write_summary(directory / "summary.json", data, comm)
    return data


def write_results(path: str | Path, problem: ContactProblem, result: SolveResult, *, label: str = "",
                  plots: bool = False, reactions: Mapping[str, Any] | None = None,
                  extra: Mapping[str, Any] | None = None, comm: MPI.Comm | None = None) -> dict[str, Any]:
    """Write the result set of a solve to ``path`` as the command line does (collective); return summary.json's
    data. See the module docstring; the arguments are those of :func:`write_result_set`.

    Raises:
        InputError: for a path that is not a non-empty name, a ``problem`` that is not a ContactProblem or a
            ``result`` that is not a SolveResult (before anything is written or communicated).
    """
    from fenics_coulomb.problem import ContactProblem

    if not isinstance(path, str | Path) or not str(path).strip():
        raise InputError(f"write_results: path = {path!r}: give the result directory's name")
    if not isinstance(problem, ContactProblem):
        raise InputError(f"write_results: problem = {type(problem).__name__}: give the ContactProblem that solved "
                         "the result")
    if not isinstance(result, SolveResult):
        raise InputError(f"write_results: result = {type(result).__name__}: give the SolveResult of the problem's "
                         "solve()")
    if id(result) not in getattr(problem, "_results", {id(result)}):
        raise InputError("write_results: the result is not one of this problem's solve() (a result of another "
                         "problem describes other nodes)")
    out = ResultDirectory(comm or problem.model.comm, path)
    out.failed = not result.converged
    with out.writing() as tmp:
        data = write_result_set(tmp, problem, result, label=label, plots=plots, reactions=reactions, extra=extra)
    return data
