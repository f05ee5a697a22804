"""Scenes of an indentation study through the real command (1 and 2 ranks): [[obstacle]], [prescribed],
[roller], an empty [tractions], reactions and the contact force in summary.json, the new point fields."""

from __future__ import annotations

import json

from mpi4py import MPI

import h5py
import numpy as np
import pytest
from conftest import read_solution

from fenics_coulomb.cli import EXIT_INPUT, main

SCENE = """
[body]
lev = 2
gap = "d3"
clamped = []
[tractions]
[prescribed]
top = [0.0, 0.0, -0.03]
[roller]
left = [0]
[friction]
coefficient = 0.3
[[obstacle]]
name = "floor"
type = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.01, 0.0, 1.0]
"""


def write(path, text):
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()


def test_pressed_on_a_tilted_plane(mpi_tmp_path, capsys):
    """The top pressed down by a prescribed displacement, a roller on the left, no tractions, a tilted floor:
    the prescribed and held values are met, reactions + contact force balance (no applied load), the contact
    force points along the floor's normal side, and the point fields are consistent (gap >= 0 on contact nodes,
    contact_normal = the floor's normal, traction·n >= 0)."""
    scene, out = mpi_tmp_path / "press.toml", mpi_tmp_path / "out"
    write(scene, SCENE)
    assert main(["--scene", str(scene), "--out", str(out), "--no-plots", "--rtol", "1e-10"]) == 0
    printed = capsys.readouterr().out
    if MPI.COMM_WORLD.rank == 0:
        assert "total contact force on the body" in printed and "reactions: top" in printed
    data = json.loads((out / "summary.json").read_text())
    force = np.asarray(data["contact_force"])
    reactions = {k: np.asarray(v) for k, v in data["reactions"].items()}
    assert set(reactions) == {"top", "left"}
    assert np.linalg.norm(force + sum(reactions.values())) < 1e-8 * np.linalg.norm(force)
    normal = np.array([0.01, 0.0, 1.0]) / np.linalg.norm([0.01, 0.0, 1.0])
    assert force @ normal > 0 and reactions["top"][2] < 0
    x, u = read_solution(out)
    top = np.isclose(x[:, 2], 1.0)
    assert np.allclose(u[top], [0.0, 0.0, -0.03], atol=1e-14)
    left = np.isclose(x[:, 0], 0.0) & ~top
    assert np.allclose(u[left, 0], 0.0, atol=1e-14) and np.abs(u[left, 1:]).max() > 0
    with h5py.File(out / "solution.h5", "r") as h5:
        gap = h5["Function/gap/0"][:].ravel()
        n = h5["Function/contact_normal/0"][:]
        traction = h5["Function/contact_traction/0"][:]
        tangential = h5["Function/tangential_force/0"][:]
        state = h5["Function/contact_state/0"][:].ravel()
    contact = state >= 0
    assert np.allclose(n[contact], normal, atol=1e-14) and np.allclose(n[~contact], 0.0)
    assert gap[contact].min() > -1e-9 and np.any(gap[contact] > 1e-4)
    assert (traction[contact] @ normal).min() > -1e-9 and (traction[contact] @ normal).max() > 0
    assert np.abs(tangential[contact] @ normal).max() < 1e-12 * np.abs(tangential).max()


@pytest.mark.parametrize(("table", "message"), [
    ('type = "plane"\npoint = [0, 0, 0]\nnormal = [0, 0, 0]', "normal"),
    ('type = "sphere"\ncenter = [1, 0.5, -1]\nradius = -1.0', "radius"),
    ('type = "torus"', "type"),
    ('name = "ball"\ntype = "sphere"\ncenter = [1.0, 0.5, -0.4]\nradius = 0.5', "'ball'.*overlaps the body"),
])
def test_bad_obstacle_exits_2(mpi_tmp_path, capsys, table, message):
    """Bad obstacles → exit 2 with one line naming the value (an overlap at the scene position names the
    obstacle and the deepest node)."""
    scene = mpi_tmp_path / "bad.toml"
    write(scene, f'[body]\nlev = 1\n[[obstacle]]\n{table}\n')
    assert main(["--scene", str(scene), "--out", str(mpi_tmp_path / "out"), "--no-plots"]) == EXIT_INPUT
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        import re
        assert re.search(message, lines[0]), lines[0]


def test_traction_expressions(mpi_tmp_path):
    """Tractions as expressions in x1, x2, x3: the load's resultant equals the exact integral of a linear
    traction over the top face (2 × 1), and a constant written as an expression equals the constant."""
    from fenics_coulomb.scenes.builder import build_problem
    from fenics_coulomb.scenes.scene import Scene

    def resultant(tractions: str) -> np.ndarray:
        scene = mpi_tmp_path / "expr.toml"
        write(scene, f'[body]\nlev = 1\n[tractions]\n{tractions}\n')
        with build_problem(Scene.from_toml(scene), MPI.COMM_WORLD).problem as problem:
            return problem.model.total_load()

    linear = resultant('top = [0, "0.1*x2", "-(1 + 0.5*(x1 - 1))"]')
    assert np.allclose(linear, [0.0, 0.1 * 2 * 0.5, -2.0], rtol=1e-12, atol=1e-14)
    assert np.allclose(resultant('top = ["0.2", 0, -1.0]'), resultant("top = [0.2, 0, -1.0]"), rtol=1e-14)
    with pytest.raises(Exception, match="unknown name 'x4'"):
        Scene.from_toml(write(mpi_tmp_path / "e.toml", '[body]\nlev = 1\n[tractions]\ntop = [0, 0, "x4"]\n')
                        or mpi_tmp_path / "e.toml")
