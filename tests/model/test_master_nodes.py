"""The master nodes of a pair against the slave body (fenics_coulomb/model/pairs/master_nodes.py).

A one-pass pair keeps its slave nodes out of the master body, not the master's nodes out of the slave body: the
slide-off blocks pressed with the roles swapped (the larger lower block's top the slave) ended with the upper
block's border inside the lower block and the normal force −16 % (node-to-surface) or −76 % (mortar) below the
right roles' 0.738, exit 0 and no word. Now `master_penetration` is reported and warned; checked here against a
brute force of its own (every master node against every slave triangle) and on the right roles (0); on curved
surfaces (the facetting allowance) by the shrink fit of tests/problems/test_verification.py."""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import pytest

import fenics_coulomb.model.pairs.master_nodes as master_nodes
from fenics_coulomb.cli import main
from fenics_coulomb.model.checks import MASTER_WARNING
from fenics_coulomb.model.pairs.projection import Surface
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene

ROOT = Path(__file__).resolve().parents[2]
PRESS = (ROOT / "demos" / "scenes" / "slide_off.toml").read_text().split("[[path.step]]")[0].replace(
    '"../../meshes/', f'"{ROOT}/meshes/')


def press(slave: str, master: str, method: str) -> str:
    """The slide-off blocks pressed 0.01, static, with the given roles and method."""
    text = PRESS.replace('slave = "upper_bottom"', f'slave = "{slave}"').replace(
        'master = "lower_top"', f'master = "{master}"').replace('method = "mortar"', f'method = "{method}"')
    assert f'slave = "{slave}"' in text and f'method = "{method}"' in text
    return text


def write(path: Path, text: str) -> Path:
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    return path


def test_turn_angles_of_a_fold_and_a_plane():
    """Two triangles folded by θ about their common edge: α = θ at the edge's vertices, 0 at the others; coplanar
    triangles: 0 everywhere."""
    theta = 0.3
    tip = np.array([0.5, -np.cos(theta), np.sin(theta)])  # the second triangle turned by θ about the x1 axis
    for second, expected in ((tip, theta), (np.array([0.5, -1.0, 0.0]), 0.0)):
        X = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1.0, 0.0]],
                      [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], second]])
        surface = Surface(X, np.array([[0, 1, 2], [1, 0, 3]], dtype=np.int64), np.ones(2))
        vertices, alpha = master_nodes.turn_angles(surface)
        assert list(vertices) == [0, 1, 2, 3]
        assert np.allclose(alpha, [expected, expected, 0.0, 0.0], atol=1e-12), alpha


def brute_force_depth(problem, slave_tag: int, master_tag: int) -> float:
    """The deepest master node inside the slave body in X + u: every master node against every slave triangle,
    sampled densely (its nearest sample c picks the triangle), the depth −(y − c)·n with that triangle's normal
    pointing out of the slave body (up: the lower block's top) where c lies inside the slave surface (not on its
    border)."""
    model = problem.model
    V = model.V
    tdim = V.mesh.topology.dim
    u = model.ghosted(problem.u.x.array[:V.dofmap.index_map.size_local * 3]).reshape(-1, 3)
    x = V.tabulate_dof_coordinates() + u
    tags = model.facet_tags

    def facets_of(tag: int) -> np.ndarray:
        V.mesh.topology.create_connectivity(tdim - 1, tdim)
        # a few hundred facets, one at a time (not collective: remote=False): the closure's DOF blocks of each
        blocks = [np.sort(dolfinx.fem.locate_dofs_topological(V, tdim - 1, np.array([f], dtype=np.int32),
                                                              remote=False)) for f in tags.find(tag)]
        return np.asarray(blocks, dtype=np.int64).reshape(-1, 3)

    slave = np.concatenate(MPI.COMM_WORLD.allgather(x[facets_of(slave_tag)].reshape(-1, 3, 3)))
    master_blocks = np.unique(facets_of(master_tag))
    owned = master_blocks[master_blocks < V.dofmap.index_map.size_local]
    y = x[owned]
    lo, hi = slave.reshape(-1, 3).min(axis=0), slave.reshape(-1, 3).max(axis=0)
    # dense samples of every slave triangle (barycentric grid) for the closest point
    k = 60
    a, b = np.meshgrid(np.linspace(0, 1, k + 1), np.linspace(0, 1, k + 1))
    keep = a + b <= 1 + 1e-12
    lam = np.stack([1 - a[keep] - b[keep], a[keep], b[keep]], axis=1)
    samples = np.einsum("sv,tvi->tsi", lam, slave).reshape(-1, 3)
    normals = np.cross(slave[:, 1] - slave[:, 0], slave[:, 2] - slave[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    normals *= np.sign(normals[:, 2])[:, None]  # out of the lower block: up
    owner = np.repeat(np.arange(slave.shape[0]), lam.shape[0])
    depth = 0.0
    for point in y:
        d = np.linalg.norm(samples - point, axis=1)
        j = int(np.argmin(d))
        c = samples[j]
        inside = np.all(c[:2] > lo[:2] + 1e-6) and np.all(c[:2] < hi[:2] - 1e-6)
        if inside:
            depth = max(depth, float(-(point - c) @ normals[owner[j]]))
    return MPI.COMM_WORLD.allreduce(depth, op=MPI.MAX)


@pytest.mark.parametrize("method", ["node-to-surface", "mortar"])
def test_a_master_smaller_than_the_slave_against_a_brute_force(mpi_tmp_path, monkeypatch, method):
    """The roles swapped: the master nodes (the upper block's bottom) sink into the slave body. Without the
    allowances the reported depth is the brute force's to the sampling's resolution; with them it stays far above
    the warning (0.33 and 0.78 of the displacement scale measured)."""
    scene = write(mpi_tmp_path / f"swap_{method}.toml", press("lower_top", "upper_bottom", method))
    with build_problem(Scene.from_toml(scene)).problem as problem:
        _, result = problem.solve()
        assert result.converged
        reported = result.checks["master_penetration"]
        assert reported > 30 * MASTER_WARNING, reported
        monkeypatch.setattr(master_nodes, "FACETTING_ALLOWANCE", 0.0)
        monkeypatch.setattr(master_nodes, "SLAVE_FACTOR", 0.0)
        model = problem.model
        raw, at, _ = model.coupling.master_depth(model, result.displacement)
        expected = brute_force_depth(problem, 1, 2)  # lower_top = 1, upper_bottom = 2
    assert at is not None
    assert min(abs(at[0] - 1.5), abs(at[0] - 0.5), abs(at[1] - 0.25), abs(at[1] - 0.75)) < 1e-2, at  # its border
    assert expected > 1e-3
    assert abs(raw - expected) <= 1e-9 * expected, (raw, expected)


def test_the_right_roles_leave_no_master_node_inside(mpi_tmp_path, capsys):
    """The smaller surface the slave (the demo's roles), node-to-surface: no master node inside beyond the allowance
    (0 reported), no warning; swapped, the real command warns and names the cure."""
    right = write(mpi_tmp_path / "right.toml", press("upper_bottom", "lower_top", "node-to-surface"))
    assert main(["--scene", str(right), "--out", str(mpi_tmp_path / "right"), "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    checks = json.loads((mpi_tmp_path / "right" / "summary.json").read_text())["physics_checks"]
    assert checks["master_penetration"] == 0.0
    printed = capsys.readouterr()
    assert "ends inside the slave body" not in printed.out + printed.err
    swapped = write(mpi_tmp_path / "swapped.toml", press("lower_top", "upper_bottom", "node-to-surface"))
    assert main(["--scene", str(swapped), "--out", str(mpi_tmp_path / "swapped"), "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    checks = json.loads((mpi_tmp_path / "swapped" / "summary.json").read_text())["physics_checks"]
    assert checks["master_penetration"] > 0.1 and len(checks["master_penetration_at"]) == 3
    printed = capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        assert "a master node of a contact pair ends inside the slave body" in printed.out + printed.err
        assert "make the smaller surface the slave" in printed.out + printed.err


@pytest.mark.parametrize("case", ["sides", "slid"])
def test_a_master_border_the_allowance_and_the_scale_hid(mpi_tmp_path, capsys, case):
    """Found by a review, both with the upper block's border 3.3e-3 inside the lower block and exit 0 without a word:
    the master surface named as the upper block's bottom AND sides turns by 90° at the edge, which counted as
    facetting (the allowance 0.78 h_s hid it) — now only the master facets facing the slave count; and the block
    pressed and slid 0.45 in one solve: 3.2e-3 inside is 0.007 of a displacement scale the slide makes 0.45 — now
    also judged against the slave facet's size (1.5 % of it)."""
    text = press("lower_top", "upper_bottom", "node-to-surface")
    if case == "sides":
        text = text.replace('master = "upper_bottom"', 'master = ["upper_bottom", "upper_sides"]')
    else:
        text = text.replace("upper_top = [0.0, 0.0, -0.01]", "upper_top = [0.45, 0.0, -0.01]")
    assert text != press("lower_top", "upper_bottom", "node-to-surface")
    scene = write(mpi_tmp_path / f"{case}.toml", text)
    out = mpi_tmp_path / case
    assert main(["--scene", str(scene), "--out", str(out), "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    checks = json.loads((out / "summary.json").read_text())["physics_checks"]
    assert checks["master_penetration_facet"] > MASTER_WARNING, checks
    printed = capsys.readouterr()
    if MPI.COMM_WORLD.rank == 0:
        assert "a master node of a contact pair ends inside the slave body" in printed.out + printed.err


def test_a_master_sunk_deeper_than_the_slaves_top_cell_layer(mpi_tmp_path, capsys):
    """Found by a review: the lower block with a top layer 0.004 thick (meshes/slide_off.py --layer), the roles
    swapped, pressed 0.02: the upper block's border ends 9e-3 inside the lower block (the force 17.6 % low), deeper
    than the slave's cell layer under it, where the side of the slave surface does not tell the inside of the body
    from the space beyond a thin one — it was dropped: 0 reported. Such nodes are now located in the deformed slave
    body's cells."""
    from meshes.slide_off import build

    mesh = mpi_tmp_path / "layer.msh"
    if MPI.COMM_WORLD.rank == 0:
        build(mesh, layer=0.004)
    MPI.COMM_WORLD.barrier()
    text = press("lower_top", "upper_bottom", "node-to-surface").replace(f"{ROOT}/meshes/slide_off.msh", str(mesh))
    text = text.replace("upper_top = [0.0, 0.0, -0.01]", "upper_top = [0.0, 0.0, -0.02]")
    assert str(mesh) in text and "-0.02]" in text
    scene = write(mpi_tmp_path / "layer.toml", text)
    out = mpi_tmp_path / "layer"
    assert main(["--scene", str(scene), "--out", str(out), "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    checks = json.loads((out / "summary.json").read_text())["physics_checks"]
    assert checks["master_penetration"] > 0.2 and checks["master_penetration_facet"] > MASTER_WARNING, checks
    at = checks["master_penetration_at"]
    assert min(abs(at[0] - 1.5), abs(at[0] - 0.5)) < 1e-2 and 0.5 - at[2] > 0.004  # the border, below the layer
