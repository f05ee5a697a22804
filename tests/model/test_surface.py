"""Rigid surface obstacles from triangles (issue 26): gaps and frames against a brute-force projection, the
analytic obstacles reproduced (a plane exactly, a sphere up to the facetting), bad files rejected in one line.

The brute-force projection is independent of fenics_coulomb.model.pairs.pairing: the distance from a point to each
triangle from its plane (the foot inside it) or its three edges, the minimum over all triangles; the sign from
the side the point is on (inside the convex icosphere: below every facet plane)."""

from __future__ import annotations

import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb import InputError, Sphere, Surface
from fenics_coulomb.cli import EXIT_INPUT, main

ROOT = Path(__file__).resolve().parents[2]
from meshes.surfaces import icosphere, rectangle, write_stl  # noqa: E402

CENTER, RADIUS = np.array([1.0, 0.5, 1.5]), 0.5


def shared(path: Path, triangles: np.ndarray, binary: bool = False) -> Path:
    if MPI.COMM_WORLD.rank == 0:
        write_stl(path, triangles, binary)
    MPI.COMM_WORLD.barrier()
    return path


def brute_distance(p: np.ndarray, triangles: np.ndarray) -> float:
    """The distance from ``p`` to the nearest triangle: for each triangle the minimum of the distance to its plane
    where the foot lies inside it (barycentric coordinates from a 2 × 2 normal-equation solve, all ≥ 0) and the
    distances to its three edges (segments, the foot's parameter clamped to [0, 1]); all triangles at once."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e1, e2, r = b - a, c - a, p - a
    gram = np.stack([np.stack([np.einsum("ij,ij->i", e1, e1), np.einsum("ij,ij->i", e1, e2)], -1),
                     np.stack([np.einsum("ij,ij->i", e2, e1), np.einsum("ij,ij->i", e2, e2)], -1)], -2)
    rhs = np.stack([np.einsum("ij,ij->i", e1, r), np.einsum("ij,ij->i", e2, r)], -1)
    w = np.linalg.solve(gram, rhs[..., None])[..., 0]
    inside = (w[:, 0] >= 0) & (w[:, 1] >= 0) & (w.sum(axis=1) <= 1)
    foot = a + w[:, :1] * e1 + w[:, 1:] * e2
    best = np.where(inside, np.linalg.norm(p - foot, axis=1), np.inf)
    for s, t in ((a, b), (b, c), (c, a)):
        d = t - s
        lam = np.clip(np.einsum("ij,ij->i", p - s, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - (s + lam[:, None] * d), axis=1))
    return float(best.min())


# rank-local geometry (no communicator): on 2 ranks each rank repeats the same brute force
@pytest.mark.serial
def test_gaps_and_normals_against_a_brute_force_projection(tmp_path):
    T = icosphere(RADIUS, tuple(CENTER), level=1)  # 80 triangles: the brute force stays cheap
    surface = Surface(file=str(write_stl(tmp_path / "ball.stl", T)))  # tmp_path is this rank's own
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    x = CENTER + directions * rng.uniform(0.2, 0.8, size=200)[:, None]  # inside and outside
    g, n, R = surface.evaluate(x)
    planes_n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    planes_n /= np.linalg.norm(planes_n, axis=1)[:, None]
    inside = np.all(np.einsum("kj,ij->ik", planes_n, x) - np.einsum("kj,kj->k", planes_n, T[:, 0]) < 0, axis=1)
    for i in range(x.shape[0]):
        assert abs(abs(g[i]) - brute_distance(x[i], T)) <= 1e-7, i
        assert (g[i] < 0) == inside[i], i
    # unit normals, right-handed frames with n last, and x − g n on the surface (distance 0)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0) and np.allclose(np.linalg.det(R), 1.0)
    assert np.allclose(R[:, :, 2], n)
    for p in surface.closest_point(x)[:8]:
        assert brute_distance(p, T) <= 1e-7


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_side_inward_flips_the_gap(tmp_path):
    T = icosphere(RADIUS, tuple(CENTER), level=1)
    path = write_stl(tmp_path / "ball.stl", T, binary=True)  # binary STL as well; tmp_path is this rank's own
    x = CENTER + np.array([[0.0, 0.0, 0.9], [0.1, 0.0, 0.0]])
    g_out = Surface(file=str(path)).signed_distance(x)
    g_in = Surface(file=str(path), side="inward").signed_distance(x)
    assert np.allclose(g_in, -g_out, rtol=0, atol=1e-14) and g_out[0] > 0 > g_out[1]


def _solve(tmp_path: Path, name: str, obstacle: str) -> tuple[dict, np.ndarray]:
    text = (ROOT / "demos" / "scenes" / "sphere_indentation.toml").read_text()
    text = text.split("[[obstacle]]")[0] + obstacle + '\n[solver]\nrtol = 1e-11\nstart = "undeformed"\n'
    scene = tmp_path / f"{name}.toml"
    if MPI.COMM_WORLD.rank == 0:
        scene.write_text(text)
    MPI.COMM_WORLD.barrier()
    out = tmp_path / name
    assert main(["--scene", str(scene), "--lev", "2", "--out", str(out), "--quiet", "--no-plots"]) == 0
    import h5py

    with h5py.File(out / "solution.h5", "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        u = h5[f"Function/displacement/{sorted(h5['Function/displacement'], key=int)[-1]}"][:]
    order = np.lexsort(np.round(x, 12).T[::-1])
    return json.loads((out / "summary.json").read_text()), u[order]


def test_a_faceted_plane_is_the_plane(mpi_tmp_path):
    """A plane pressed onto the block's top from above (x3 = 1.005, normal −e3, moved 0.01 down), as two large
    triangles, gives the Plane obstacle's solution to 1e-10."""
    top = rectangle((-1.0, -1.0), (3.0, 2.0), z=1.005)[:, ::-1]  # reversed: normals −e3, toward the body below
    path = shared(mpi_tmp_path / "plane.stl", top)
    plane = '[[obstacle]]\ntype = "plane"\npoint = [0.0, 0.0, 1.005]\nnormal = [0.0, 0.0, -1.0]\n' \
            'displacement = [0.0, 0.0, -0.01]\n'
    faceted = f'[[obstacle]]\ntype = "surface"\nfile = "{path}"\ndisplacement = [0.0, 0.0, -0.01]\n'
    a, ua = _solve(mpi_tmp_path, "plane", plane)
    b, ub = _solve(mpi_tmp_path, "faceted", faceted)
    assert a["state_counts"] == b["state_counts"] and a["state_counts"]["stick"] + a["state_counts"]["slip"] > 0
    assert np.linalg.norm(ub - ua) <= 1e-10 * np.linalg.norm(ua)
    # the surface's geometry is checked after a looser first solve (finite sliding), the plane's is fixed: the
    # forces agree to the solves' accuracy, not bit for bit
    force = np.asarray(a["contact_force"])
    assert np.linalg.norm(np.asarray(b["contact_force"]) - force) <= 1e-10 * np.linalg.norm(force)


def test_a_faceted_sphere_approaches_the_sphere(mpi_tmp_path):
    """An icosphere of 5120 triangles (edge ≈ 0.027 R) against the analytic sphere: the contact force within
    the facetting error (a few per cent), not identical."""
    center, radius = (1.0, 0.5, 1.5), 0.5
    path = shared(mpi_tmp_path / "ball.stl", icosphere(radius, center, level=4))
    analytic = f'[[obstacle]]\ntype = "sphere"\ncenter = {list(center)}\nradius = {radius}\n' \
               'displacement = [0.0, 0.0, -0.01]\n'
    faceted = f'[[obstacle]]\ntype = "surface"\nfile = "{path}"\ndisplacement = [0.0, 0.0, -0.01]\n'
    a, ua = _solve(mpi_tmp_path, "sphere", analytic)
    b, ub = _solve(mpi_tmp_path, "icosphere", faceted)
    fa, fb = np.array(a["contact_force"]), np.array(b["contact_force"])
    assert 0 < np.linalg.norm(fb - fa) <= 0.05 * np.linalg.norm(fa)
    assert np.linalg.norm(ub - ua) <= 0.05 * np.linalg.norm(ua)
    assert isinstance(Sphere(center=center, radius=radius), Sphere)


BAD = {
    "empty": ("solid x\nendsolid x\n", "no triangles"),
    "nan": ("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 nan\nvertex 0 1 0\nendloop\n"
            "endfacet\nendsolid x\n", "triangle 1 has a non-finite coordinate"),
    "degenerate": ("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 2 0 0\nendloop\n"
                   "endfacet\nendsolid x\n", "triangle 1 is degenerate"),
    "flipped": ("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
                "endfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 0 1 0\nvertex 1 1 0\nendloop\n"
                "endfacet\nendsolid x\n", "triangles 1 and 2 are oriented inconsistently"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_surface_files_exit_2_naming_file_and_triangle(case, mpi_tmp_path, capsys):
    text, fragment = BAD[case]
    stl = mpi_tmp_path / f"{case}.stl"
    scene = mpi_tmp_path / f"{case}.toml"
    if MPI.COMM_WORLD.rank == 0:
        stl.write_text(text)
        scene.write_text(f'[body]\nlev = 1\n[[obstacle]]\ntype = "surface"\nfile = "{case}.stl"\n')
    MPI.COMM_WORLD.barrier()
    with pytest.raises(InputError, match=fragment):
        Surface(file=str(stl))
    capsys.readouterr()
    assert main(["--scene", str(scene), "--out", str(mpi_tmp_path / "o"), "--quiet", "--no-plots"]) == EXIT_INPUT
    err = capsys.readouterr().err.strip()
    if MPI.COMM_WORLD.rank == 0:
        assert len(err.splitlines()) == 1 and fragment in err and str(stl) in err, err


def test_bad_surface_keys_are_named(tmp_path):
    path = write_stl(tmp_path / "ok.stl", rectangle((0.0, 0.0), (1.0, 1.0)))
    with pytest.raises(InputError, match="side = 'up': choose one of outward, inward"):
        Surface(file=str(path), side="up")
    with pytest.raises(InputError, match="no such file"):
        Surface(file=str(tmp_path / "missing.stl"))
    (tmp_path / "ok.obj").write_text("v 0 0 0\n")
    with pytest.raises(InputError, match="give an .stl"):
        Surface(file=str(tmp_path / "ok.obj"))
