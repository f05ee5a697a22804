"""Histories per obstacle and per contact pair: path.csv's columns (units in the headers) and summary.json's group
entries, on the paper's path (one plane), the rolling demo and a contact pair beside a floor (1 and 2 ranks).

Physics asserted: against a plane the normal force is the contact force's normal component and the tangential
force its tangential length; for any group |Σ tᵢ| ≤ Σ |tᵢ| ≤ F Σ λᵢ (Coulomb at every node); the groups' stick
and slip nodes add up to the step's counts; the last row equals summary.json."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb.cli import main

ROOT = Path(__file__).resolve().parents[2]
COLUMNS = {"normal_force": " [GPa*L^2]", "tangential_force": " [GPa*L^2]", "peak_pressure": " [GPa]",
           "contact_area": " [L^2]", "contact_nodes": "", "stick": "", "slip": ""}


def run(out: Path, *args: str) -> tuple[list[dict[str, str]], dict]:
    assert main([*args, "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    with open(out / "path.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return rows, json.loads((out / "summary.json").read_text())


def group(row: dict[str, str], name: str) -> dict[str, float]:
    return {key: float(row[f"{key}_{name}{unit}"]) for key, unit in COLUMNS.items()}


def test_plane_groups_are_the_force_components(mpi_tmp_path):
    """The paper's path against its plane (n = e₃): N = F₃, T = |(F₁, F₂)| at every step."""
    rows, summary = run(mpi_tmp_path / "d3", "--scene", str(ROOT / "demos" / "scenes" / "d3_L2_path.toml"),
                        "--lev", "1")
    assert len(rows) == len(summary["steps"]) > 1
    for row in rows:
        g = group(row, "plane 1")
        force = np.array([float(row[f"contact_force_{c} [GPa*L^2]"]) for c in "xyz"])
        assert g["normal_force"] == pytest.approx(force[2], rel=1e-12)
        assert g["tangential_force"] == pytest.approx(np.hypot(*force[:2]), rel=1e-10, abs=1e-14)
        assert (g["stick"], g["slip"]) == (int(row["stick"]), int(row["slip"]))
        assert g["contact_nodes"] == g["stick"] + g["slip"]
        assert g["tangential_force"] <= 0.23 * g["normal_force"] * (1 + 1e-8)
    last = group(rows[-1], "plane 1")
    assert last["peak_pressure"] == summary["peak_pressure"] and last["contact_area"] == summary["contact_area"]
    assert summary["obstacles"]["plane 1"]["normal_force"] == last["normal_force"]


def test_rolling_demo_has_the_roller_history(mpi_tmp_path):
    """The rolling demo (its own lev 4): the roller's columns at every step, Coulomb's bound F = 0.5 on the group,
    nodes in contact; summary.json's steps carry the same numbers."""
    rows, summary = run(mpi_tmp_path / "roll", "--scene", str(ROOT / "demos" / "scenes" / "roller_rolling_path.toml"))
    assert [s["groups"]["roller"]["normal_force"] for s in summary["steps"]] == [
        group(row, "roller")["normal_force"] for row in rows]
    for row in rows:
        g = group(row, "roller")
        assert g["normal_force"] > 0 and g["contact_nodes"] > 0 and g["peak_pressure"] > 0
        assert g["tangential_force"] <= 0.5 * g["normal_force"] * (1 + 1e-8)
        assert (g["stick"], g["slip"]) == (int(row["stick"]), int(row["slip"]))


def test_the_path_summary_and_its_initial_state(mpi_tmp_path):
    """The cylinder drag demo cut to its press (lev 1): summary.json has the last step's applied load and the
    balance of the written forces, ``timings_s.total`` is the solves' time over the path (it was the last solve's
    while the phases added up), and the t = 0 grid's gap is the distance to the cylinder at rest as obstacles.h5
    draws it (it was measured to the cylinder already pressed 0.01 in: gap −0.01 on open nodes)."""
    import h5py

    comm = MPI.COMM_WORLD
    text = (ROOT / "demos" / "scenes" / "cylinder_drag_path.toml").read_text()
    scene = mpi_tmp_path / "press.toml"
    if comm.rank == 0:
        scene.write_text(text[: text.index("[[path.step]]           # 2")])
    comm.barrier()
    out = mpi_tmp_path / "press"
    rows, summary = run(out, "--scene", str(scene), "--lev", "1")
    assert len(rows) == 2 and summary["applied_load"] == summary["steps"][-1]["applied_load"]
    assert summary["physics_checks"]["reaction_balance"] <= 1e-8
    assert summary["timings_s"]["total"] == pytest.approx(sum(s["wall_time_s"] for s in summary["steps"]))
    assert summary["timings_s"]["total"] >= summary["timings_s"]["ksp"]
    if comm.rank == 0:
        with h5py.File(out / "solution.h5", "r") as h5:
            x = h5["Mesh/mesh/geometry"][:]
            gap, state = h5["Function/gap/0"][:].ravel(), h5["Function/contact_state/0"][:].ravel()
        top = state >= 0
        axis = np.array([1.0, 0.5, 1.5])
        distance = np.hypot(x[top, 0] - axis[0], x[top, 2] - axis[2]) - 0.5
        assert np.allclose(gap[top], distance, rtol=0, atol=1e-12) and gap[top].min() >= -1e-12
