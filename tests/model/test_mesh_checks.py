"""The cell checks of fenics_coulomb/model/mesh_checks.py against determinants of their own."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb.model.mesh_checks import corner_determinants


def reference_hexahedron(X: np.ndarray) -> np.ndarray:
    """det of the Jacobian at each corner (x + 2y + 4z numbering): columns the edges leaving the corner along
    ξ, η, ζ (towards the opposite value of that bit), signed as ξ, η, ζ increase; numpy's det."""
    out = np.empty((X.shape[0], 8))
    for corner in range(8):
        bits = [(corner >> k) & 1 for k in range(3)]
        columns = []
        for k in range(3):
            hi, lo = list(bits), list(bits)
            hi[k], lo[k] = 1, 0
            index = lambda b: b[0] + 2 * b[1] + 4 * b[2]  # noqa: E731
            columns.append(X[:, index(hi)] - X[:, index(lo)])
        out[:, corner] = np.linalg.det(np.stack(columns, axis=2))
    return out


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_corner_determinants_of_distorted_hexahedra_and_tetrahedra():
    rng = np.random.default_rng(7)
    unit = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=float)
    X = unit[None] * rng.uniform(0.1, 3.0, (500, 1, 3)) + 0.2 * rng.standard_normal((500, 8, 3))
    det = corner_determinants("hexahedron", X)
    assert det.shape == (500, 8)
    assert np.allclose(det, reference_hexahedron(X), rtol=1e-12, atol=1e-12)
    # an inverted corner: one vertex pushed through the opposite face
    Y = unit[None].copy()
    Y[0, 7] = [0.2, 0.2, 0.2]
    d = corner_determinants("hexahedron", Y)
    assert d[0, 7] < 0 < d[0, 0]
    T = rng.standard_normal((200, 4, 3))
    dt = corner_determinants("tetrahedron", T)
    assert dt.shape == (200, 1)
    assert np.allclose(dt[:, 0], np.linalg.det(np.swapaxes(T[:, 1:] - T[:, :1], 1, 2)), rtol=1e-12, atol=1e-12)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_diameters_are_the_largest_vertex_distance():
    """The cell diameter that scales the degeneracy bound, against every vertex pair by np.linalg.norm (a loop per
    cell): equal to round-off, for distorted hexahedra and tetrahedra, and 0 for a cell collapsed to a point."""
    from fenics_coulomb.model.mesh_checks import _diameters

    rng = np.random.default_rng(11)
    for vertices in (8, 4):
        X = rng.standard_normal((300, vertices, 3)) * rng.uniform(1e-3, 1e3, (300, 1, 1))
        X[0] = 1.5  # every vertex at one point
        reference = np.array([max(np.linalg.norm(c[i] - c[j]) for i in range(vertices) for j in range(i))
                              for c in X])
        h = _diameters(X)
        assert h[0] == 0.0
        assert np.allclose(h, reference, rtol=1e-14, atol=0.0)


def _second_order_box(comm):
    """A gmsh box of 10-node tetrahedra (second-order geometry)."""
    import gmsh
    from dolfinx.io import gmshio

    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addBox(0, 0, 0, 2, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [1], 1)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)
    msh, _, _ = gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=3)
    if comm.rank == 0:
        gmsh.finalize()
    return msh


@pytest.mark.parametrize("order", [1, 2])
def test_displaced_geometry_moves_every_node_and_restores_them(order):
    """The body at X + u for the obstacle checks of finite sliding: every geometry node moved by the P1
    displacement (a linear field: exact at the midside nodes of a second-order mesh too, where the first-order
    mapping failed with a shape mismatch), and the reference geometry back bit for bit afterwards."""
    import dolfinx.fem
    import dolfinx.mesh

    from fenics_coulomb.model.mesh_checks import displaced_geometry

    comm = MPI.COMM_WORLD
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], [2, 1, 1]], [4, 2, 2]) if order == 1 else _second_order_box(comm)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    B, c = np.array([[0.1, 0.02, 0.0], [0.0, -0.05, 0.03], [0.01, 0.0, 0.2]]), np.array([0.3, -0.1, 0.05])
    u = dolfinx.fem.Function(V)
    u.interpolate(lambda x: (B @ x) + c[:, None])
    before = np.array(msh.geometry.x, copy=True)
    with displaced_geometry(V, u.x.array):
        moved = np.array(msh.geometry.x, copy=True)
    assert np.array_equal(msh.geometry.x, before)
    assert np.allclose(moved, before + before @ B.T + c, rtol=0, atol=1e-13)
