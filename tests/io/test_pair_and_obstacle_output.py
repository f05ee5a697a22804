"""A contact pair together with a rigid obstacle, written as a user writes it (1 and 2 ranks).

An elastic hemisphere (its flat face pushed down and sideways) on an elastic block held by its clamped sides,
one gmsh mesh with two volumes (meshes/hemisphere_on_block.py); the block's bottom is the contact boundary of a
rigid floor, either just below it (it carries part of the push) or far below (it touches nothing). Checked:
the real command writes the whole result set (exit 0, every file summary.json lists), ``problem.report()`` and
``write_results()`` work on the same scene, and the forces balance — per body (the hemisphere: the pair's force
on it + its support's reaction = 0; the block: the pair's force on it + the floor's + its support's = 0) and in
total (reactions + obstacle forces + applied load = 0, the pair's forces being internal).
"""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb import write_results
from fenics_coulomb.cli import main
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene

ROOT = Path(__file__).resolve().parents[2]
from meshes import hemisphere_on_block  # noqa: E402

SCENE = """
[body]
shape = "mesh"
mesh = "{mesh}"
clamped = ["block_sides"]
contact = ["block_bottom"]

[boundaries]
block_top = 1
block_bottom = 2
block_sides = 3
curved = 4
flat = 5

[bodies]
block = 1
hemisphere = 2

[material]
young = 70.0
poisson = 0.3

[material.hemisphere]
young = 200.0
poisson = 0.25

[prescribed]
flat = [0.004, 0.0, -0.02]

[tractions]

[[contact_pair]]
slave = "curved"
master = "block_top"
friction = 0.3

[[obstacle]]
type = "plane"
name = "floor"
point = [0.0, 0.0, {floor}]
normal = [0.0, 0.0, 1.0]

[solver]
rtol = 1e-11
"""

#: The floor just below the block's bottom (x3 = −2: it carries part of the push) or far below (no contact).
FLOORS = {"touching": -2.000001, "far": -3.0}


@pytest.fixture(scope="module")
def mesh_file(tmp_path_factory) -> Path:
    """A coarse hemisphere-on-block mesh, written by rank 0 into a directory all ranks share."""
    comm = MPI.COMM_WORLD
    path = Path(comm.bcast(str(tmp_path_factory.mktemp("pair_floor")) if comm.rank == 0 else None, root=0))
    if comm.rank == 0:
        hemisphere_on_block.build(contact=0.12, path=path / "hob.msh", size=0.8)
    comm.barrier()
    return path / "hob.msh"


def scene_file(mesh: Path, floor: str) -> Path:
    path = mesh.parent / f"{floor}{MPI.COMM_WORLD.size}.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(SCENE.format(mesh=mesh, floor=FLOORS[floor]))
    MPI.COMM_WORLD.barrier()
    return path


@pytest.mark.parametrize("floor", sorted(FLOORS))
def test_the_command_writes_a_pair_and_an_obstacle(mesh_file, floor):
    """Exit 0 and every file of the result set; summary.json's pair forces are equal and opposite and the
    supports, the floor and the applied load balance (the contact force on the bodies is the floor's: a pair's
    forces are internal; it counted the pair's slave side too, and the written balance failed by the pair's
    force)."""
    out = mesh_file.parent / f"out_{floor}{MPI.COMM_WORLD.size}"
    assert main(["--scene", str(scene_file(mesh_file, floor)), "--out", str(out), "--no-plots", "--quiet"]) == 0
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    assert data["converged"]
    assert all((out / name).is_file() for name in data["files"])
    assert {"solution.xdmf", "solution.h5", "convergence.csv", "summary.json"} <= set(data["files"])
    (pair,) = data["contact_pairs"]
    slave, master = np.array(pair["force_on_slave_body"]), np.array(pair["force_on_master_body"])
    assert slave[2] > 0 and np.linalg.norm(slave + master) <= 1e-8 * np.linalg.norm(slave)
    reactions = {name: np.array(v) for name, v in data["reactions"].items()}
    assert set(reactions) == {"block_sides", "flat"}
    floor_force = np.array(data["contact_force"])
    assert np.allclose(floor_force, data["obstacles"]["floor"]["force"], rtol=1e-12, atol=1e-15)
    assert data["physics_checks"]["reaction_balance"] <= 1e-7
    if floor == "touching":
        assert floor_force[2] > 1e-6 * np.linalg.norm(slave)
    else:  # no floor node in contact
        assert np.abs(floor_force).max() <= 1e-12 * np.linalg.norm(slave)
    total = sum(reactions.values()) + floor_force + np.array(data["applied_load"])
    assert np.linalg.norm(total) <= 1e-7 * np.linalg.norm(slave)


def test_report_and_write_results_with_a_pair_and_an_obstacle(mesh_file, mpi_tmp_path):
    """The API on the same scene (the floor touching): report() balances per body and in total; write_results()
    writes the same reactions and pair forces."""
    built = build_problem(Scene.from_toml(scene_file(mesh_file, "touching")))
    with built.problem as problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result, reactions=built.dirichlet_groups)
        data = write_results(mpi_tmp_path / "set", problem, result, reactions=built.dirichlet_groups)
    (pair,) = report.pair_forces
    slave, master = np.array(pair["force_on_slave_body"]), np.array(pair["force_on_master_body"])
    floor_force = report.obstacle_forces["floor"]
    sides, flat = report.reactions["block_sides"], report.reactions["flat"]
    scale = np.linalg.norm(slave)
    assert slave[2] > 0 and floor_force[2] > 0 and pair["slave_equilibrium"] < 1e-7
    assert np.linalg.norm(slave + flat) <= 1e-7 * scale  # the hemisphere: the pair's push and its support
    assert np.linalg.norm(master + floor_force + sides) <= 1e-7 * scale  # the block
    assert np.linalg.norm(sides + flat + floor_force + report.applied_load) <= 1e-7 * scale
    # the pair's forces act between the bodies: the contact force on the bodies is the floor's, and it balances
    assert np.array_equal(report.total_force, floor_force) and pair["name"] == "pair 1"
    assert np.linalg.norm(sum(report.reactions.values()) + report.total_force + report.applied_load) <= 1e-7 * scale
    assert np.allclose(data["contact_force"], floor_force, rtol=1e-12, atol=1e-14 * scale)
    assert data["physics_checks"]["reaction_balance"] <= 1e-7
    assert np.allclose(data["reactions"]["block_sides"], sides, rtol=1e-12, atol=1e-14 * scale)
    assert np.allclose(data["contact_pairs"][0]["force_on_master_body"], master, rtol=1e-12, atol=1e-14 * scale)
    assert all((mpi_tmp_path / "set" / name).is_file() for name in data["files"])


def test_path_history_per_pair_and_obstacle(mesh_file, mpi_tmp_path):
    """The pair beside the touching floor as a 2-step path: path.csv has the columns of the floor and of the pair
    (units in the headers); per row the groups' stick/slip nodes add up to the row's, each group obeys Coulomb
    (|Σ tᵢ| ≤ F Σ λᵢ), the floor's normal force is its force's x₃ component (a plane); the last row equals
    summary.json's groups."""
    import csv

    out = mpi_tmp_path / "path"
    assert main(["--scene", str(scene_file(mesh_file, "touching")), "--steps", "2", "--out", str(out), "--quiet",
                 "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    with open(out / "path.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    units = {"normal_force": " [GPa*L^2]", "tangential_force": " [GPa*L^2]", "peak_pressure": " [GPa]",
             "contact_area": " [L^2]", "contact_nodes": "", "stick": "", "slip": ""}
    friction = {"floor": summary["scene"]["friction"]["coefficient"], "pair 1": 0.3}
    for row in rows:
        groups = {name: {key: float(row[f"{key}_{name}{unit}"]) for key, unit in units.items()} for name in friction}
        for key in ("stick", "slip"):
            assert sum(g[key] for g in groups.values()) == int(row[key])
        for name, g in groups.items():
            assert g["normal_force"] > 0 and g["contact_nodes"] == g["stick"] + g["slip"]
            assert g["tangential_force"] <= friction[name] * g["normal_force"] * (1 + 1e-8)
    last = summary["steps"][-1]["groups"]
    assert last["floor"]["normal_force"] == float(rows[-1]["normal_force_floor [GPa*L^2]"])
    floor = summary["obstacles"]["floor"]
    assert floor["normal_force"] == pytest.approx(floor["force"][2], rel=1e-12)
    assert floor["tangential_force"] == pytest.approx(np.hypot(*floor["force"][:2]), rel=1e-9, abs=1e-15)
    (pair,) = summary["contact_pairs"]
    assert pair["normal_force"] == last["pair 1"]["normal_force"] and pair["stick"] == last["pair 1"]["stick"]
