"""The one writer of a result set — a solve's or a load path's: fields, histories, summary.json and (optionally)
figures.

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
a result that did not converge goes to ``PATH.not-converged`` when PATH holds a converged set. The figures are drawn
after it is in place (:func:`add_figures`): an interrupt while they are drawn (seconds) leaves it without them.

A load path's set (:class:`PathResultSet`) grows by one grid of ``solution.xdmf`` and of ``obstacles.xdmf`` per
solve (an interrupted path keeps its completed solves as ``OUT.interrupted``, with the files below, :meth:`progress`)
and ends with ``path.csv`` (one row per solve, per obstacle and contact pair too), ``path.png``,
``convergence.csv`` of the last solve and summary.json with its ``steps``. The forces of summary.json are those of
:class:`~fenics_coulomb.report.ContactReport` (one definition: summed in the contact nodes' global order, the
same bits on any number of ranks).
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mpi4py import MPI

import numpy as np

from fenics_coulomb.errors import InputError, OutputError
from fenics_coulomb.io.obstacle_surfaces import ObstacleSeries, body_box
from fenics_coulomb.io.results import ResultDirectory
from fenics_coulomb.io.summary import summary, write_convergence_csv, write_path_csv, write_summary
from fenics_coulomb.io.units import Units
from fenics_coulomb.io.view import contact_bodies, largest_force_normal, warp_scale, write_view_script
from fenics_coulomb.io.xdmf import XDMFTimeSeries, write_initial_grid, write_result_grid, write_xdmf
from fenics_coulomb.model.checks import displacement_scale, force_floor
from fenics_coulomb.report import make_report
from fenics_coulomb.scd.records import SolveResult

if TYPE_CHECKING:
    from fenics_coulomb.problem import ContactProblem

__all__ = ["PathResultSet", "add_figures", "write_result_set", "write_results"]

logger = logging.getLogger(__name__)


def write_result_set(directory: Path, problem: ContactProblem, result: SolveResult, *,
                     reactions: Mapping[str, Any] | None = None,
                     extra: Mapping[str, Any] | None = None, timings: Mapping[str, float] | None = None,
                     started: float | None = None, wall_start: float | None = None,
                     units: Units | None = None) -> dict[str, Any]:
    """Write the result set of ``result`` into the (temporary) ``directory`` (collective); return summary.json's
    data. The figures follow once the set is committed (:func:`add_figures`).

    Args:
        directory: Where the files go (a :class:`~fenics_coulomb.io.results.ResultDirectory`'s temporary set).
        problem: The solved problem.
        result: Its result.
        reactions: Named supports whose reactions summary.json reports: name → DirichletBC or local node blocks.
        extra: More summary.json entries.
        timings: More phases for ``timings_s`` (this rank's seconds; the maximum over the ranks is written).
        started: ``time.perf_counter()`` when writing began: ``timings_s["output"]`` is measured from it.
        wall_start: ``time.perf_counter()`` when the command began: ``wall_time_s`` is the whole command's time
            since it, as for a load path (without it, the solver's time, ``timings_s["total"]``).
        units: The units the outputs are labelled with (:class:`~fenics_coulomb.io.units.Units`; default GPa, L).
    """
    model = problem.model
    comm = model.comm
    write_xdmf(directory / "solution.xdmf", model, result, units)
    write_convergence_csv(directory / "convergence.csv", result, comm)
    write_view_script(directory / "view.py", warp_scale(model, [result.displacement]),
                      largest_force_normal(model, result.contact_force), comm, contact_bodies(model))
    files = ["solution.xdmf", "solution.h5", "convergence.csv", "view.py"]
    if model.obstacles:
        ObstacleSeries(directory / "obstacles.xdmf", model.obstacles, body_box(model.V.mesh.geometry.x, comm),
                       comm, (units or Units()).length).write(0.0, model.obstacles)
        files += ["obstacles.xdmf", "obstacles.h5"]
    data = summary(model, result, dict(extra or {}), units)
    report = make_report(model, result, model.obstacles, reactions or {})
    data["reactions"] = {name: [float(c) for c in v] for name, v in report.reactions.items()}
    data["contact_force"] = [float(c) for c in report.total_force]
    data["applied_load"] = [float(c) for c in report.applied_load]
    _reaction_balance(data, _force_floor(model, result))
    if wall_start is not None:
        data["wall_time_s"] = comm.allreduce(time.perf_counter() - wall_start, op=MPI.MAX)
    return _finish(directory, data, comm, files, timings, started)


def _force_floor(model: Any, result: SolveResult) -> float:
    """The forces that are round-off for ``result`` (:func:`~fenics_coulomb.model.checks.force_floor`; collective)."""
    unknown = result.relative_displacement if result.relative_displacement is not None else result.displacement
    # at least the forces of a displacement of 1e-12 of the body's size (an unloaded state: u = 0 and no gap)
    scale = max(displacement_scale(model, np.asarray(unknown, dtype=np.float64)), 1e-2 * model.placement.size)
    return force_floor(model, scale)


def _reaction_balance(data: dict[str, Any], floor: float) -> None:
    """``physics_checks.reaction_balance`` from the written forces when the result set names supports: ‖Σ reactions
    + contact force + applied load‖ over the largest of ‖applied load‖, ‖contact force‖, Σ ‖reaction‖ and the
    forces that are round-off (``floor``: a state without forces balances) (the command names every support; an API
    result set those its ``reactions`` name)."""
    if not data.get("reactions"):
        return
    reactions = [np.asarray(v, dtype=np.float64) for v in data["reactions"].values()]
    contact, applied = np.asarray(data["contact_force"]), np.asarray(data["applied_load"])
    scale = max(float(np.linalg.norm(applied)), float(np.linalg.norm(contact)),
                sum(float(np.linalg.norm(r)) for r in reactions), floor)
    data.setdefault("physics_checks", {})["reaction_balance"] = \
        float(np.linalg.norm(sum(reactions) + contact + applied)) / scale


def _finish(directory: Path, data: dict[str, Any], comm: MPI.Comm, files: list[str],
            timings: Mapping[str, float] | None, started: float | None, seconds: float = 0.0) -> dict[str, Any]:
    """The end of every result set: the phases' timings (the maximum over the ranks; ``output`` since
    ``started`` plus ``seconds`` spent writing before), the file list, summary.json (collective)."""
    for key, value in (timings or {}).items():
        data["timings_s"][key] = comm.allreduce(float(value), op=MPI.MAX)
    if started is not None:
        data["timings_s"]["output"] = comm.allreduce(seconds + time.perf_counter() - started, op=MPI.MAX)
    data["files"] = [*files, "summary.json"]
    write_summary(directory / "summary.json", data, comm)
    return data


class PathResultSet:
    """The result set of a load path, written while the path is solved (every method is collective).

    ``solution.xdmf`` and ``obstacles.xdmf`` (when there are obstacles) get one grid per solve
    (:meth:`write_solve`, the obstacles as placed for it), starting with the unloaded body at t = 0 (``initial``;
    a resumed path has it in its first part); :meth:`finish` writes the rest.

    Args:
        directory: Where the files go (a :class:`~fenics_coulomb.io.results.ResultDirectory`'s temporary set).
        problem: The problem that solves the path.
        initial: Write the unloaded state as t = 0 (the obstacles at their scene positions).
    """

    def __init__(self, directory: Path, problem: ContactProblem, *, initial: bool = True) -> None:
        start = time.perf_counter()
        self.directory = Path(directory)
        self.problem = problem
        model = problem.model
        self.xdmf = XDMFTimeSeries(self.directory / "solution.xdmf", model.V.mesh)
        self.surfaces = ObstacleSeries(self.directory / "obstacles.xdmf", model.obstacles,
                                       body_box(model.V.mesh.geometry.x, model.comm), model.comm) \
            if model.obstacles else None
        if initial:
            write_initial_grid(self.xdmf, model)
            if self.surfaces is not None:
                self.surfaces.write(0.0, [o.at_scene_position().rotated(None) for o in model.obstacles])
        #: Seconds spent writing so far (this rank).
        self.seconds = time.perf_counter() - start

    def write_solve(self, t: float, name: str, result: SolveResult) -> None:
        """Append the grids of the solve at time ``t`` (its grid's ``name``, e.g. "step 2 (1/3)")."""
        start = time.perf_counter()
        model = self.problem.model
        write_result_grid(self.xdmf, model, result, t, name)
        if self.surfaces is not None:  # as placed for this solve
            self.surfaces.write(t, model.obstacles)
        self.seconds += time.perf_counter() - start

    def progress(self, steps: list[dict[str, Any]], result: SolveResult,
                 extra: Mapping[str, Any]) -> Callable[[Path], None]:
        """What makes the set so far the result set of its solves ``steps`` (collective: the parts that need every
        rank are computed now, and a barrier ends it — on return every rank's grids are written): a function that
        writes, on this rank alone, into a directory, convergence.csv of the last solve ``result``, path.csv,
        view.py and a summary.json of ``extra`` (the scene, the settings, the path) with the steps, ``converged``
        false and ``reason`` "interrupted". An interrupt between two solves calls it
        (:meth:`ResultDirectory.keep_on_interrupt <fenics_coulomb.io.results.ResultDirectory.keep_on_interrupt>`):
        nothing is written per solve beyond its grids. ``steps`` is read when it writes (its first entries as now)."""
        model = self.problem.model
        count = len(steps)
        scale = warp_scale(model, [result.displacement])
        normal = largest_force_normal(model, result.contact_force)
        bodies = contact_bodies(model)
        files = ["solution.xdmf", "solution.h5", "convergence.csv", "path.csv", "view.py"]
        files += ["obstacles.xdmf", "obstacles.h5"] if self.surfaces is not None else []
        files += [ResultDirectory.MANIFEST]
        model.comm.barrier()
        alone = MPI.COMM_SELF

        def write(directory: Path) -> None:
            done = steps[:count]
            _raising(write_convergence_csv)(directory / "convergence.csv", result, alone)
            _raising(write_path_csv)(directory / "path.csv", done, alone)
            _raising(write_view_script)(directory / "view.py", scale, normal, alone, bodies)
            data = {**extra, "converged": False, "reason": "interrupted", "steps": done, "files": files}
            _raising(write_summary)(directory / "summary.json", data, alone)

        return write

    def finish(self, steps: list[dict[str, Any]], result: SolveResult, *,
               extra: Mapping[str, Any] | None = None, timings: Mapping[str, float] | None = None,
               wall_start: float | None = None) -> dict[str, Any]:
        """Write convergence.csv (of the last solve ``result``), path.csv (``steps``: one record per solve,
        :meth:`~fenics_coulomb.scenes.path.StepRecord.as_dict`), view.py and summary.json (the last solve's
        summary, ``steps``, the last step's reactions and contact force, the iteration totals and ``extra``;
        ``wall_time_s`` since ``wall_start``, a ``time.perf_counter()``); return summary.json's data. The figures
        follow once the set is committed (:func:`add_figures`)."""
        started = time.perf_counter()
        model = self.problem.model
        comm = model.comm
        directory = self.directory
        write_convergence_csv(directory / "convergence.csv", result, comm)
        write_path_csv(directory / "path.csv", steps, comm)
        write_view_script(directory / "view.py", warp_scale(model, [result.displacement]),
                          largest_force_normal(model, result.contact_force), comm, contact_bodies(model))
        files = ["solution.xdmf", "solution.h5", "convergence.csv", "path.csv", "view.py"]
        files += ["obstacles.xdmf", "obstacles.h5"] if self.surfaces is not None else []
        data = summary(model, result, dict(extra or {}))
        data["steps"] = steps
        slid = [s["small_sliding"] for s in steps if s.get("small_sliding")]
        if slid:  # small sliding: the largest slide over the path, not the last solve's
            data["small_sliding"] = dict(max(slid, key=lambda s: s["slide_per_size"]))
        data["reactions"] = steps[-1]["reactions"]
        data["contact_force"] = steps[-1]["contact_force"]
        data["applied_load"] = steps[-1]["applied_load"]
        _reaction_balance(data, _force_floor(model, result))
        # the solves' time over the whole path (the phases of timings_s add up over every solve too)
        data["timings_s"]["total"] = float(sum(s["wall_time_s"] for s in steps))
        data["newton_iterations_total"] = sum(s["newton_iterations"] for s in steps)
        data["krylov_iterations_total"] = sum(s["krylov_iterations"] for s in steps)
        if wall_start is not None:
            data["wall_time_s"] = comm.allreduce(time.perf_counter() - wall_start, op=MPI.MAX)
        return _finish(directory, data, comm, files, timings, started, self.seconds)


def _raising(write: Callable[..., None]) -> Callable[..., None]:
    """A rank-0 file writer (:func:`~fenics_coulomb.io.results.rank0_file`) as it is, raising its OSError at once
    (the interrupt's handler writes the rest of a kept set on one rank, and must know whether it could)."""
    return write.__wrapped__  # type: ignore[attr-defined]


#: summary.json's entries that ``extra`` may not replace: what the solve says about itself.
PROTECTED_KEYS = ("converged", "reason", "newton_iterations", "krylov_iterations", "residual_history",
                  "physics_checks", "contact_force", "reactions", "applied_load", "n", "p")


def check_extra(extra: Any) -> None:
    """InputError unless ``extra`` is None or a mapping of JSON data that replaces none of PROTECTED_KEYS (pure: the
    same on every rank, before anything is written)."""
    if extra is None:
        return
    if not isinstance(extra, Mapping):
        raise InputError(f"write_results: extra = {type(extra).__name__}: give a dict of entries for summary.json")
    taken = [key for key in extra if key in PROTECTED_KEYS]
    if taken:
        raise InputError(f"write_results: extra would replace summary.json's {taken[0]!r}, which the solve reports")
    try:
        json.dumps(dict(extra))
    except (TypeError, ValueError) as err:
        raise InputError(f"write_results: extra is not JSON data ({err}): give numbers, strings, lists and dicts "
                         "(e.g. array.tolist())") from None


def write_results(path: str | Path, problem: ContactProblem, result: SolveResult, *, label: str = "",
                  plots: bool = False, reactions: Mapping[str, Any] | None = None,
                  extra: Mapping[str, Any] | None = None, comm: MPI.Comm | None = None,
                  units: Mapping[str, str] | Units | None = None) -> dict[str, Any]:
    """Write the result set of a solve to ``path`` as the command line does (collective); return summary.json's
    data. See the module docstring; the arguments are those of :func:`write_result_set`, ``units`` also as a dict
    (``{"stress": "Pa", "length": "m"}``: the form's stress unit and the mesh's length unit; default GPa and L).

    Raises:
        InputError: for a path that is not a non-empty name, a ``problem`` that is not a ContactProblem, a
            ``result`` that is not a SolveResult, ``plots`` that is not a bool, a ``label`` that is not a string or
            ``units`` that are not unit names (before anything is written or communicated).
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
    if not isinstance(plots, bool | np.bool_):  # "no" would draw them: a non-empty string is true
        raise InputError(f"write_results: plots = {plots!r}: give True or False")
    if not isinstance(label, str):
        raise InputError(f"write_results: label = {label!r}: give the figures' title as a string")
    problem.check_result(result, "write_results")
    if "\0" in str(path):
        raise InputError(f"write_results: path = {str(path)!r}: a file name cannot hold a NUL character")
    check_extra(extra)
    labels = Units.of(units, "write_results: units")
    out = ResultDirectory(comm or problem.model.comm, path, "write_results: path")
    out.failed = not result.converged
    with out.writing() as tmp:
        data = write_result_set(tmp, problem, result, reactions=reactions, extra=extra, units=labels)
    if plots:
        from fenics_coulomb.io.figures import write_figures

        add_figures(out, data, lambda directory: write_figures(directory, problem.model, result, label, labels))
    return data


def add_figures(out: ResultDirectory, data: dict[str, Any], draw: Callable[[Path], list[str]], *,
                wall: bool = False) -> None:
    """Draw the figures of the result set committed last in ``out`` into it (collective;
    :meth:`~fenics_coulomb.io.results.ResultDirectory.add`): ``draw`` writes them into a directory and returns their
    names (a figure that fails is a logged warning, :func:`~fenics_coulomb.io.figures.write_figures`). summary.json
    (``data``, updated in place) then lists them, with ``timings_s["figures"]`` the seconds they took (the maximum
    over the ranks), added to ``wall_time_s`` when that is the ``wall`` time of a whole command. An interrupt
    meanwhile ends the run with the set in place without them; figures that cannot be added (a full disk) are a
    logged warning, the set stays as it is (``data`` too)."""
    started = time.perf_counter()
    comm = out.comm
    added = {**data, "timings_s": dict(data["timings_s"])}

    def write(directory: Path) -> list[str]:
        names = draw(directory)
        seconds = comm.allreduce(time.perf_counter() - started, op=MPI.MAX)
        added["timings_s"]["figures"] = seconds
        if wall:
            added["wall_time_s"] += seconds
        added["files"] = [*(f for f in data["files"] if f != ResultDirectory.MANIFEST), *names,
                          ResultDirectory.MANIFEST]
        write_summary(directory / ResultDirectory.MANIFEST, added, comm)
        return [*names, ResultDirectory.MANIFEST]

    ended = "ended" if out.failed else "finished"
    try:
        out.add(write, lambda place: f"the run had {ended}: its results are in {place}, without the figures it was "
                                     "drawing")
    except OutputError as err:  # a figure never costs the results (a full disk): a warning, as for one figure
        if comm.rank == 0:
            logger.warning("fenics-coulomb: warning: %s", err)
        return
    data.update(added)
