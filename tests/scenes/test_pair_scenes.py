"""Two bodies from a scene file (issue 18): ``[bodies]``, ``[material.NAME]`` and ``[[contact_pair]]``.

An elastic hemisphere (stiffer, its flat face pushed down and sideways) on an elastic block (clamped bottom),
one gmsh mesh with two volumes (meshes/hemisphere_on_block.py), run with the real command line in-process on
1 and 2 ranks: it converges, the physics holds in the pair's variables, the per-pair forces on the two bodies
are equal and opposite, and the hemisphere's own material is used; bad pair input exits 2 with one line.
"""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.cli import EXIT_INPUT, main
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs import node_to_surface, register_pair_method, unregister_pair_method
from fenics_coulomb.scenes.scene import Scene

ROOT = Path(__file__).resolve().parents[2]
from meshes import hemisphere_on_block  # noqa: E402

SCENE = """
[body]
shape = "mesh"
mesh = "{mesh}"
clamped = ["block_bottom"]

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
young = {young}
poisson = 0.25

[prescribed]
flat = [0.004, 0.0, -0.02]

[tractions]

[[contact_pair]]
slave = "curved"
master = "block_top"
friction = 0.3
{extra}
[solver]
rtol = 1e-12
"""


@pytest.fixture(scope="module")
def mesh_file(tmp_path_factory) -> Path:
    """A coarse hemisphere-on-block mesh, written by rank 0 into a directory all ranks share."""
    comm = MPI.COMM_WORLD
    path = Path(comm.bcast(str(tmp_path_factory.mktemp("pairs")) if comm.rank == 0 else None, root=0))
    if comm.rank == 0:
        hemisphere_on_block.build(contact=0.12, path=path / "hob.msh", size=0.8)
    comm.barrier()
    return path / "hob.msh"


def write_scene(path: Path, mesh: Path, young: float = 200.0, extra: str = "") -> Path:
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        path.write_text(SCENE.format(mesh=mesh, young=young, extra=extra))
    comm.barrier()
    return path


def test_pair_scene_on_the_command_line(mesh_file):
    """The real command solves the scene; summary.json reports equal and opposite forces on the two bodies;
    the physics of the solve holds (rebuilt from the same scene)."""
    scene_path = write_scene(mesh_file.parent / f"pair{MPI.COMM_WORLD.size}.toml", mesh_file)
    out = mesh_file.parent / f"out{MPI.COMM_WORLD.size}"
    assert main(["--scene", str(scene_path), "--out", str(out), "--no-plots", "--quiet"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"]
    (pair,) = summary["contact_pairs"]
    assert pair["method"] == "mortar"  # the default
    slave, master = np.array(pair["force_on_slave_body"]), np.array(pair["force_on_master_body"])
    assert slave[2] > 0 and abs(slave[0]) > 0  # pressed up by the block, dragged back by friction
    assert np.linalg.norm(slave + master) <= 1e-8 * np.linalg.norm(slave)

    built = build_problem(Scene.from_toml(scene_path))
    with built.problem as problem:
        _, result = problem.solve()
        checks = physics_residuals(problem.model, result.relative_displacement)
        assert problem.model.num_bodies == 2
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction",
                "reaction_balance"):
        assert checks[key] < 1e-7, (key, checks[key])
    assert result.counts["stick"] + result.counts["slip"] > 0


def test_the_method_key_is_checked_against_the_registry(mesh_file):
    """[[contact_pair]] method accepts the registered pair methods: one registered at run time is accepted, and
    refused (InputError naming it) once unregistered."""
    path = write_scene(mesh_file.parent / f"toy{MPI.COMM_WORLD.size}.toml", mesh_file, extra='method = "toy"\n')
    register_pair_method("toy", node_to_surface.stencils)
    try:
        (pair,) = Scene.from_toml(path).contact_pairs
        assert pair.method == "toy"
    finally:
        unregister_pair_method("toy")
    with pytest.raises(InputError, match="method = 'toy': must be one of 'mortar', 'node-to-surface'"):
        Scene.from_toml(path)


@pytest.mark.parametrize("method", ["mortar", "node-to-surface"])
def test_the_method_key_chooses_the_discretization(mesh_file, method):
    """[[contact_pair]] method: dual mortar nodes carry D_j (their pressure's area), node-to-surface ones none;
    both solve the scene with the physics."""
    path = write_scene(mesh_file.parent / f"method{method}{MPI.COMM_WORLD.size}.toml", mesh_file,
                       extra=f'method = "{method}"\n')
    with build_problem(Scene.from_toml(path)).problem as problem:
        _, result = problem.solve()
        pairing = problem.model.pairing
        has_area = MPI.COMM_WORLD.allreduce(bool(np.isfinite(pairing.area).any()), op=MPI.LOR)
        checks = physics_residuals(problem.model, result.relative_displacement)
    assert result.converged and has_area == (method == "mortar")
    assert all(checks[k] < 1e-7 for k in ("equilibrium", "penetration", "negative_pressure", "complementarity"))


def test_material_per_body_is_used(mesh_file):
    """A stiffer hemisphere carries a larger force for the same prescribed approach ([material.hemisphere])."""
    forces = []
    for young in (200.0, 20.0):
        scene = Scene.from_toml(write_scene(mesh_file.parent / f"m{young:g}_{MPI.COMM_WORLD.size}.toml", mesh_file,
                                            young))
        with build_problem(scene).problem as problem:
            _, result = problem.solve()
            local = result.contact_force.sum(axis=0)
            forces.append(MPI.COMM_WORLD.allreduce(local, op=MPI.SUM)[2])
    assert forces[0] > 1.2 * forces[1] > 0


def test_pair_scene_with_a_rigid_floor(mesh_file):
    """[[contact_pair]] together with an [[obstacle]]: the block held by its sides rests on a rigid floor just
    below its bottom ([body] contact); both carry the hemisphere's push (the floor's share from the block)."""
    text = SCENE.format(mesh=mesh_file, young=200.0, extra="").replace(
        'clamped = ["block_bottom"]', 'clamped = ["block_sides"]\ncontact = ["block_bottom"]')
    text += '\n[[obstacle]]\ntype = "plane"\nname = "floor"\npoint = [0.0, 0.0, -2.000001]\nnormal = [0.0, 0.0, 1.0]\n'
    path = mesh_file.parent / f"floor{MPI.COMM_WORLD.size}.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(text)
    MPI.COMM_WORLD.barrier()
    with build_problem(Scene.from_toml(path)).problem as problem:
        _, result = problem.solve()
        assert result.converged
        model = problem.model
        floor = np.zeros(3)
        paired = model.coupling.paired_mask(model.contact.size)
        floor[:] = MPI.COMM_WORLD.allreduce(result.contact_force[~paired].sum(axis=0), op=MPI.SUM)
        pushed = MPI.COMM_WORLD.allreduce(result.contact_force[paired].sum(axis=0), op=MPI.SUM)
        checks = physics_residuals(model, result.relative_displacement)
    assert floor[2] > 0 and pushed[2] > 0
    for key in ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "reaction_balance"):
        assert checks[key] < 1e-7, (key, checks[key])


@pytest.mark.parametrize(("extra", "message"), [
    ('[[contact_pair]]\nslave = "curved"\nmaster = "nowhere"\n', "boundary 'nowhere' is not in"),
    ('[[contact_pair]]\nslave = "curved"\n', "needs a master surface"),
    ('[[contact_pair]]\nslave = "flat"\nmaster = "block_top"\nfriction = -1.0\n', "friction = -1.0"),
    ('[[contact_pair]]\nslave = "flat"\nmaster = "block_top"\nsearch_distance = 0\n', "search_distance = 0"),
    ('[[contact_pair]]\nslave = "flat"\nmaster = "block_top"\nspeed = 1\n', "unknown key 'speed'"),
    ('method = "nitsche"\n', "method = 'nitsche'"),
    ('method = 3\n', "method"),
    ('[material.ball]\nyoung = 1.0\n', "[material.ball]: 'ball' is not in [bodies]"),
    ('[[obstacle]]\ntype = "plane"\npoint = [0, 0, -5]\nnormal = [0, 0, 1]\n', "name the obstacles' contact boundary"),
])
def test_bad_pair_input_exits_2_with_one_line(mesh_file, extra, message, capsys):
    scene_path = write_scene(mesh_file.parent / f"bad{MPI.COMM_WORLD.size}.toml", mesh_file, extra=extra)
    status = main(["--scene", str(scene_path), "--out", str(mesh_file.parent / "never"), "--quiet"])
    MPI.COMM_WORLD.barrier()
    err = capsys.readouterr().err.strip().splitlines()
    assert status == EXIT_INPUT
    if MPI.COMM_WORLD.rank == 0:  # rank 0 prints the one line, the others nothing (tests/cli/test_errors.py)
        assert len(err) == 1 and message in err[0], err
    else:
        assert err == [], err


def test_the_header_names_each_pairs_friction(mesh_file, capsys):
    """The first line of a two-body run gives the pair's own F (0.3), not the scene's default [friction] (0.23)."""
    scene_path = write_scene(mesh_file.parent / f"header{MPI.COMM_WORLD.size}.toml", mesh_file)
    out = mesh_file.parent / f"header-out{MPI.COMM_WORLD.size}"
    assert main(["--scene", str(scene_path), "--out", str(out), "--no-plots"]) == 0
    if MPI.COMM_WORLD.rank == 0:
        header = capsys.readouterr().err.splitlines()[0]
        assert "pair 1 F = 0.3," in header and "F = 0.23" not in header, header
