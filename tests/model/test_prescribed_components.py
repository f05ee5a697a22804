"""Per-component prescribed values in scenes: ``[prescribed] top = [0.004, "free", -0.03]`` (1 and 2 ranks).

A "free" component carries no condition: the support holds only the numbers, its reaction has only those
components (our own assembly over the held DOFs, tests/model/reaction_reference.py), the free components move,
and a load path blends the held values; bad values are one-line InputErrors naming the value.
"""

from __future__ import annotations

import csv

from mpi4py import MPI

import numpy as np
import pytest
from reaction_reference import assembled_reactions, bc_blocks, bc_dofs

from fenics_coulomb import write_results
from fenics_coulomb.errors import InputError
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene

SCENE = """
[body]
lev = 2
gap = "d3"
clamped = []
[tractions]
[prescribed]
top = [0.004, "free", -0.03]
left = [0.0, "free", "free"]
[roller]
sides = [1]
[friction]
coefficient = 0.3
[[obstacle]]
name = "floor"
type = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[solver]
rtol = 1e-11
"""

HELD = {"top": [0, 2], "left": [0], "sides": [1]}


def contact_forces(problem, result):
    n = problem.V.dofmap.index_map.size_local
    out = np.zeros((n, 3))
    out[problem.model.contact.blocks] = result.contact_force
    return out


def write(comm, path, text):
    if comm.rank == 0:
        path.write_text(text)
    comm.barrier()


def build(comm, path, text):
    """The scene ``text`` written to ``path`` by rank 0 and built on every rank."""
    write(comm, path, text)
    return build_problem(Scene.from_toml(path))


def test_free_components_are_not_held(mpi_tmp_path):
    """The held components take their values bit for bit, the free ones move; each reaction in summary.json equals
    our assembly over the held components of its nodes (1e-10) and is exactly 0 in the free ones; supports, floor
    balance (no applied load)."""
    comm = MPI.COMM_WORLD
    built = build(comm, mpi_tmp_path / "free.toml", SCENE)
    with built.problem as problem:
        uh, result = problem.solve()
        assert result.converged and result.counts["open"] < problem.p
        data = write_results(mpi_tmp_path / "out", problem, result, reactions=built.dirichlet_groups)
        groups = built.dirichlet_groups
        a, L = built.forms
        supports = {name: bc_dofs(groups[name]) for name in groups}
        for name in groups:  # each support holds its components of its nodes (the first boundary per component)
            held = bc_dofs(groups[name])
            assert set(np.unique(held % 3)) <= set(HELD[name]), name
        ours = assembled_reactions(a, L, result.displacement, supports, comm, minus=contact_forces(problem, result))
        n = problem.V.dofmap.index_map.size_local
        u = uh.x.array[: 3 * n].reshape(-1, 3)
        top = bc_blocks(groups["top"])
        top = top[top < n]
        left = bc_blocks(groups["left"])
        left = left[left < n]
        assert np.all(u[top, 0] == 0.004) and np.all(u[top, 2] == -0.03) and np.all(u[left, 0] == 0.0)
        moved_y = comm.allreduce(float(np.abs(u[top, 1]).max(initial=0.0)), op=MPI.MAX)
        moved_left = comm.allreduce(float(np.abs(u[left, 1:]).max(initial=0.0)), op=MPI.MAX)
        assert moved_y > 1e-6 and moved_left > 1e-4
    reactions = {name: np.asarray(v) for name, v in data["reactions"].items()}
    assert set(reactions) == set(HELD)
    scale = np.linalg.norm(reactions["top"])
    for name, value in reactions.items():
        assert np.allclose(value, ours[name], rtol=0, atol=1e-10 * scale), name
        assert np.all(np.delete(value, HELD[name]) == 0.0), name
    assert abs(reactions["left"][0]) > 1e-3 * scale
    assert np.linalg.norm(sum(reactions.values()) + np.asarray(data["contact_force"])) <= 1e-8 * scale


def test_a_load_path_blends_the_held_values(mpi_tmp_path):
    """``[[path.step]] prescribed = { top = [0.008, "free", -0.03] }`` on the command line in two solves: the
    held x value reaches 0.008, the free y component still has no reaction, each step balances."""
    from fenics_coulomb.cli import main

    comm = MPI.COMM_WORLD
    path, out = mpi_tmp_path / "path.toml", mpi_tmp_path / "path"
    write(comm, path, SCENE + '[[path.step]]\n[[path.step]]\nprescribed = { top = [0.008, "free", -0.03] }\n')
    assert main(["--scene", str(path), "--out", str(out), "--no-plots", "--quiet"]) == 0
    comm.barrier()
    rows = list(csv.DictReader((out / "path.csv").read_text().splitlines()))
    assert len(rows) == 2
    for row in rows:
        reactions = {name: np.array([float(row[f"reaction_{name}_{c} [GPa*L^2]"]) for c in "xyz"]) for name in HELD}
        for name, held in HELD.items():
            assert np.all(np.delete(reactions[name], held) == 0.0), name
        contact = np.array([float(row[f"contact_force_{c} [GPa*L^2]"]) for c in "xyz"])
        assert np.linalg.norm(sum(reactions.values()) + contact) <= 1e-8 * np.linalg.norm(reactions["top"])
    first, last = (float(r["reaction_top_x [GPa*L^2]"]) for r in rows)
    assert abs(last) > abs(first) > 0  # the push grew


SHARED = """
[body]
lev = 2
gap = "d1"
clamped = []
contact = ["bottom"]
[material]
young = 70.0
poisson = 0.3
[friction]
coefficient = 0.0
[tractions]
[prescribed]
top = ["free", "free", -0.02]
[roller]
sides = [1]
left = [0]
"""


def test_a_node_on_two_supports_is_held_by_both(mpi_tmp_path):
    """Each component of a node takes the first boundary that holds it: the top's edges with the sides' and the
    left face's rollers keep u_y = 0 and u_x = 0 there (they were released: the edge nodes took the top's condition
    alone). The block, pressed 0.01 onto a frictionless floor through the height 0.99, is then in uniform plane
    strain: σ₃₃ = E/(1 − ν²)·ε₃₃, the top's reaction σ₃₃·2 (exact in Q1, to the solve's accuracy)."""
    comm = MPI.COMM_WORLD
    built = build(comm, mpi_tmp_path / "shared.toml", SHARED)
    with built.problem as problem:
        uh, result = problem.solve()
        assert result.converged
        data = write_results(mpi_tmp_path / "out", problem, result, reactions=built.dirichlet_groups)
        n = problem.V.dofmap.index_map.size_local
        x = problem.V.tabulate_dof_coordinates()[:n]
        u = uh.x.array[: 3 * n].reshape(-1, 3)
        sides = np.isclose(x[:, 1], 0.0) | np.isclose(x[:, 1], 1.0)
        left = np.isclose(x[:, 0], 0.0)
        top = np.isclose(x[:, 2], 1.0)
        assert np.all(u[sides, 1] == 0.0) and np.all(u[left, 0] == 0.0) and np.all(u[top, 2] == -0.02)
        assert comm.allreduce(int(np.sum(sides & top)), op=MPI.SUM) > 0
    strain = -0.01 / 0.99
    expected = 70.0 / (1.0 - 0.3**2) * strain * 2.0
    assert abs(data["reactions"]["top"][2] - expected) <= 1e-6 * abs(expected)
    assert abs(data["peak_pressure"] + expected / 2.0) <= 1e-6 * abs(expected)


@pytest.mark.parametrize(("value", "message"), [
    ('[0.01, "free"]', r"^\[prescribed\] top = \[0.01, 'free'\]: must be a list of 3 entries"),
    ('[0.01, "loose", 0]', r"\[0.01, 'loose', 0\]: must be a list of 3 entries, each a finite number or \"free\""),
    ('["free", "free", "free"]', r"at least one a number"),
    ('[nan, "free", "free"]', r"\[nan, 'free', 'free'\]: must be"),
    ('[inf, 0, 0]', r"\[inf, 0, 0\]: must be"),
    ('[true, "free", "free"]', r"\[True, 'free', 'free'\]: must be"),
    ('"free"', r"= 'free': must be"),
    ('[0.01, "FREE", 0]', r"must be a list of 3 entries"),
])
def test_bad_per_component_values_are_one_line_errors(mpi_tmp_path, value, message):
    comm = MPI.COMM_WORLD
    path = mpi_tmp_path / "bad.toml"
    write(comm, path, SCENE.replace('top = [0.004, "free", -0.03]', f"top = {value}"))
    with pytest.raises(InputError, match=message) as err:
        Scene.from_toml(path)
    assert "\n" not in str(err.value)


def test_a_path_step_may_not_change_which_components_are_free(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    path = mpi_tmp_path / "bad_path.toml"
    write(comm, path, SCENE + '[[path.step]]\nprescribed = { top = [0.008, 0.0, -0.03] }\n')
    with pytest.raises(InputError, match=r"^\[\[path.step\]\] 1 prescribed displacement on 'top' = \[0.008, 0.0, "
                       r"-0.03\]: must leave the same components free as \[prescribed\] top"):
        Scene.from_toml(path)
