"""The rigid obstacles in the result set: obstacles.xdmf holds each obstacle's surface as placed at every time of
solution.xdmf (1 and 2 ranks). The surfaces are checked against the obstacles' own geometry (signed distance 0 at
every point) and the placements against an independent rotation (scipy's rotation vectors)."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fenics_coulomb.cli import main
from fenics_coulomb.io.obstacle_surfaces import tessellate
from fenics_coulomb.model.obstacles import Cylinder, Plane, Sphere
from fenics_coulomb.model.surface import Surface

ROOT = Path(__file__).resolve().parents[2]
BOX = (np.array([0.0, 0.0, 0.0]), np.array([2.0, 1.0, 1.0]))


def placed(rest: np.ndarray, rotation: list | None, delta: list[float]) -> np.ndarray:
    """rest rotated about the rotation's centre by its angle (degrees) about its axis, then translated by δ."""
    if rotation is None:
        return rest + np.asarray(delta)
    angle, axis, centre = rotation
    turn = Rotation.from_rotvec(np.radians(angle) * np.asarray(axis) / np.linalg.norm(axis))
    return turn.apply(rest - np.asarray(centre)) + np.asarray(centre) + np.asarray(delta)


def edges(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The undirected edges of a triangulation and how many triangles share each."""
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0, return_counts=True)


OBSTACLES = {
    "plane": Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), displacement=(0.0, 0.0, -0.01)),
    "tilted plane": Plane(point=(1.0, 0.5, 1.2), normal=(0.3, 0.0, -1.0), rotation=[10.0, [0.0, 1.0, 0.0],
                                                                                   [1.0, 0.5, 1.2]]),
    "sphere": Sphere(center=(1.0, 0.5, 1.5), radius=0.5, displacement=(0.1, 0.0, -0.02),
                     rotation=[30.0, [0.0, 1.0, 0.0], [1.0, 0.5, 1.5]]),
    "cylinder": Cylinder(point=(0.6, 0.5, 1.5), axis=(0.0, 1.0, 0.0), radius=0.5, displacement=(0.01, 0.0, -0.005),
                         rotation=[45.0, [0.0, 1.0, 0.0], [0.6, 0.5, 1.5]]),
    "stl ball": Surface(file=str(ROOT / "meshes" / "ball.stl"), displacement=(0.0, 0.0, -0.01),
                        rotation=[20.0, [1.0, 1.0, 0.0], [1.0, 0.5, 1.5]]),
}


@pytest.mark.serial  # rank-local (docs/testing.md)
@pytest.mark.parametrize("name", list(OBSTACLES))
def test_surfaces_lie_on_their_obstacles(name):
    """Every placed point is on the placed obstacle (its own signed distance 0); the triangles are proper; a
    sphere's and a cylinder's edges stay close to the surface; a plane's patch covers the body; the placement is
    the rotation about the centre, then δ."""
    obstacle = OBSTACLES[name]
    rest, triangles, octant = tessellate(obstacle, *BOX)
    points = placed(rest, obstacle.rotation, obstacle.displacement)
    scale = float(np.linalg.norm(BOX[1] - BOX[0]))
    assert np.abs(obstacle.signed_distance(points)).max() < 1e-12 * scale
    assert triangles.min() == 0 and triangles.max() == rest.shape[0] - 1
    a, b, c = (points[triangles[:, i]] for i in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    assert area.min() > 0.0
    assert set(np.unique(octant)) == {0, 1}
    _, shared = edges(triangles)
    if name in ("sphere", "stl ball"):  # closed surfaces: every edge between two triangles
        assert np.all(shared == 2)
    if name in ("sphere", "cylinder"):  # the edges' midpoints within 0.5 % of the radius of the surface
        e, _ = edges(triangles)
        mid = 0.5 * (points[e[:, 0]] + points[e[:, 1]])
        assert np.abs(obstacle.signed_distance(mid)).max() < 5e-3 * obstacle.radius
    if name == "sphere":  # outward triangles
        normal = np.cross(b - a, c - a)
        assert np.all(np.einsum("ij,ij->i", normal, (a + b + c) / 3 - np.asarray(obstacle.placed)) > 0)
    if "plane" in name:  # the body's box projected onto the plane lies inside the patch
        frame = np.linalg.svd(points - points.mean(axis=0))[2][:2]
        corners = np.array([[x, y, z] for x in (0.0, 2.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
        inside = (corners - points.mean(axis=0)) @ frame.T
        extent = (points - points.mean(axis=0)) @ frame.T
        assert np.all(np.abs(inside) < np.abs(extent).max(axis=0))
    if name == "stl ball":  # the file's triangles as given
        from fenics_coulomb.model.triangulation import read_triangles

        X, V = read_triangles(obstacle.file, obstacle.source)
        assert np.array_equal(triangles, V) and np.allclose(rest[V], X, rtol=0, atol=0)


def grids(path: Path) -> list[ET.Element]:
    (series,) = ET.parse(path).getroot().findall("Domain/Grid")
    assert series.get("CollectionType") == "Temporal"
    return series.findall("Grid")


def times(path: Path) -> list[float]:
    return [float(g.find("Time").get("Value")) for g in grids(path)]


def test_a_static_result_set_writes_its_obstacle(mpi_tmp_path):
    """The README's first scene: obstacles.xdmf with one grid at solution.xdmf's time, the ball as placed."""
    out = mpi_tmp_path / "ball"
    scene = ROOT / "demos" / "scenes" / "sphere_indentation.toml"
    assert main(["--scene", str(scene), "--lev", "1", "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert {"obstacles.xdmf", "obstacles.h5"} <= set(summary["files"])
    assert times(out / "obstacles.xdmf") == times(out / "solution.xdmf") == [0.0]
    (grid,) = grids(out / "obstacles.xdmf")
    info = {i.get("Name"): i.get("Value") for i in grid.findall("Information")}
    assert info["obstacles"] == "1 ball"
    ball = Sphere(center=(1.0, 0.5, 1.5), radius=0.5, displacement=(0.0, 0.0, -0.01))
    with h5py.File(out / "obstacles.h5", "r") as h5:
        x = h5["Mesh/geometry/0"][:]
        rest = h5["Function/rest_position"][:]
        assert set(np.unique(h5["Function/obstacle"][:])) == {1}
        assert h5["Mesh/triangles"].shape[1] == 3
    assert np.allclose(x, rest + [0.0, 0.0, -0.01], rtol=0, atol=1e-15)
    assert np.abs(ball.signed_distance(x)).max() < 1e-12


def test_a_rolling_path_writes_the_obstacle_at_every_time(mpi_tmp_path):
    """The rolling ball: one grid per time of solution.xdmf; at t = 0 the scene position, at each step the ball
    turned about its centre by the step's angle and moved by its δ (scipy's rotation); the pattern turns."""
    out = mpi_tmp_path / "rolling"
    scene = ROOT / "demos" / "scenes" / "ball_rolling_path.toml"
    assert main(["--scene", str(scene), "--lev", "1", "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    steps = summary["steps"]
    assert times(out / "obstacles.xdmf") == times(out / "solution.xdmf") == [0.0, *(s["time"] for s in steps)]
    with h5py.File(out / "obstacles.h5", "r") as h5:
        rest = h5["Function/rest_position"][:]
        x = [h5[f"Mesh/geometry/{k}"][:] for k in range(len(steps) + 1)]
    assert np.array_equal(x[0], rest)
    for k, step in enumerate(steps, start=1):
        expected = placed(rest, step["obstacle_rotations"]["ball"], step["obstacle_displacements"]["ball"])
        assert np.abs(x[k] - expected).max() < 1e-14
    # the ball turned by 22.9° at the end: its rest points moved by up to 2 R sin(θ/2) plus δ, far beyond δ
    turned = np.linalg.norm(x[-1] - rest - steps[-1]["obstacle_displacements"]["ball"], axis=1).max()
    assert turned == pytest.approx(2 * 0.5 * np.sin(np.radians(22.918311805232932) / 2), rel=1e-2)


@pytest.mark.parametrize("obstacle", [
    Sphere(center=(1.0, 0.5, 1.0 + 2e-9), radius=1e-9), Sphere(center=(1e12, -1e12, 1e12), radius=1.0),
    Sphere(center=(1.0, 0.5, 1e9 + 1.0), radius=1e9),
    Cylinder(point=(0.0, 0.0, 1e9 + 1.0), axis=(1e-300, 1.0, 0.0), radius=1e9),
    Plane(point=(1e15, 0.0, -1e15), normal=(1.0, 1.0, 1.0), rotation=[1e6, [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]),
], ids=["tiny sphere", "far sphere", "huge sphere", "huge cylinder", "far turned plane"])
@pytest.mark.serial  # rank-local (docs/testing.md)
def test_hostile_obstacles_give_finite_surfaces(obstacle):
    """Obstacles far away, tiny or huge (as the fuzz tests' scenes have them): finite points, proper triangles,
    the placed points on the obstacle to the round-off of its own coordinates."""
    rest, triangles, octant = tessellate(obstacle, *BOX)
    points = placed(rest, obstacle.rotation, obstacle.displacement)
    assert np.all(np.isfinite(points)) and triangles.max() < rest.shape[0] and octant.shape == (rest.shape[0],)
    a, b, c = (points[triangles[:, i]] for i in range(3))
    assert np.all(np.linalg.norm(np.cross(b - a, c - a), axis=1) > 0)
    scale = max(float(np.abs(points).max()), float(np.abs(obstacle.placed).max()), getattr(obstacle, "radius", 1.0))
    assert np.abs(obstacle.signed_distance(points)).max() <= 1e-12 * scale
