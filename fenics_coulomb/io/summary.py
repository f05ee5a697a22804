"""The run's numbers as files: ``summary.json`` (the solve's summary, software versions, per-pair forces),
``convergence.csv`` (one row per Newton iteration) and ``path.csv`` (one row per solve of a load path)."""

from __future__ import annotations

import json
import platform
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl

from fenics_coulomb.io.fields import UNITS, contact_statistics, stress_statistics
from fenics_coulomb.io.units import Units
from fenics_coulomb.io.results import rank0_file
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.scd.records import SolveResult

__all__ = ["GROUP_COLUMNS", "summary", "write_summary", "write_convergence_csv", "write_path_csv", "software_versions"]


def summary(model: ContactModel, result: SolveResult, extra: dict[str, Any] | None = None,
            units: Units | None = None) -> dict[str, Any]:
    """Global summary of a solve (collective; identical on all ranks): the result's own summary, the contact
    area and the peak contact pressure with its location (``contact_area``, ``contact_nodes``,
    ``peak_pressure``, ``peak_pressure_at``), the same per obstacle (``obstacles``: name → those and the
    ``force`` on the body) and per contact pair (``contact_pairs``: those and the force on each body,
    :func:`~fenics_coulomb.model.pairs.forces.pair_forces`), the largest von Mises and shear stress with their
    places (``max_von_mises``, ``max_von_mises_at``, ``max_shear``, ``max_shear_at``:
    :func:`~fenics_coulomb.io.fields.stress_statistics`),
    the ``units`` (default GPa and L), the software versions and ``extra``
    (:func:`~fenics_coulomb.io.fields.contact_statistics`)."""
    comm = model.V.mesh.comm
    data = result.summary(comm)
    statistics = contact_statistics(model, result)
    per_pair = statistics.pop("contact_pairs")
    data.update(statistics)
    data.update(model.coupling.summary_entries(model, result, per_pair))  # contact pairs: "contact_pairs"
    data.update(stress_statistics(model, result))
    data["units"] = (units or Units()).table()
    data["versions"] = software_versions()
    if extra:
        data.update(extra)
    return data


@rank0_file
def write_summary(path: Path, data: dict[str, Any], comm: MPI.Comm) -> None:
    """Write the summary as JSON on rank 0."""
    if comm.rank == 0:
        path.write_text(json.dumps(data, indent=2) + "\n")


@rank0_file
def write_convergence_csv(path: Path, result: SolveResult, comm: MPI.Comm) -> None:
    """Per-iteration history as CSV on rank 0: residual, relative residual, step, Krylov, states, and the solve of
    finite sliding's geometry iteration each row belongs to (``geometry``; each solve starts with its own row 0,
    the relative residual is relative to it)."""
    if comm.rank != 0:
        return
    lines = ["iteration,residual,relative_residual,step_length,krylov_iterations,open,stick,slip,forcing,"
             "linear_residual,geometry"]
    history = list(result.residual_history) or [0.0]
    solve_of = list(result.history_geometry) or [0] * len(history)  # one solve: one row 0
    records = iter(result.records)
    h0 = 0.0
    for k, (residual, g) in enumerate(zip(history, solve_of, strict=True)):
        if k == 0 or g != solve_of[k - 1]:  # a solve's initial residual
            h0 = residual
            lines.append(f"0,{h0:.17g},1,,,,,,,,{g}")
            continue
        rec = next(records)
        rel = rec.residual / h0 if h0 > 0 else 0.0
        lines.append(f"{rec.iteration},{rec.residual:.17g},{rel:.17g},{rec.step_length:.17g},"
                     f"{rec.krylov_iterations},{rec.open},{rec.stick},{rec.slip},{rec.forcing:.6g},"
                     f"{rec.linear_residual:.6g},{g}")
    path.write_text("\n".join(lines) + "\n")


#: The per-obstacle and per-pair columns of path.csv (of the steps' "groups").
GROUP_COLUMNS = ("normal_force", "tangential_force", "peak_pressure", "contact_area", "contact_nodes", "stick", "slip")


@rank0_file
def write_path_csv(path: Path, steps: Sequence[Mapping[str, Any]], comm: MPI.Comm) -> None:
    """One row per solve of a load path on rank 0 (``steps``: summary.json's "steps"): solve, time (the step
    number), step, substep, load factor, converged, Newton and Krylov iterations, the geometry updates of finite
    sliding, open/stick/slip, the total
    contact force, the applied load's resultant, the reaction per Dirichlet boundary and δ per obstacle (x, y,
    z components each; a boundary group "a,b" is named "a+b"), per obstacle and contact pair (the steps'
    "groups") the normal and tangential force, peak pressure, contact area, nodes in contact and stick/slip
    nodes, under small sliding each solve's largest slide in partner sizes (``slide_per_size``), wall time.
    Columns of a quantity with a unit carry it after the name: ``contact_force_x [GPa*L^2]``,
    ``delta_ball_z [L]``, ``normal_force_ball [GPa*L^2]``, ``peak_pressure_pair 1 [GPa]``."""
    if comm.rank != 0 or not steps:
        return
    FORCE, LENGTH = f"[{UNITS['force']}]", f"[{UNITS['length']}]"  # noqa: N806
    xyz = ("x", "y", "z")
    reactions = list(steps[0]["reactions"])
    obstacles = list(steps[0]["obstacle_displacements"])
    groups = list(steps[0].get("groups", {}))
    small = any(s.get("small_sliding") for s in steps)  # small sliding: each solve's largest slide
    units = {"normal_force": f" {FORCE}", "tangential_force": f" {FORCE}", "peak_pressure": f" [{UNITS['pressure']}]",
             "contact_area": f" [{UNITS['area']}]", "contact_nodes": "", "stick": "", "slip": ""}
    header = ["solve", "time", "step", "substep", "load_factor", "converged", "newton_iterations",
              "krylov_iterations", "geometry_updates", "open", "stick", "slip",
              *[f"contact_force_{c} {FORCE}" for c in xyz], *[f"applied_load_{c} {FORCE}" for c in xyz],
              *[f"reaction_{name.replace(',', '+')}_{c} {FORCE}" for name in reactions for c in xyz],
              *[f"delta_{name.replace(',', '+')}_{c} {LENGTH}" for name in obstacles for c in xyz],
              *[f"{key}_{name.replace(',', '+')}{units[key]}" for name in groups for key in GROUP_COLUMNS],
              *(["slide_per_size"] if small else []), "wall_time_s"]
    lines = [",".join(header)]
    for s in steps:
        counts = s["state_counts"]
        row = [s["index"], f"{s['time']:.17g}", s["step"], s["substep"], f"{s['load_factor']:.17g}",
               str(bool(s["converged"])).lower(), s["newton_iterations"], s["krylov_iterations"],
               s.get("geometry_updates", 0), counts["open"], counts["stick"], counts["slip"],
               *[f"{c:.17g}" for c in s["contact_force"]], *[f"{c:.17g}" for c in s["applied_load"]],
               *[f"{c:.17g}" for name in reactions for c in s["reactions"][name]],
               *[f"{c:.17g}" for name in obstacles for c in s["obstacle_displacements"][name]],
               *[format(s["groups"][name][key], ".17g") for name in groups for key in GROUP_COLUMNS],
               *([format(s.get("small_sliding", {}).get("slide_per_size", 0.0), ".17g")] if small else []),
               f"{s['wall_time_s']:.6g}"]
        lines.append(",".join(map(str, row)))
    path.write_text("\n".join(lines) + "\n")


def software_versions() -> dict[str, str]:
    """Versions of the numerical stack."""

    major, minor, sub = PETSc.Sys.getVersion()
    return {
        "dolfinx": dolfinx.__version__,
        "ufl": ufl.__version__,
        "petsc": f"{major}.{minor}.{sub}",
        "numpy": np.__version__,
        "python": platform.python_version(),
        "mpi": MPI.Get_library_version().splitlines()[0].strip(),
    }

