"""One meaning per name: ``contact_pressure`` is force per area everywhere (the XDMF field, the report, summary.json,
the result lines), ``contact_force`` the nodal force vector, ``contact_traction`` the traction vector.

Physics: a block under a uniform pressure p on its top, resting on the frictionless plane x3 = 0 (rollers on two
sides above the bottom remove the rigid modes): the stress is uniaxial, σ₃₃ = −p, the displacement linear — exact
in Q1 — and the contact pressure is p at EVERY bottom node (the nodal force p ∫φᵢ ds over the node's area ∫φᵢ ds), the
contact area the whole bottom. A sphere pressed into a block: the XDMF ``contact_pressure`` equals
``problem.report(result).nodes.pressure`` node by node, and summary.json's area and peak pressure are the
report's. 1 and 2 ranks."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import h5py
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem, InputError, Sphere, contact_functions, write_results
from fenics_coulomb.io.fields import stress_from_form, stress_functions
from fenics_coulomb.io.units import Units

E, NU = 70.0, 0.3
MU, LMBDA = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
TOP, BOTTOM = 2, 1
TIGHT = {"rtol": 1e-12, "tol": 1e-12}


def _elasticity(V):
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    return ufl.inner(2 * MU * eps(u) + LMBDA * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx, v


def _tags(msh, faces):
    facets, values = [], []
    for tag, where in faces.items():
        f = dolfinx.mesh.locate_entities_boundary(msh, 2, where)
        facets.append(f)
        values.append(np.full(f.size, tag, np.int32))
    facets, values = np.concatenate(facets), np.concatenate(values)
    order = np.argsort(facets)
    return dolfinx.mesh.meshtags(msh, 2, facets[order].astype(np.int32), values[order])


def _read(out):
    """The single grid's information items and every point field, rows ordered by the vertex coordinates."""
    (grid,) = ET.parse(out / "solution.xdmf").getroot().find("Domain/Grid").findall("Grid")
    info = {i.get("Name"): i.get("Value") for i in grid.findall("Information")}
    with h5py.File(out / "solution.h5", "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        fields = {name: h5[f"Function/{name}/0"][:] for name in h5["Function"]}
    order = np.lexsort(np.round(x, 9).T[::-1])
    return info, x[order], {k: v[order] for k, v in fields.items()}


def uniform_pressure(comm, p=0.05, n=(4, 3, 2)):
    """A block [0,1]×[0,0.75]×[0,0.5] on the frictionless plane x3 = 0 under the pressure p on its top; rollers
    u1 = 0 on x1 = 0 and u2 = 0 on x2 = 0 above the bottom (the exact solution has u1 = 0, u2 = 0 there too)."""
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], [1, 0.75, 0.5]], list(n), dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    tags = _tags(msh, {BOTTOM: lambda x: np.isclose(x[2], 0.0), TOP: lambda x: np.isclose(x[2], 0.5)})
    bcs = []
    for i in (0, 1):
        Vi, _ = V.sub(i).collapse()
        # the roller's nodes above the bottom only: a held component would take a node out of the contact
        dofs = dolfinx.fem.locate_dofs_geometrical(
            (V.sub(i), Vi), lambda x, i=i: np.isclose(x[i], 0.0) & (x[2] > 1e-9))
        bcs.append(dolfinx.fem.dirichletbc(dolfinx.fem.Function(Vi), dofs, V.sub(i)))
    a, v = _elasticity(V)
    L = -p * v[2] * ufl.Measure("ds", domain=msh, subdomain_data=tags)(TOP)
    return ContactProblem(a, L, bcs=bcs, contact=(tags, [BOTTOM]), friction=0.0, settings=TIGHT,
                          petsc_options_prefix="unip_"), bcs


def test_uniform_pressure_is_the_applied_pressure_everywhere(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    p = 0.05
    problem, _ = uniform_pressure(comm, p)
    with problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result)
        out = mpi_tmp_path / "uniform"
        data = write_results(out, problem, result)
    comm.barrier()
    info, x, fields = _read(out)
    bottom = np.isclose(x[:, 2], 0.0)
    assert np.all(fields["contact_state"][bottom] > 0) and np.all(fields["contact_state"][~bottom] == -1)
    # every bottom node carries the applied pressure, as a pressure (not a mesh-dependent nodal force)
    assert np.allclose(fields["contact_pressure"][bottom], p, rtol=1e-9, atol=0)
    assert np.allclose(fields["contact_traction"][bottom], [0.0, 0.0, p], rtol=0, atol=1e-9 * p)
    assert np.allclose(report.nodes.pressure, p, rtol=1e-9, atol=0)
    # the nodal forces sum to the load p·|bottom| and are the report's
    assert np.allclose(fields["contact_force"].sum(axis=0), [0.0, 0.0, p * 0.75], rtol=0, atol=1e-9 * p)
    assert np.allclose(np.sort(fields["contact_force"][bottom, 2]), np.sort(report.nodes.force[:, 2]), rtol=1e-12)
    # summary.json: area = the whole bottom, the peak = p at the lexicographically first node (all tie)
    assert abs(data["contact_area"] - 0.75) <= 1e-12 and data["contact_nodes"] == bottom.sum()
    assert abs(data["peak_pressure"] - p) <= 1e-9 * p and np.allclose(data["peak_pressure_at"], 0.0, atol=1e-12)
    (plane,) = data["obstacles"].values()
    assert plane["contact_area"] == data["contact_area"] and plane["peak_pressure"] == data["peak_pressure"]
    assert np.allclose(plane["force"], data["contact_force"], rtol=1e-12)
    assert data["units"]["pressure"] == "GPa" and data["units"]["area"] == "L^2"
    assert "contact_pressure GPa" in info["units"] and "contact_traction GPa" in info["units"]
    assert json.loads((out / "summary.json").read_text())["peak_pressure"] == data["peak_pressure"]
    # the stress fields: uniaxial σ₃₃ = −p, von Mises p at every vertex; their maxima in summary.json
    exact = np.zeros(9)
    exact[8] = -p
    assert np.abs(fields["stress"] - exact).max() <= 1e-9 * p
    assert np.abs(fields["von_mises"] - p).max() <= 1e-9 * p
    assert abs(data["max_von_mises"] - p) <= 1e-9 * p and abs(data["max_shear"] - p / 2) <= 1e-9 * p
    assert np.allclose(data["max_von_mises_at"], 0.0, atol=1e-12)  # all tie: the first vertex
    assert "stress GPa" in info["units"] and "von_mises GPa" in info["units"]


def test_the_units_given_label_every_output(mpi_tmp_path):
    """write_results(units=...): the form in MPa on a mesh in mm is labelled so in summary.json, the XDMF grid's
    units item; the values are the same numbers as with the default labels
    (GPa, L: the solver does not convert). Refused before anything is written: a unit that is not a name, an
    unknown key."""
    comm = MPI.COMM_WORLD
    problem, _ = uniform_pressure(comm, 0.05)
    with problem:
        _, result = problem.solve()
        default = write_results(mpi_tmp_path / "default", problem, result)
        data = write_results(mpi_tmp_path / "mm", problem, result, units={"stress": "MPa", "length": "mm"})
        for units, message in [({"stress": ""}, "stress = ''"), ({"length": "m,m"}, "length = 'm,m'"),
                               ({"force": "N"}, "unknown key 'force'"), ("MPa", "give a dict"),
                               ({"stress": 3}, "stress = 3"), ({"stress": "$x^$"}, r"stress = '\$x\^\$'")]:
            with pytest.raises(InputError, match=f"write_results: units.*{message}"):
                write_results(mpi_tmp_path / "bad", problem, result, units=units)
    comm.barrier()
    assert not (mpi_tmp_path / "bad").exists()
    assert data["units"] == {"length": "mm", "area": "mm^2", "pressure": "MPa", "stress": "MPa",
                             "force": "MPa*mm^2"}
    info, _, fields = _read(mpi_tmp_path / "mm")
    for item in ("displacement mm", "contact_pressure MPa", "contact_force MPa*mm^2", "gap mm", "stress MPa",
                 "von_mises MPa", "contact_traction MPa"):
        assert item in info["units"].split(", ")
    assert "GPa" not in info["units"] and " L" not in info["units"]
    text = (mpi_tmp_path / "mm" / "obstacles.xdmf").read_text()  # the plane's rest positions in the length unit
    assert "rest_position mm," in text and "rest_position L" not in text
    # a compound name is grouped in what derives from it; a Units made directly is checked too
    assert Units(stress="kN/m^2", length="0.1 m").force == "(kN/m^2)*(0.1 m)^2"
    with pytest.raises(InputError, match="units: stress = ''"):
        Units(stress="")
    _, _, unlabelled = _read(mpi_tmp_path / "default")
    for name, values in fields.items():
        assert np.array_equal(values, unlabelled[name])
    assert data["peak_pressure"] == default["peak_pressure"] and data["contact_area"] == default["contact_area"]


def test_contact_functions_take_the_problem_and_check_the_result():
    """contact_functions(problem, result) checks the result as report() does — one of an earlier solve of the same
    problem, or of another problem, was drawn with the current normals or crashed deep inside (a review) —; the
    model is taken too (a result of other sizes refused); the fields are the same either way."""
    comm = MPI.COMM_WORLD
    problem, _ = uniform_pressure(comm, 0.05)
    other, _ = uniform_pressure(comm, 0.05, n=(3, 3, 2))
    with problem, other:
        _, result = problem.solve()
        _, foreign = other.solve()
        via_problem = contact_functions(problem, result)
        via_model = contact_functions(problem.model, result)
        assert [f.name for f in via_problem] == [f.name for f in via_model]
        for a, b in zip(via_problem, via_model, strict=True):
            assert np.array_equal(a.x.array, b.x.array)
        for source, res, match in [(problem, foreign, "not one of this problem's solve"),
                                   (problem, "x", "result = 'x'"), (object(), result, "object given"),
                                   (problem.model, foreign, "not one of this model's"),
                                   (problem.model, None, "result = NoneType")]:
            with pytest.raises(InputError, match=f"contact_functions: .*{match}"):
                contact_functions(source, res)
        problem.solve()
        with pytest.raises(InputError, match="contact_functions: the result of an earlier solve"):
            contact_functions(problem, result)


def test_the_report_reads_and_refuses_nodes_no_support_holds():
    """From a review: str(report) was the dataclass repr (59 k characters for 169 nodes), now a few lines; node blocks
    that no boundary condition holds gave the reaction [0, 0, 0] without a word, now an InputError; contact_radius
    took a normal of length 1e-300 or 1e308 for no direction."""
    comm = MPI.COMM_WORLD
    problem, bcs = uniform_pressure(comm, 0.05)
    with problem:
        _, result = problem.solve()
        report = problem.report(result)
        text = str(report)
        assert len(text.splitlines()) <= 4 and "contact force on the body" in text
        assert "of 20 contact nodes in contact" in text and len(text) < 1000
        x = problem.model.V.tabulate_dof_coordinates()
        n = problem.model.V.dofmap.index_map.size_local
        top = np.flatnonzero(np.isclose(x[:n, 2], 0.5) & (x[:n, 0] > 1e-9) & (x[:n, 1] > 1e-9)).astype(np.int32)
        rollers = np.flatnonzero(np.isclose(x[:n, 0], 0.0) & (x[:n, 2] > 1e-9)).astype(np.int32)
        with pytest.raises(InputError, match=r"reactions\['top'\]: none of its \d+ node\(s\) is held"):
            problem.report(result, reactions={"top": top, "rollers": rollers})
        held = problem.report(result, reactions={"rollers": rollers}).reactions["rollers"]
        assert np.all(np.isfinite(held))
        radius = report.contact_radius([0.5, 0.375, 0.0], [0.0, 0.0, 1.0])
        for tiny in ([0.0, 0.0, 1e-300], [0.0, 0.0, 1e308]):
            assert report.contact_radius([0.5, 0.375, 0.0], tiny) == radius


def test_sphere_pressure_field_is_the_report(mpi_tmp_path):
    """A rigid sphere pressed 0.01 into a block: the XDMF contact_pressure is report.nodes.pressure at every contact
    node, contact_traction's normal part is it, and summary.json's area and peak (with its node) are the report's."""
    comm = MPI.COMM_WORLD
    n, radius, depth = 12, 0.5, 0.01
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], [1, 1, 0.5]], [n, n, n // 2], dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    tags = _tags(msh, {TOP: lambda x: np.isclose(x[2], 0.5)})
    bottom = dolfinx.fem.locate_dofs_topological(
        V, 2, dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0)))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), bottom, V)
    a, _ = _elasticity(V)
    ball = Sphere(center=[0.5, 0.5, 0.5 + radius], radius=radius, displacement=[0, 0, -depth], name="ball")
    with ContactProblem(a, None, bcs=[clamp], contact=(tags, [TOP]), friction=0.3, obstacles=[ball],
                        petsc_options_prefix="sphp_") as problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result)
        out = mpi_tmp_path / "sphere"
        data = write_results(out, problem, result)
    comm.barrier()
    _, x, fields = _read(out)
    contact = fields["contact_state"] >= 0
    nodes = report.nodes
    # both orders are lexicographic in the (rounded) reference coordinates
    assert np.allclose(x[contact], nodes.coordinates, atol=1e-12)
    assert np.allclose(fields["contact_pressure"][contact], nodes.pressure, rtol=1e-12, atol=0)
    assert np.allclose(fields["contact_force"][contact], nodes.force, rtol=1e-12, atol=1e-15)
    normal_traction = np.einsum("ij,ij->i", fields["contact_traction"][contact], nodes.normal)
    assert np.allclose(normal_traction, nodes.pressure, rtol=1e-10, atol=1e-12 * nodes.pressure.max())
    closed = nodes.closed
    assert closed.sum() == data["contact_nodes"] > 4
    assert np.isclose(data["contact_area"], nodes.area[closed].sum(), rtol=1e-12)
    peak = np.argmax(nodes.pressure)
    assert data["peak_pressure"] == nodes.pressure.max()
    assert np.allclose(data["peak_pressure_at"], nodes.coordinates[peak], atol=1e-12)
    # the peak is under the sphere's centre (symmetric patch: the first of the tied nodes in x1, x2)
    assert np.linalg.norm(np.asarray(data["peak_pressure_at"][:2]) - 0.5) <= 1.5 / n
    assert data["obstacles"]["ball"]["peak_pressure"] == data["peak_pressure"]
    assert np.allclose(data["obstacles"]["ball"]["force"], report.obstacle_forces["ball"], rtol=1e-10)
    # the stress maxima: a brute force over every written vertex (the eigenvalues of all the tensors)
    principal = np.linalg.eigvalsh(fields["stress"].reshape(-1, 3, 3))
    shear = 0.5 * (principal[:, -1] - principal[:, 0])
    assert data["max_shear"] == shear.max() > 0 and data["max_von_mises"] == fields["von_mises"].max()
    first = np.flatnonzero(shear >= shear.max() * (1 - 1e-9))[0]  # rows are in lexicographic order
    assert np.allclose(data["max_shear_at"], x[first], atol=1e-12)


def test_uniaxial_stress_and_von_mises():
    """The block under uniform pressure p: σ = −p e₃ ⊗ e₃ and von Mises = p at every vertex to round-off (the
    lumped projection reproduces a uniform stress), from the law read off the bilinear form; a term in v itself
    (an elastic foundation k u·v dx) does not enter the stress; the law given per subdomain (dx(1) + dx(2)) gives
    the same stress."""
    comm = MPI.COMM_WORLD
    p = 0.05
    problem, _ = uniform_pressure(comm, p)
    with problem:
        uh, result = problem.solve()
        assert result.converged
        a = problem.model.a_ufl
        stress = stress_from_form(a, uh)
        sigma, mises = stress_functions(stress, uh.function_space.mesh)
        test, trial = sorted(a.arguments(), key=lambda w: w.number())
        with_foundation = stress_from_form(a + 3.0 * ufl.inner(trial, test) * ufl.dx, uh)
        _, mises_foundation = stress_functions(with_foundation, uh.function_space.mesh)
        # the law given body by body, dx(1) + dx(2) over two halves of the block (cell tags)
        msh = uh.function_space.mesh
        cells = np.arange(msh.topology.index_map(3).size_local + msh.topology.index_map(3).num_ghosts, dtype=np.int32)
        halves = np.where(dolfinx.mesh.compute_midpoints(msh, 3, cells)[:, 0] < 0.5, 1, 2).astype(np.int32)
        dx = ufl.Measure("dx", domain=msh, subdomain_data=dolfinx.mesh.meshtags(msh, 3, cells, halves))
        (integral,) = a.integrals()
        split = stress_from_form(integral.integrand() * dx(1) + integral.integrand() * dx(2), uh)
        sigma_split, _ = stress_functions(split, msh)
    exact = np.zeros(9)
    exact[8] = -p
    owned = sigma.function_space.dofmap.index_map.size_local
    values = sigma.x.array.reshape(-1, 9)
    assert values.shape[0] == mises.x.array.size
    assert np.abs(values - exact).max() <= 1e-9 * p
    assert np.abs(mises.x.array - p).max() <= 1e-9 * p
    assert np.abs(mises_foundation.x.array - p).max() <= 1e-9 * p
    assert np.abs(sigma_split.x.array.reshape(-1, 9) - exact).max() <= 1e-9 * p
    assert comm.allreduce(owned) == mises.function_space.dofmap.index_map.size_global
