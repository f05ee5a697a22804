"""The user's script with top-level names only (issue 25): press a sphere, read the total force, the reaction
and the contact radius (ContactProblem.report), write the result set (write_results) — docs/api.md's example.

Checks: the report is the same on every rank and for every rank count (its arrays are gathered and ordered by
coordinates), the forces balance (reaction + obstacle force + applied load = 0), the sphere's force is the total
contact force, the nodal pressures are ≥ 0 and vanish on open nodes, the contact radius is Hertz's √(Rδ) to
within a mesh cell, and summary.json written by write_results reports the same reaction and force."""

from __future__ import annotations

import hashlib
import json

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

import fenics_coulomb
from fenics_coulomb import ContactProblem, ContactReport, Sphere, write_results

R, DEPTH, N = 0.5, 0.01, 24


def press_sphere(comm: MPI.Comm):
    """docs/api.md's script: a block [0,1]² × [0,0.5] clamped at its bottom, a rigid sphere pressed into its top."""
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], [1, 1, 0.5]], [N, N, N // 2], dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(top).astype(np.int32), np.full(top.size, 1, np.int32))
    bottom = dolfinx.fem.locate_dofs_topological(
        V, 2, dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0)))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), bottom, V)
    E, nu = 70.0, 0.3
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    a = ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx
    ball = Sphere(center=[0.5, 0.5, 0.5 + R], radius=R, displacement=[0, 0, -DEPTH], name="ball")
    problem = ContactProblem(a, None, bcs=[clamp], contact=(tags, [1]), friction=0.3, obstacles=[ball],
                             petsc_options_prefix="press_")
    _, result = problem.solve()
    return problem, result, clamp


def _digest(report: ContactReport) -> str:
    h = hashlib.sha256()
    for array in (report.total_force, report.reactions["bottom"], report.nodes.coordinates,
                  report.nodes.force, report.nodes.pressure, report.nodes.state):
        h.update(np.ascontiguousarray(array).tobytes())
    return h.hexdigest()


def test_press_a_sphere_and_read_the_forces(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    problem, result, clamp = press_sphere(comm)
    with problem:
        assert result.converged
        report = problem.report(result, reactions={"bottom": clamp})
        assert isinstance(report, fenics_coulomb.ContactReport)
        # the same numbers on every rank
        assert len(set(comm.allgather(_digest(report)))) == 1
        nodes = report.nodes
        assert nodes.coordinates.shape == (problem.p, 3)
        assert np.all(np.diff(nodes.coordinates[:, 0]) >= -1e-12)  # ordered by x1 (then x2, x3)
        # balance: support + obstacle + applied load = 0; the one obstacle carries the whole contact force
        reaction = report.reactions["bottom"]
        assert np.linalg.norm(reaction + report.total_force + report.applied_load) <= 1e-6 * np.linalg.norm(reaction)
        assert np.allclose(report.obstacle_forces["ball"], report.total_force, rtol=0, atol=0)
        assert report.total_force[2] < 0  # the sphere pushes the body down
        # pressures: non-negative, zero on open nodes, force / area on the others
        assert np.all(nodes.pressure >= 0) and np.all(nodes.pressure[~nodes.closed] == 0)
        assert np.allclose(nodes.pressure * nodes.area, nodes.normal_force, rtol=1e-12, atol=1e-14)
        counts = {s.name.lower(): int(np.sum(nodes.state == s)) for s in fenics_coulomb.report.ContactState}
        assert counts == result.counts
        # the contact radius against Hertz's √(Rδ) (a half-space; the block is 14 radii wide), one cell
        radius = report.contact_radius(center=(0.5, 0.5, 0.5))
        assert abs(radius - np.sqrt(R * DEPTH)) <= 1.0 / N + 1e-12, radius
        # the result set as the command line writes it
        data = write_results(mpi_tmp_path / "press", problem, result, reactions={"bottom": clamp})
        summary = json.loads((mpi_tmp_path / "press" / "summary.json").read_text())
        assert summary == json.loads(json.dumps(data))
        assert np.allclose(summary["reactions"]["bottom"], reaction, rtol=1e-12, atol=0)
        assert np.allclose(summary["contact_force"], report.total_force, rtol=1e-12, atol=1e-15)
        assert {"solution.xdmf", "solution.h5", "convergence.csv", "summary.json"} <= set(summary["files"])


@pytest.mark.compares_ranks
def test_the_report_does_not_depend_on_the_rank_count():
    """Rank 0 solves alone and compares its report with the one of all ranks (identical to round-off)."""
    comm = MPI.COMM_WORLD
    problem, result, clamp = press_sphere(comm)
    with problem:
        everyone = problem.report(result, reactions={"bottom": clamp})
    if comm.rank == 0:
        alone, r1, clamp1 = press_sphere(MPI.COMM_SELF)
        with alone:
            single = alone.report(r1, reactions={"bottom": clamp1})
        assert np.allclose(single.nodes.coordinates, everyone.nodes.coordinates, rtol=0, atol=1e-12)
        assert np.array_equal(single.nodes.state, everyone.nodes.state)
        assert np.allclose(single.nodes.force, everyone.nodes.force, rtol=1e-6, atol=1e-9)
        assert np.allclose(single.reactions["bottom"], everyone.reactions["bottom"], rtol=1e-6)
