"""Shared helpers of the benchmark scripts: build and solve a Section 7 case through the API, record numbers."""

from __future__ import annotations

import json
import platform
import resource
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from fenics_coulomb import ContactProblem, SolverError, SolveResult, SolverSettings
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.io.summary import software_versions

CASES = [(g, ld) for g in ("d1", "d2", "d3") for ld in ("L1", "L2")]


@dataclass
class Run:
    """A solved case: the problem (owns PETSc objects), the result and timings."""

    problem: ContactProblem
    result: SolveResult
    model_s: float
    solve_s: float

    @property
    def model(self):
        return self.problem.model

    def destroy(self) -> None:
        self.problem.destroy()


def build(comm: MPI.Comm, lev: int, gap: str, load: str, friction: float = 0.23,
          **overrides: Any) -> tuple[ContactProblem, float]:
    """Build a case (scene settings as overrides); return the problem and the wall time (max over ranks)."""
    t0 = time.perf_counter()
    scene = Scene().override(lev=lev, gap=gap, load=load, friction=friction, **overrides)
    problem = build_problem(scene, comm).problem
    return problem, comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)


def solve(problem: ContactProblem, settings: SolverSettings,
          start: dolfinx.fem.Function | None = None) -> tuple[SolveResult, float]:
    """Solve with ``settings`` (a new solver on the same model) from ``start`` (default: the paper's u⁽⁰⁾ = 0 of
    the shifted unknown); return the result, converged or not, and the wall time including the solver set-up."""
    comm = problem.V.mesh.comm
    comm.barrier()
    t0 = time.perf_counter()
    problem.set_solver(settings)
    problem.reset()  # the same static problem again, not the next step of a load path from the last solution
    try:
        _, result = problem.solve(start)
    except SolverError as err:
        result = err.result
    return result, comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)


def run_case(comm: MPI.Comm, lev: int, gap: str, load: str, settings: SolverSettings,
             start: dolfinx.fem.Function | None = None) -> Run:
    problem, t_model = build(comm, lev, gap, load)
    result, t_solve = solve(problem, settings, start)
    return Run(problem, result, t_model, t_solve)


def peak_rss_mib(comm: MPI.Comm) -> float:
    """Sum over ranks of the peak resident set size (MiB)."""
    return comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.SUM) / 1024.0


def norm(comm: MPI.Comm, x: np.ndarray) -> float:
    return float(np.sqrt(comm.allreduce(float(np.dot(x, x)), op=MPI.SUM)))


def machine(comm: MPI.Comm) -> dict[str, Any]:
    info = {"machine": platform.machine(), "ranks": comm.size, "versions": software_versions()}
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return info


def write_table(out: Path, name: str, title: str, rows: list[dict[str, Any]], comm: MPI.Comm) -> None:
    """Write rows as CSV and a Markdown table with the machine description (rank 0)."""
    if comm.rank != 0 or not rows:
        return
    import csv

    out.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    with open(out / f"{name}.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)

    def fmt(v: Any) -> str:
        if isinstance(v, float):
            return f"{v:.3g}" if (abs(v) < 1e-2 or abs(v) >= 1e5) and v != 0 else f"{v:.2f}"
        return str(v)

    lines = [f"# {title}", "", f"Machine: `{json.dumps(machine(comm))}`", "",
             "| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    (out / f"{name}.md").write_text("\n".join(lines) + "\n")
