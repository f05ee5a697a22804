"""The reaction of every kind of support, against an assembly of our own (1 and 2 ranks).

A reaction is K u − l (K and l assembled without boundary conditions; minus the contact forces acting on the
same DOFs) summed over the DOFs the support HOLDS, component by component. Checked for a condition on
``V.sub(i)`` (one component, prescribed non-zero), rollers (``V.sub(i)`` held at 0, in the API and as a
scene's ``[roller]``, also in path.csv along a load path), clamped and prescribed-vector supports, supports named
by node blocks, a DOF named by two groups, and a condition of another problem (refused). The reference
(tests/model/reaction_reference.py) uses DOLFINx's assembled matrix, not the library's residual.

The statics a user checks: a block on a rigid plane under gravity, held in plane strain by rollers on its two
faces normal to x2 (so u2 = 0 and every slip is along x1) and pushed along the plane by a one-component
prescribed displacement of its face x1 = 0 far enough that every contact node slides: the push's reaction is
F × weight (Coulomb on every node, Σ λ = weight), the rollers carry equal and opposite x2 forces (the plane
strain stress σ22) and nothing in x1 or x3.
"""

from __future__ import annotations

import json

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from reaction_reference import assembled_reactions, bc_dofs, held_dofs

from fenics_coulomb import ContactProblem, Plane, write_results
from fenics_coulomb.errors import InputError
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene

E, NU, WEIGHT_DENSITY = 1000.0, 0.3, 1.0
SIZE = (1.0, 1.0, 0.5)


def lame(V, E=E, nu=NU):
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    return ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx


def block(comm, n=(8, 8, 4), cell=dolfinx.mesh.CellType.hexahedron):
    """The block [0, 1] × [0, 1] × [0, 0.5] on the plane x3 = 0 (its bottom, tag 1, is the contact boundary),
    under its weight (density × g = 1): the space, the forms and the facet tags."""
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], list(SIZE)], list(n), cell)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 1, np.int32))
    gravity = dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -WEIGHT_DENSITY]))
    L = ufl.inner(gravity, ufl.TestFunction(V)) * ufl.dx
    return V, lame(V), L, tags


def face(V, axis, value):
    return dolfinx.mesh.locate_entities_boundary(V.mesh, 2, lambda x: np.isclose(x[axis], value))


def contact_forces(problem, result):
    """The contact forces on the owned nodes, shape (owned nodes, 3) (zero off the contact nodes)."""
    n = problem.V.dofmap.index_map.size_local
    out = np.zeros((n, 3))
    out[problem.model.contact.blocks] = result.contact_force
    return out


@pytest.mark.parametrize(("friction", "rollers"), [(0.1, ("front", "back")), (0.3, ("front", "back")),
                                                   (0.3, ("front",))])
def test_a_block_pushed_along_a_plane_by_one_component(friction, rollers):
    """The push (``V.sub(0)``, prescribed 0.01) and the rollers (``V.sub(1)`` at 0) react in the components they
    hold only, and equal our own assembly over their DOFs (1e-10 of the push), also at the nodes of the edges
    that both hold (one component each); the supports, the plane and the weight balance. In plane strain
    (rollers on both faces) the push is F × weight once every node slides (1e-6) and the rollers' x2 forces
    are equal and opposite; with one roller the slip turns slightly out of x1 and the push is a little less."""
    comm = MPI.COMM_WORLD
    V, a, L, tags = block(comm)
    push_dofs = dolfinx.fem.locate_dofs_topological(V.sub(0), 2, face(V, 0, 0.0))
    dofs = {"push": push_dofs,
            "front": dolfinx.fem.locate_dofs_topological(V.sub(1), 2, face(V, 1, 0.0)),
            "back": dolfinx.fem.locate_dofs_topological(V.sub(1), 2, face(V, 1, SIZE[1]))}
    dofs = {name: dofs[name] for name in ("push", *rollers)}
    bcs = {"push": dolfinx.fem.dirichletbc(PETSc.ScalarType(0.01), push_dofs, V.sub(0)),
           **{name: dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), dofs[name], V.sub(1)) for name in rollers}}
    with ContactProblem(a, L, list(bcs.values()), contact=(tags, [1]), friction=friction, obstacles=[Plane()],
                        settings={"rtol": 1e-12}, petsc_options_prefix="push_") as problem:
        _, result = problem.solve()
        assert result.converged and result.counts["slip"] == problem.p > 0
        report = problem.report(result, reactions=bcs)
        ours = assembled_reactions(a, L, result.displacement, dofs, comm, minus=contact_forces(problem, result))
    weight = -report.applied_load[2]
    assert np.isclose(weight, WEIGHT_DENSITY * np.prod(SIZE), rtol=1e-12)
    r = report.reactions
    for name, value in ours.items():
        assert np.allclose(r[name], value, rtol=0, atol=1e-10 * weight), name
        held = 0 if name == "push" else 1
        assert np.all(np.delete(r[name], held) == 0.0), name
    total = sum(r.values()) + report.total_force + report.applied_load
    assert np.linalg.norm(total) <= 1e-8 * weight
    if rollers == ("front", "back"):
        assert abs(r["push"][0] - friction * weight) <= 1e-6 * friction * weight, r["push"]
        assert r["front"][1] > 0 > r["back"][1] and abs(r["front"][1] + r["back"][1]) <= 1e-8 * weight
    else:
        assert 0.99 * friction * weight < r["push"][0] < friction * weight


def test_clamped_prescribed_and_node_blocks():
    """A tetrahedral block on the plane, clamped on its face x1 = 1 and its top prescribed to a vector (minus the
    clamped nodes): each support's reaction equals our assembly over its DOFs; naming the supports by their node
    blocks gives the same numbers; a DOF named by two groups counts once (in the first); a condition of another
    problem is refused on every rank."""
    comm = MPI.COMM_WORLD
    V, a, L, tags = block(comm, n=(6, 6, 3), cell=dolfinx.mesh.CellType.tetrahedron)
    clamp_blocks = dolfinx.fem.locate_dofs_topological(V, 2, face(V, 0, SIZE[0]))
    top_blocks = np.setdiff1d(dolfinx.fem.locate_dofs_topological(V, 2, face(V, 2, SIZE[2])),
                              clamp_blocks).astype(np.int32)
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), clamp_blocks, V)
    top = dolfinx.fem.dirichletbc(np.array([0.002, 0.001, -0.005]), top_blocks, V)
    other = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0),
                                    dolfinx.fem.locate_dofs_topological(V.sub(2), 2, face(V, 0, 0.0)), V.sub(2))
    with ContactProblem(a, L, [clamp, top], contact=(tags, [1]), friction=0.3, obstacles=[Plane()],
                        settings={"rtol": 1e-12}, petsc_options_prefix="clamp_") as problem:
        _, result = problem.solve()
        assert result.converged and result.counts["open"] < problem.p
        by_bc = problem.report(result, reactions={"clamp": clamp, "top": top}).reactions
        by_blocks = problem.report(result, reactions={"clamp": clamp_blocks, "top": top_blocks}).reactions
        twice = problem.report(result, reactions={"top": top,
                                                  "both": np.union1d(clamp_blocks, top_blocks)}).reactions
        report = problem.report(result)
        ours = assembled_reactions(a, L, result.displacement, {"clamp": held_dofs(V, clamp_blocks),
                                                                "top": held_dofs(V, top_blocks)}, comm,
                                   minus=contact_forces(problem, result))
        with pytest.raises(InputError, match=r"reactions\['x'\]: a DirichletBC that is not one of the problem"):
            problem.report(result, reactions={"x": other})
        with pytest.raises(InputError, match=r"reactions\['x'\]"):
            problem.report(result, reactions={"x": "left"})
    scale = np.linalg.norm(by_bc["top"])
    assert scale > 0
    for name in ("clamp", "top"):
        assert np.allclose(by_bc[name], ours[name], rtol=0, atol=1e-10 * scale), name
        assert np.allclose(by_blocks[name], by_bc[name], rtol=0, atol=1e-13 * scale), name
    assert np.array_equal(twice["top"], by_bc["top"])
    assert np.allclose(twice["both"], by_bc["clamp"], rtol=0, atol=1e-13 * scale)
    total = by_bc["clamp"] + by_bc["top"] + report.total_force + report.applied_load
    assert np.linalg.norm(total) <= 1e-8 * scale


SCENE = """
[body]
lev = 2
gap = "d3"
clamped = []
[tractions]
[prescribed]
top = [0.004, 0.0, -0.03]
[roller]
left = [0]
sides = [1]
right = [0, 2]
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

ROLLERS = {"left": [0], "sides": [1], "right": [0, 2]}


def test_scene_rollers_in_summary_json(mpi_tmp_path):
    """A scene's [roller] supports (one and two components) and a [prescribed] one, written by write_results
    as the command line writes them: each reaction in summary.json equals our assembly over the held
    components of the boundary's nodes and is exactly 0 in the components the roller leaves free."""
    comm = MPI.COMM_WORLD
    path = mpi_tmp_path / "rollers.toml"
    if comm.rank == 0:
        path.write_text(SCENE)
    comm.barrier()
    built = build_problem(Scene.from_toml(path))
    with built.problem as problem:
        _, result = problem.solve()
        assert result.converged and result.counts["open"] < problem.p
        data = write_results(mpi_tmp_path / "out", problem, result, reactions=built.dirichlet_groups)
        a, L = built.forms
        groups = built.dirichlet_groups
        supports = {name: bc_dofs(groups[name]) for name in groups}
        for name in groups:  # each support holds its own components only
            assert set(np.unique(supports[name] % 3)) <= set(ROLLERS.get(name, (0, 1, 2))), name
        ours = assembled_reactions(a, L, result.displacement, supports, comm, minus=contact_forces(problem, result))
    written = json.loads((mpi_tmp_path / "out" / "summary.json").read_text())
    assert written["reactions"] == data["reactions"]
    reactions = {name: np.asarray(v) for name, v in data["reactions"].items()}
    assert set(reactions) == {"top", *ROLLERS}
    scale = np.linalg.norm(reactions["top"])
    for name, value in reactions.items():
        assert np.allclose(value, ours[name], rtol=0, atol=1e-10 * scale), name
        free = np.setdiff1d([0, 1, 2], ROLLERS.get(name, [0, 1, 2]))
        assert np.all(value[free] == 0.0), name
    assert abs(reactions["left"][0]) > 1e-3 * scale and abs(reactions["right"][2]) > 1e-6 * scale
    total = sum(reactions.values()) + np.asarray(data["contact_force"]) + np.asarray(data["applied_load"])
    assert np.linalg.norm(total) <= 1e-8 * scale


def test_scene_rollers_along_a_load_path(mpi_tmp_path):
    """The same scene on the command line in two steps (``--steps 2``): every row of path.csv has the rollers'
    reactions in their own components only, and each step balances (supports + floor + load = 0); the last
    step's reactions are summary.json's."""
    import csv

    from fenics_coulomb.cli import main

    comm = MPI.COMM_WORLD
    path, out = mpi_tmp_path / "rollers.toml", mpi_tmp_path / "path"
    if comm.rank == 0:
        path.write_text(SCENE)
    comm.barrier()
    assert main(["--scene", str(path), "--out", str(out), "--steps", "2", "--no-plots", "--quiet"]) == 0
    comm.barrier()
    rows = list(csv.DictReader((out / "path.csv").read_text().splitlines()))
    data = json.loads((out / "summary.json").read_text())
    assert len(rows) == 2
    for row in rows:
        reactions = {name: np.array([float(row[f"reaction_{name}_{c} [GPa*L^2]"]) for c in "xyz"])
                     for name in ("top", *ROLLERS)}
        for name, held in ROLLERS.items():
            assert np.all(np.delete(reactions[name], held) == 0.0), name
        contact = np.array([float(row[f"contact_force_{c} [GPa*L^2]"]) for c in "xyz"])
        scale = np.linalg.norm(reactions["top"])
        assert np.linalg.norm(sum(reactions.values()) + contact) <= 1e-8 * scale  # no applied load
    assert [float(rows[-1][f"reaction_left_{c} [GPa*L^2]"]) for c in "xyz"] == data["reactions"]["left"]
