"""The README's and docs/'s examples run as printed, on 1 and 2 ranks: the README's Python API example, its first
scene, the API reference's press of a sphere (docs/api.md), every scene and command of docs/scenes.md and its
flag synopsis against the parser, and the API demo."""

from __future__ import annotations

import json
import re
import runpy
import shlex
import textwrap
from pathlib import Path

from mpi4py import MPI

import numpy as np

import pytest

from fenics_coulomb.cli import build_parser, main
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.model.dof_values import owned_values

ROOT = Path(__file__).resolve().parents[2]


def readme_example(index: int = 0) -> str:
    """The ``index``-th ``python`` code block of the README's "Python API" section."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## The Python API", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "the README's Python API section has no python block"
    return blocks[index]


def doc_blocks(name: str, language: str) -> list[str]:
    """The ``language`` code blocks of ``docs/<name>``, dedented (a block may sit in a list item)."""
    text = (ROOT / "docs" / name).read_text()
    return [textwrap.dedent(block) for block in
            re.findall(rf"^ *```{language}\n(.*?)^ *```", text, flags=re.S | re.M)]


def doc_commands(block: str) -> list[list[str]]:
    """The fenics_coulomb arguments of each command of a ``sh`` block (continuation lines joined; the launcher
    ``container/run mpirun -n N python3 -m fenics_coulomb`` stripped: the test runs on its own ranks)."""
    commands = []
    for line in block.replace("\\\n", " ").splitlines():
        words = shlex.split(line, comments=True)
        if words:
            assert "fenics_coulomb" in words, f"docs/scenes.md: not a fenics_coulomb command: {line}"
            commands.append(words[words.index("fenics_coulomb") + 1:])
    return commands


@pytest.fixture
def doc_directory(mpi_tmp_path, monkeypatch):
    """A working directory in which the docs' relative paths (demos/, meshes/, out/) resolve as in the
    repository's root, with the outputs in a temporary directory."""
    if MPI.COMM_WORLD.rank == 0:
        for name in ("demos", "meshes"):
            (mpi_tmp_path / name).symlink_to(ROOT / name)
    MPI.COMM_WORLD.barrier()
    monkeypatch.chdir(mpi_tmp_path)
    return mpi_tmp_path


SCENES = doc_blocks("scenes.md", "toml")
COMMANDS = [command for block in doc_blocks("scenes.md", "sh") for command in doc_commands(block)]


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_scenes_doc_has_examples():
    """The reference shows scenes and commands (a change of the block markup would silently drop them)."""
    assert len(SCENES) >= 5 and len(COMMANDS) >= 3


def test_scenes_doc_commands(doc_directory):
    """Every command of docs/scenes.md, in order (a later one may read an earlier one's output), exits 0."""
    for command in COMMANDS:
        assert main([*command, "--quiet", "--no-plots"]) == 0, command


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_scenes_doc_synopsis():
    """The flag synopsis of docs/scenes.md names every flag of the parser and no other."""
    (synopsis,) = doc_blocks("scenes.md", "text")
    flags = synopsis.split("fenics_coulomb", 1)[1]  # after the program's name (python3 -m ...)
    shown = set(re.findall(r"(?<![\w-])(--?[a-z][a-z-]*)", flags)) - {"-coulomb"}
    parser = {flag for action in build_parser()._actions for flag in action.option_strings} - {"-h", "--help"}
    assert shown == parser, (sorted(shown - parser), sorted(parser - shown))


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
        checks = physics_residuals(problem.model, owned_values(uh))
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "reaction_balance"):
        assert checks[key] < 1e-8, (key, checks[key])


def test_api_doc_press_a_sphere(mpi_tmp_path, monkeypatch, capsys):
    """docs/api.md's example (top-level names only): the sphere's force balances the support's reaction, the
    contact radius is Hertz's √(Rδ) within a cell, the result set is written."""
    monkeypatch.chdir(mpi_tmp_path)
    namespace: dict = {}
    (code,) = doc_blocks("api.md", "python")
    exec(compile(code, "docs/api.md", "exec"), namespace)
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


@pytest.mark.parametrize("index", range(len(SCENES)))
def test_scenes_doc_scene(doc_directory, index):
    """Every scene of docs/scenes.md, written to a file and run (its path too), solves and passes the physics
    checks (exit 0), presses its body into contact (every scene pushes an obstacle, a prescribed face or a load
    toward the contact surface) and writes its result set. Last in this file: after the two-bodies scene on 2
    ranks, later solves in the same process ran 5-25x slower (up to the test timeout)."""
    scene = doc_directory / f"scene{index}.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene.write_text(SCENES[index])
    MPI.COMM_WORLD.barrier()
    out = doc_directory / "out" / f"scene{index}"
    assert main(["--scene", scene.name, "--out", str(out), "--quiet", "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    counts = summary["state_counts"]
    assert summary["converged"] and counts["stick"] + counts["slip"] > 0, counts
