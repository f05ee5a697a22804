"""Shared helpers of the benchmark scripts: build and solve a Section 7 case, record numbers."""

from __future__ import annotations

import json
import platform
import resource
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np

from fenics_coulomb.errors import SolverError
from fenics_coulomb.model import ContactModel, Material
from fenics_coulomb.newton import SCDNewtonSolver, SolveResult, SolverSettings
from fenics_coulomb.output import software_versions
from fenics_coulomb.scene import create_cuboid, paper_tractions

CASES = [(g, ld) for g in ("d1", "d2", "d3") for ld in ("L1", "L2")]


@dataclass
class Run:
    """A solved case: the model (owns PETSc objects), the result and timings."""

    model: ContactModel
    result: SolveResult
    model_s: float
    solve_s: float

    def destroy(self) -> None:
        self.model.destroy()


def build(comm: MPI.Comm, lev: int, gap: str, load: str, friction: float = 0.23) -> tuple[ContactModel, float]:
    """Assemble a case; return the model and the wall time (max over ranks)."""
    t0 = time.perf_counter()
    body = create_cuboid(comm, lev, gap)
    model = ContactModel(body, Material(), friction, paper_tractions(load))
    return model, comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)


def solve(model: ContactModel, settings: SolverSettings, start: np.ndarray | None = None) -> tuple[SolveResult, float]:
    """Solve from ũ⁽⁰⁾ = start (default: the paper's origin of the shifted unknown)."""
    comm = model.V.mesh.comm
    comm.barrier()
    t0 = time.perf_counter()
    solver = SCDNewtonSolver(model, settings)
    init = -model.shift.getArray(readonly=True).copy() if start is None else start
    try:
        result = solver.solve(init)
    except SolverError as err:
        result = err.result
    solver.destroy()
    return result, comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)


def run_case(comm: MPI.Comm, lev: int, gap: str, load: str, settings: SolverSettings,
             start: np.ndarray | None = None) -> Run:
    model, t_model = build(comm, lev, gap, load)
    result, t_solve = solve(model, settings, start)
    return Run(model, result, t_model, t_solve)


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
