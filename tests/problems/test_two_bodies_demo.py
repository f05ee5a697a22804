"""demos/two_bodies.py on coarse non-matching meshes (1 and 2 ranks): a block pressed onto a larger block, then
sheared in two steps. Every step converges and obeys the physics; each body's force from its own residual is
equal and opposite; the shear is carried by friction (|f₁| ≤ F f₃, growing with the shear); the XDMF series
has one grid per step with every field on both bodies, and the written master reaction balances the slave
force."""

from __future__ import annotations

import json
import runpy
import xml.etree.ElementTree as ET
from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FIELDS = {"displacement", "contact_state", "contact_pressure", "contact_force", "tangential_force", "stress",
          "von_mises", "contact_traction", "gap",
          "contact_normal", "master_reaction", "body"}


def test_two_bodies_demo(mpi_tmp_path, capsys):
    demo = runpy.run_path(str(ROOT / "demos" / "two_bodies.py"), run_name="demo")
    out = mpi_tmp_path / "two_bodies"
    if MPI.COMM_WORLD.rank == 0:
        out.mkdir()
    MPI.COMM_WORLD.barrier()
    friction = 0.3
    steps = demo["run"](out, n_lower=(4, 4, 2), n_upper=(3, 3, 2), press=0.002, shears=(0.001, 0.002),
                        friction=friction, settings={"rtol": 1e-11})
    MPI.COMM_WORLD.barrier()
    assert len(steps) == 3
    shear_force = []
    for step in steps:
        assert step["converged"], step
        for key, value in step["checks"].items():
            assert value < 1e-8, (step["step"], key, value)
        (pair,) = step["pairs"]
        f_s, f_m = np.array(pair["force_on_slave_body"]), np.array(pair["force_on_master_body"])
        assert pair["contact_nodes"] == 16 and pair["prescribed_nodes"] == 0  # the 4 × 4 bottom nodes
        assert np.linalg.norm(f_s + f_m) <= 1e-8 * np.linalg.norm(f_s) and pair["balance"] < 1e-8
        assert np.allclose(f_s, pair["contact_force"], rtol=0, atol=1e-9 * np.linalg.norm(f_s))
        assert f_s[2] > 0 and abs(f_s[0]) <= friction * f_s[2] * (1 + 1e-9)
        shear_force.append(-f_s[0])
    # dragged along +x1: the large block holds the small one back, more with more shear
    assert abs(shear_force[0]) < 1e-6 * steps[0]["pairs"][0]["force_on_slave_body"][2]
    assert 0 < shear_force[1] < shear_force[2]
    assert steps[-1]["state_counts"]["stick"] + steps[-1]["state_counts"]["slip"] == 16

    root = ET.parse(out / "solution.xdmf").getroot()
    grids = root.find("Domain/Grid").findall("Grid")
    assert [float(g.find("Time").get("Value")) for g in grids] == [1.0, 2.0, 3.0]
    summary = json.loads((out / "summary.json").read_text())
    assert [s["pairs"] for s in summary["steps"]] == [s["pairs"] for s in steps]
    with h5py.File(out / "solution.h5", "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        for grid, step in zip(grids, steps, strict=True):
            items = {a.get("Name"): a.find("DataItem").text.split(":")[1] for a in grid.findall("Attribute")}
            assert set(items) == FIELDS
            data = {name: h5[dataset][:] for name, dataset in items.items()}
            body = data["body"]
            assert set(np.unique(body)) == {1, 2} and np.all(x[body == 2, 2] >= -1e-12)
            slave = data["contact_state"] >= 0
            assert slave.sum() == 16 and np.allclose(x[slave, 2], 0.0) and np.all(body[slave] == 2)
            f_s = np.array(step["pairs"][0]["force_on_slave_body"])
            reaction = data["master_reaction"]
            assert np.all(body[np.any(reaction != 0, axis=1)] == 1)
            assert np.allclose(reaction.sum(axis=0), -f_s, rtol=0, atol=1e-9 * np.linalg.norm(f_s))
            assert data["gap"][slave].min() >= -1e-10
    if MPI.COMM_WORLD.rank == 0:
        printed = capsys.readouterr().out
        assert printed.count("force on the small block") == 3
