"""Obstacles in the real solver: rotation invariance of a whole scene, bad obstacle input, indentation by δ,
scenes with ``[[obstacle]]`` tables (1 and 2 ranks)."""

from __future__ import annotations

import dataclasses

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import pytest

from conftest import assert_physics

from fenics_coulomb import ContactProblem, InputError, Plane, Sphere
from fenics_coulomb.scenes.builder import build_body, build_problem, clamp, isotropic_forms
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.model.dof_values import owned_values

#: Converged to round-off (the invariance is asserted to 1e-8).
TIGHT = {"rtol": 1e-12, "tol": 1e-10}


def rotation(axis, angle: float) -> np.ndarray:
    """The rotation matrix about the unit ``axis`` by ``angle`` (Rodrigues)."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def solve_rotated(scene: Scene, Q: np.ndarray) -> np.ndarray:
    """Solve the scene with the whole setting rotated by Q (mesh coordinates, obstacle plane, tractions, the
    clamped boundary moves with the mesh); return the owned displacement DOFs (collective)."""
    comm = MPI.COMM_WORLD
    body = build_body(scene, comm)
    x = body.mesh.geometry.x
    x[:] = x @ Q.T
    V = dolfinx.fem.functionspace(body.mesh, ("Lagrange", 1, (3,)))
    tractions = {body.tag(name): tuple(Q @ np.asarray(value)) for name, value in scene.traction_table().items()}
    a, L = isotropic_forms(V, scene.material.material(), body.facet_tags, tractions)
    plane = Plane(point=[0.0, 0.0, 0.0], normal=list(Q @ np.array([0.0, 0.0, 1.0])))
    contact = (body.facet_tags, [body.tag(name) for name in body.contact])
    with ContactProblem(a, L, bcs=[clamp(V, body)], contact=contact, friction=scene.friction.coefficient,
                        obstacles=[plane], settings=TIGHT, petsc_options_prefix="rot_") as problem:
        uh, result = problem.solve()
        assert result.converged
        assert_physics(problem.model, result.displacement, tol=1e-6)
        assert result.counts["slip"] > 0 and result.counts["stick"] > 0
        return owned_values(uh)


def test_rotated_scene_gives_the_rotated_displacement():
    """d3/L2 at lev 3 solved in the paper's placement and with everything rotated by Q (a generic rotation,
    so the frames are not the identity): ũ_rot(Q x) = Q ũ(x) to 1e-8 relative, node by node."""
    scene = Scene().override(lev=3, gap="d3", load="L2")
    u = solve_rotated(scene, np.eye(3)).reshape(-1, 3)
    Q = rotation([1.0, -2.0, 0.5], 0.7)
    u_rot = solve_rotated(scene, Q).reshape(-1, 3)
    comm = MPI.COMM_WORLD
    error = comm.allreduce(float(np.sum((u_rot - u @ Q.T) ** 2)), op=MPI.SUM)
    norm = comm.allreduce(float(np.sum(u**2)), op=MPI.SUM)
    print("rotation invariance: relative error", np.sqrt(error / norm), "of", np.sqrt(norm))
    assert np.sqrt(error / norm) < 1e-8


def test_obstacle_overlapping_at_scene_position_is_input_error():
    """A sphere already overlapping the body at δ = 0 is rejected on every rank, naming it and the node."""
    scene = Scene().override(lev=1, gap="d3", load="L2")
    scene = dataclasses.replace(scene, obstacles=[Sphere(center=[1.0, 0.5, -0.4], radius=0.5, name="ball")])
    with pytest.raises(InputError, match=r"obstacle 1 \(sphere 'ball'\) overlaps the body .* node \("):
        build_problem(scene, MPI.COMM_WORLD)


def test_indentation_by_displacement_is_solved():
    """The same sphere touching at its scene position, moved 0.01 up by δ: the overlap is an indentation,
    solved; the surface is pushed out (gap >= 0 in the sphere's frames) and the sphere carries the body."""
    scene = Scene().override(lev=2, gap="d3", load="L2", friction=0.3, **TIGHT)
    sphere = Sphere(center=[1.0, 0.5, -10.0], radius=10.0, displacement=[0.001, 0.0, 0.01], name="indenter")
    scene = dataclasses.replace(scene, obstacles=[sphere])
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        assert MPI.COMM_WORLD.allreduce(float(np.min(problem.model.contact.gap, initial=0.0)), op=MPI.MIN) < 0
        _, result = problem.solve()
        assert result.converged
        checks = assert_physics(problem.model, result.displacement, tol=1e-6)
        total = np.asarray(MPI.COMM_WORLD.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM))
        assert total[2] > 0  # the indenter pushes the body up
        assert np.allclose(total, checks["contact_resultant"], rtol=1e-6, atol=1e-9 * abs(total[2]))


def test_scene_obstacle_tables(mpi_tmp_path):
    """``[[obstacle]]`` tables reach the problem; bad tables are one-line InputErrors."""
    path = mpi_tmp_path / "tilted.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text('[body]\nlev = 1\ngap = "d3"\n[load]\ncase = "L2"\n'
                        '[[obstacle]]\ntype = "plane"\npoint = [0, 0, -0.01]\nnormal = [0.01, -0.005, 1.0]\n')
    MPI.COMM_WORLD.barrier()
    scene = Scene.from_toml(path)
    assert len(scene.obstacles) == 1 and np.isclose(np.linalg.norm(scene.obstacles[0].normal), 1.0)
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        R = problem.model.contact.frames
        assert np.allclose(R[:, :, 2], scene.obstacles[0].normal)
        _, result = problem.solve()
        assert result.converged
    for bad, message in [('type = "plane"\npoint = [0, 0, 0]\nnormal = [0, 0, 0]', "normal"),
                         ('type = "sphere"\ncenter = [0, 0, 0]\nradius = -1.0', "radius"),
                         ('type = "cone"', "type")]:
        if MPI.COMM_WORLD.rank == 0:
            path.write_text(f"[body]\nlev = 1\n[[obstacle]]\n{bad}\n")
        MPI.COMM_WORLD.barrier()
        with pytest.raises(InputError, match=message) as err:
            Scene.from_toml(path)
        assert "\n" not in str(err.value)
        MPI.COMM_WORLD.barrier()


@pytest.mark.parametrize("name", ["cylinder_roller", "tilted_plane"])
def test_shipped_obstacle_scenes_physics(name):
    """The shipped cylinder-roller and tilted-plane scenes (at lev 2) solve and pass the physics checks in
    the nodes' frames; the cylinder drags the plate along its motion."""
    from pathlib import Path

    from fenics_coulomb.io.start import start_function

    scene = Scene.from_toml(Path(__file__).parents[2] / "demos" / "scenes" / f"{name}.toml").override(lev=2)
    with build_problem(scene, MPI.COMM_WORLD).problem as problem:
        _, result = problem.solve(start_function(scene.start, problem.V))
        assert result.converged
        checks = assert_physics(problem.model, result.displacement, tol=1e-6)
        force = np.asarray(checks["contact_resultant"])
        if name == "cylinder_roller":
            assert force[2] < 0 and force[0] > 0  # pressed down, dragged along +x1
        else:
            assert force @ np.array(scene.obstacles[0].normal) > 0
