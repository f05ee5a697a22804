"""The lumped stress projection's quadrature (io/fields.py): on hexahedra two Gauss points per direction integrate it
exactly, on parallelepipeds and on distorted (trilinear) cells alike; a uniform stress is reproduced. 1 and 2
ranks."""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from petsc4py import PETSc

from fenics_coulomb.io.fields import shear_candidates, stress_from_form, stress_functions

MU, LMBDA = 26.9, 40.4


def _law(V):
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    return ufl.inner(2 * MU * eps(u) + LMBDA * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx


def _box(distort: float) -> dolfinx.mesh.Mesh:
    """A sheared box of hexahedra (parallelepipeds: affine cells), its interior nodes moved by ``distort`` of a
    cell."""
    msh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [[0, 0, 0], [2, 1, 1]], [6, 4, 3], dolfinx.mesh.CellType.hexahedron)
    x = msh.geometry.x
    inner = np.all((x > 1e-9) & (x < np.array([2, 1, 1]) - 1e-9), axis=1)
    # a smooth, partition-independent displacement of the interior nodes (a function of the position)
    x[inner] += distort * 0.25 * np.sin(7 * x[inner] + np.array([0.3, 1.1, 2.3])[None, :] * x[inner, ::-1])
    x[:, 0] += 0.4 * x[:, 2]  # the shear: cells stay parallelepipeds without distortion
    return msh


def _reference(stress, msh, degree: int) -> np.ndarray:
    """∫ φᵢ σ dx / ∫ φᵢ dx with a rule of the given degree, assembled here (the owned vertices' 3 × 3 tensors)."""
    T = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3, 3)))
    S = dolfinx.fem.functionspace(msh, ("Lagrange", 1))
    dx = ufl.dx(domain=msh, metadata={"quadrature_degree": degree})
    vectors = []
    for form in (ufl.inner(stress, ufl.TestFunction(T)) * dx, ufl.TestFunction(S) * dx):
        b = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(form))
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        vectors.append(b.getArray(readonly=True).copy())
        b.destroy()
    return vectors[0].reshape(-1, 9) / vectors[1][:, None]


def _warp(msh: dolfinx.mesh.Mesh) -> float:
    """The largest |x₀ − x₁ − x₂ + x₃| of a cell's bottom face (vertices in tensor-product order): 0 on
    parallelepipeds."""
    v = msh.geometry.x[msh.geometry.dofmap]
    local = float(np.abs(v[:, 0] - v[:, 1] - v[:, 2] + v[:, 3]).max(initial=0.0))
    return msh.comm.allreduce(local, op=MPI.MAX)


def _field(x):
    return np.vstack([np.sin(3 * x[0] + x[1]), x[0] * x[1] * x[2], np.cos(2 * x[2] - x[0])])


@pytest.mark.parametrize("distort", [0.0, 0.3], ids=["parallelepipeds", "distorted"])
def test_two_gauss_points_are_exact_on_hexahedra(distort):
    """A displacement of arbitrary nodal values: the recovery equals the projection integrated with a degree-8 rule
    to round-off on sheared and on distorted hexahedra (the shear and the warp of the cells checked)."""
    msh = _box(distort)
    assert (_warp(msh) > 0.01) == (distort > 0)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u = dolfinx.fem.Function(V)
    u.interpolate(_field)
    stress = stress_from_form(_law(V), u)
    sigma, _ = stress_functions(stress, msh)
    owned = V.dofmap.index_map.size_local
    exact = _reference(stress, msh, 8)[:owned]
    got = sigma.x.array.reshape(-1, 9)[:owned]
    scale = MPI.COMM_WORLD.allreduce(float(np.abs(exact).max(initial=0.0)), op=MPI.MAX)
    assert scale > 1.0
    assert np.abs(got - exact).max(initial=0.0) <= 1e-12 * scale
    # the control: one Gauss point per direction is not exact, so the comparison can see a wrong rule
    difference = np.abs(_reference(stress, msh, 1)[:owned] - exact).max(initial=0.0)
    assert MPI.COMM_WORLD.allreduce(difference, op=MPI.MAX) > 1e-3 * scale


def test_a_uniform_stress_on_distorted_hexahedra():
    """An affine displacement on distorted hexahedra: the stress is uniform, and the recovery gives it at every
    vertex to round-off."""
    msh = _box(0.3)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    G = np.array([[1.0, 0.2, -0.3], [0.1, -0.5, 0.4], [0.0, 0.3, 0.7]]) * 1e-3
    u = dolfinx.fem.Function(V)
    u.interpolate(lambda x: G @ x)
    eps = 0.5 * (G + G.T)
    exact = 2 * MU * eps + LMBDA * np.trace(eps) * np.eye(3)
    sigma, _ = stress_functions(stress_from_form(_law(V), u), msh)
    got = sigma.x.array.reshape(-1, 9)[: V.dofmap.index_map.size_local]
    assert np.abs(got - exact.ravel()).max(initial=0.0) <= 1e-12 * np.abs(exact).max()


def test_the_largest_shear_is_found_where_von_mises_is_not_largest():
    """summary.json's largest shear τ = (σ₁ − σ₃)/2 from the eigenvalues of the candidate nodes only
    (io/fields.shear_candidates): the same largest τ, at the same node, as the eigenvalues of every node — on a
    pure shear τ = 1 (von Mises √3) beside a uniaxial stress 1.9 (von Mises 1.9, τ 0.95), where the largest von
    Mises stress and the largest shear lie at different nodes, and on random tensors spanning six decades, with
    a hydrostatic half and a non-finite tensor. Each rank has its own nodes; the maxima are over all ranks."""
    comm = MPI.COMM_WORLD
    rng = np.random.default_rng(7 + comm.rank)

    def von_mises(t):
        s = t - np.einsum("nii->n", t)[:, None, None] / 3 * np.eye(3)
        return np.sqrt(1.5 * np.einsum("nij,nij->n", s, s))

    pure_shear = np.diag([1.0, 0.0, -1.0])
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    cases = [np.stack([rotation @ pure_shear @ rotation.T, np.diag([1.9, 0.0, 0.0]), np.zeros((3, 3))])]
    for _ in range(20):
        a = rng.normal(size=(500, 3, 3)) * 10.0 ** rng.integers(-3, 3, size=(500, 1, 1))
        t = a + a.transpose(0, 2, 1)
        t[:250] = np.eye(3) * rng.normal(size=(250, 1, 1))
        cases.append(t)
    failures = []  # asserted after the last collective call: a rank must not leave the others waiting
    for k, t in enumerate(cases):
        shear = shear_candidates(comm, t, von_mises(t))
        principal = np.linalg.eigvalsh(t)
        every = 0.5 * (principal[:, -1] - principal[:, 0])
        largest = comm.allreduce(every.max(), op=MPI.MAX)
        computed = shear != 0.0
        if comm.allreduce(shear.max(), op=MPI.MAX) != largest:
            failures.append(f"case {k}: largest shear")
        if every.max() == largest and np.argmax(shear) != np.argmax(every):  # the rank that holds it: same node
            failures.append(f"case {k}: its node")
        if not (np.array_equal(shear[computed], every[computed]) and np.all(shear <= every)):
            failures.append(f"case {k}: the computed values")
    broken = cases[1].copy()
    broken[3, 0, 0] = np.nan
    shear = shear_candidates(comm, broken, von_mises(broken))
    assert not failures, failures
    assert np.isnan(shear[3]) and np.isfinite(np.delete(shear, 3)).all()
    # the pure shear (node 0, on every rank) carries the largest τ although node 1 has the largest von Mises stress
    assert np.argmax(shear_candidates(MPI.COMM_SELF, cases[0], von_mises(cases[0]))) == 0
