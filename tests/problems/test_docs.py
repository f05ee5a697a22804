"""The README's Python API example (run verbatim) and the API demo, on 1 and 2 ranks."""

from __future__ import annotations

import json
import re
import runpy
from pathlib import Path

from mpi4py import MPI

import numpy as np

from fenics_coulomb.cli import main
from fenics_coulomb.model.checks import physics_residuals

ROOT = Path(__file__).resolve().parents[2]


def readme_example(index: int = 0) -> str:
    """The ``index``-th ``python`` code block of the README's "Python API" section."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## The Python API", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "the README's Python API section has no python block"
    return blocks[index]


def test_readme_example(mpi_tmp_path, monkeypatch):
    """The example runs as printed, converges, touches the plane and passes the physics checks."""
    monkeypatch.chdir(mpi_tmp_path)
    namespace: dict = {}
    code = readme_example()
    exec(compile(code, "README.md", "exec"), namespace)
    result = namespace["result"]
    assert result.converged and result.counts["stick"] + result.counts["slip"] > 0
    assert (mpi_tmp_path / "block.xdmf").exists()
    problem_cls = namespace["ContactProblem"]
    with problem_cls(namespace["a"], namespace["L"], bcs=[namespace["bc"]],
                     contact=(namespace["facet_tags"], [namespace["BOTTOM"]]), friction=0.23,
                     settings={"rtol": 1e-11}, petsc_options_prefix="check_") as problem:
        uh, _ = problem.solve()
        checks = physics_residuals(problem.model, uh.x.petsc_vec.array)
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "reaction_balance"):
        assert checks[key] < 1e-8, (key, checks[key])


def test_readme_press_a_sphere(mpi_tmp_path, monkeypatch, capsys):
    """The second example (top-level names only): the sphere's force balances the support's reaction, the
    contact radius is Hertz's √(Rδ) within a cell, the result set is written."""
    monkeypatch.chdir(mpi_tmp_path)
    namespace: dict = {}
    exec(compile(readme_example(1), "README.md", "exec"), namespace)
    force, reaction, radius = namespace["force"], namespace["reaction"], namespace["radius"]
    assert force[2] < 0 and np.linalg.norm(force + reaction) <= 1e-6 * np.linalg.norm(reaction)
    assert abs(radius - np.sqrt(0.5 * 0.01)) <= 1 / 24
    assert (mpi_tmp_path / "press" / "summary.json").exists()
    out = capsys.readouterr().out
    assert MPI.COMM_WORLD.rank != 0 or out.startswith("force -")


def test_readme_first_scene(mpi_tmp_path):
    """The README's first scene, written to a file and run with the command it shows, exits 0 with a contact
    patch of at least 30 nodes in contact."""
    text = (ROOT / "README.md").read_text().split("## A first scene", 1)[1].split("\n## ", 1)[0]
    (toml,) = re.findall(r"```toml\n(.*?)```", text, flags=re.S)
    scene = mpi_tmp_path / "sphere.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene.write_text(toml)
    MPI.COMM_WORLD.barrier()
    assert main(["--scene", str(scene), "--out", str(mpi_tmp_path / "sphere"), "--quiet", "--no-plots"]) == 0
    summary = json.loads((mpi_tmp_path / "sphere" / "summary.json").read_text())
    assert summary["contact_nodes"] >= 30 and summary["obstacles"]["ball"]["contact_nodes"] == summary["contact_nodes"]


def test_api_orthotropic_demo(mpi_tmp_path, capsys):
    """demos/api_orthotropic.py (coarse mesh) converges with contact, stick and slip, passes the physics checks
    and writes its ParaView and JSON output."""
    out = mpi_tmp_path / "demo"
    namespace = runpy.run_path(str(ROOT / "demos" / "api_orthotropic.py"), run_name="demo")
    assert namespace["main"](["--h", "0.08", "--out", str(out)]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and summary["ranks"] == MPI.COMM_WORLD.size
    counts = summary["state_counts"]
    assert counts["stick"] + counts["slip"] > 0 and counts["open"] > 0 and sum(counts.values()) == summary["p"]
    checks = summary["checks"]
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction"):
        assert checks[key] < 1e-7, (key, checks[key])
    assert checks["reaction_balance"] < 1e-6
    # pressed down: the plane pushes up; dragged along +x1: friction pulls back
    assert checks["contact_resultant"][2] > 0 and checks["contact_resultant"][0] < 0
    assert (out / "solution.xdmf").exists() and (out / "solution.h5").exists()
    if MPI.COMM_WORLD.rank == 0:
        assert "converged" in capsys.readouterr().out
