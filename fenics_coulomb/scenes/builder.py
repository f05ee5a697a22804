"""From a scene (pure data) to the forms, the boundary conditions and a :class:`ContactProblem`.

This is the only place where the command line's model is built; the scene's material is isotropic (the
Lamé operator in UFL), its Dirichlet boundaries are clamped (u = 0), prescribed or rollers, its loads are
tractions per boundary (constants or expressions) and a constant body force. The load form and the prescribed
values are built on coefficients (:class:`fenics_coulomb.scenes.loads.StepLoads`) that a load path changes in place
between solves.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Sequence
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import check_all
from fenics_coulomb.model.materials import Material, epsilon, sigma
from fenics_coulomb.model.pairs import ContactPair
from fenics_coulomb.problem import ContactProblem
from fenics_coulomb.scenes.cuboid import GAP_PROFILES, Body, GapFunction, create_cuboid
from fenics_coulomb.scenes.meshes import read_gmsh_tags
from fenics_coulomb.scenes.loads import StepLoads, scene_state, step_state
from fenics_coulomb.scenes.scene import Scene, held_components
from fenics_coulomb.settings import COMMAND_PREFIX, START_RULES

__all__ = ["QUADRATURE_DEGREE", "cuboid_gap", "build_body", "lame_fields", "isotropic_forms", "boundary_nodes",
           "clamp", "dirichlet_conditions", "Built", "build_problem"]

#: 2×2×2 Gauss points (degree 2), the standard rule for trilinear hexahedra and exact for linear tetrahedra;
#: UFL's estimate for the non-affine hexahedra of Ω(d) would be far more expensive.
QUADRATURE_DEGREE = 2


def cuboid_gap(scene: Scene) -> str | GapFunction:
    """The gap profile of a cuboid scene: a profile's name or the scene's expression d(x1, x2)."""
    spec = scene.body
    return spec.gap if spec.gap in GAP_PROFILES else spec.gap_function()


def build_body(scene: Scene, comm: MPI.Comm) -> Body:
    """Create the mesh and its named boundary tags (collective)."""
    spec = scene.body
    if spec.shape == "cuboid":
        body = create_cuboid(comm, spec.lev, cuboid_gap(scene))
    else:
        assert spec.mesh is not None  # validate() requires it for shape = "mesh"
        msh, cell_tags, facet_tags = read_gmsh_tags(spec.mesh, comm)
        present = np.unique(np.concatenate(comm.allgather(np.unique(facet_tags.values))))
        missing = [f"{n} = {t}" for n, t in scene.boundaries.items() if t not in present]
        check_all(comm, not missing, f"mesh {spec.mesh!r} has no facets tagged {', '.join(missing)}")
        volumes = np.unique(np.concatenate(comm.allgather(np.unique(cell_tags.values))))
        missing = [f"{n} = {t}" for n, t in scene.bodies.items() if t not in volumes]
        check_all(comm, not missing, f"mesh {spec.mesh!r} has no cells tagged {', '.join(missing)} (its volume "
                  f"tags: {', '.join(map(str, volumes))})")
        cells = msh.topology.index_map(msh.topology.dim).size_global
        body = Body(mesh=msh, facet_tags=facet_tags, boundaries=dict(scene.boundaries),
                    description=f"mesh {Path(spec.mesh).name} ({cells} cells)", cell_tags=cell_tags)
    body.dirichlet = list(spec.clamped)
    body.contact = list(spec.contact)
    return body


def lame_fields(V: dolfinx.fem.FunctionSpace, material: Material, cell_tags: dolfinx.mesh.MeshTags,
                bodies: dict[int, Material]) -> tuple[dolfinx.fem.Function, dolfinx.fem.Function]:
    """μ and λ as piecewise-constant (DG0) fields: ``material`` everywhere, ``bodies[tag]`` on the cells tagged
    ``tag``."""
    msh = V.mesh
    Q = dolfinx.fem.functionspace(msh, ("DG", 0))
    mu, lmbda = dolfinx.fem.Function(Q, name="mu"), dolfinx.fem.Function(Q, name="lambda")
    mu.x.array[:], lmbda.x.array[:] = material.lame
    for tag, body_material in bodies.items():
        dofs = Q.dofmap.list[cell_tags.find(tag)].ravel()
        mu.x.array[dofs], lmbda.x.array[dofs] = body_material.lame
    mu.x.scatter_forward()
    lmbda.x.scatter_forward()
    return mu, lmbda


def isotropic_forms(
    V: dolfinx.fem.FunctionSpace,
    material: Material,
    facet_tags: dolfinx.mesh.MeshTags,
    tractions: dict[int, tuple[Any, Any, Any]],
    body_force: tuple[float, float, float] = (0.0, 0.0, 0.0),
    cell_tags: dolfinx.mesh.MeshTags | None = None,
    bodies: dict[int, Material] | None = None,
) -> tuple[ufl.Form, ufl.Form]:
    """The Lamé bilinear form and the load form (tractions per facet tag: constants, or callables of points
    x (shape (3, m)) interpolated into P1; a constant body force). With ``bodies`` (cell tag → material) the
    Lamé parameters are piecewise constant fields (:func:`lame_fields`), else Constants."""
    msh = V.mesh
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=facet_tags)
    dx = ufl.Measure("dx", domain=msh, metadata={"quadrature_degree": QUADRATURE_DEGREE})
    if bodies:
        assert cell_tags is not None, "materials per body need the cell tags"
        mu_c, lmbda_c = lame_fields(V, material, cell_tags, bodies)
    else:
        mu, lmbda = material.lame
        mu_c = dolfinx.fem.Constant(msh, PETSc.ScalarType(mu))
        lmbda_c = dolfinx.fem.Constant(msh, PETSc.ScalarType(lmbda))
    a = ufl.inner(sigma(u, mu_c, lmbda_c), epsilon(v)) * dx
    f = dolfinx.fem.Constant(msh, np.asarray(body_force, dtype=PETSc.ScalarType))
    L = ufl.inner(f, v) * ufl.dx
    for tag, value in tractions.items():
        if any(callable(c) for c in value):  # expressions in x1, x2, x3: interpolated into P1
            g = dolfinx.fem.Function(V)
            g.interpolate(lambda x, value=value: np.vstack(
                [c(x) if callable(c) else np.full(x.shape[1], float(c)) for c in value]))
            L = L + ufl.inner(g, v) * ds(tag)
        else:
            L = L + ufl.inner(dolfinx.fem.Constant(msh, np.asarray(value, dtype=PETSc.ScalarType)), v) * ds(tag)
    return a, L


def boundary_nodes(V: dolfinx.fem.FunctionSpace, body: Body, names: list[str], what: str) -> np.ndarray:
    """Local DOF blocks (owned and ghost) on the named boundaries; InputError on every rank if none."""
    fdim = body.mesh.topology.dim - 1
    tags = [body.tag(name) for name in names]
    facets = np.hstack([body.facet_tags.find(t) for t in tags]).astype(np.int32)
    dofs = dolfinx.fem.locate_dofs_topological(V, fdim, facets)
    count = body.mesh.comm.allreduce(int(np.sum(dofs < V.dofmap.index_map.size_local)), op=MPI.SUM)
    check_all(body.mesh.comm, count > 0, f"the {what} boundary {names} has no nodes")
    return dofs


def clamp(V: dolfinx.fem.FunctionSpace, body: Body) -> dolfinx.fem.DirichletBC:
    """u = 0 on the body's clamped boundaries; InputError on every rank if they hold no node."""
    dofs = boundary_nodes(V, body, body.dirichlet, "clamped")
    return dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), dofs, V)


def dirichlet_conditions(V: dolfinx.fem.FunctionSpace, body: Body, scene: Scene,
                         prescribed: dict[str, dolfinx.fem.Constant] | None = None,
                         prescribed_components: dict[str, list[dolfinx.fem.Constant]] | None = None,
                         ) -> tuple[list[dolfinx.fem.DirichletBC], dict[str, list[dolfinx.fem.DirichletBC]]]:
    """The scene's clamped, prescribed and roller conditions, and per boundary name the conditions it owns (for
    its reaction force).

    Each component of a node takes the first of the boundaries that hold it, in the order clamped, prescribed
    (in scene order), roller: a clamped boundary wins over a prescribed one on shared edges, and a node on two
    boundaries that hold different components (the edge of two symmetry planes, a roller beside a face
    prescribed in one component) is held in both. ``prescribed`` (boundary name → a vector Constant) makes the
    prescribed conditions hold those Constants (changed in place along a load path) instead of the scene's fixed
    values; a prescribed component of a node that an earlier boundary holds in another component is a condition
    on ``V.sub(i)`` holding the scalar Constant of ``prescribed_components`` (set with the vector).
    """
    bcs: list[dolfinx.fem.DirichletBC] = []
    groups: dict[str, list[dolfinx.fem.DirichletBC]] = {}
    fdim = body.mesh.topology.dim - 1
    imap = V.dofmap.index_map
    taken = np.zeros((imap.size_local + imap.num_ghosts, 3), dtype=bool)  # (node, component) held already
    if body.dirichlet:
        dofs = boundary_nodes(V, body, body.dirichlet, "clamped")
        bc = dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), dofs, V)
        bcs.append(bc)
        groups[",".join(body.dirichlet)] = [bc]
        taken[dofs] = True

    def hold_components(name: str, blocks: npt.NDArray[np.int32], components: Sequence[int],
                        value: Any) -> list[dolfinx.fem.DirichletBC]:
        """Conditions on the components ``components`` of ``blocks`` no earlier boundary holds (``value(c)``: the
        held value of component c)."""
        facets = body.facet_tags.find(body.tag(name))
        out = []
        for c in components:
            sub = V.sub(int(c))
            sub_dofs = dolfinx.fem.locate_dofs_topological(sub, fdim, facets)
            sub_dofs = sub_dofs[np.isin(sub_dofs // 3, blocks) & ~taken[sub_dofs // 3, int(c)]]
            out.append(dolfinx.fem.dirichletbc(value(int(c)), sub_dofs.astype(np.int32), sub))
        return out

    for name, value in scene.prescribed.items():
        nodes = boundary_nodes(V, body, [name], "prescribed")
        components = held_components(value)

        def component_value(c: int, name: str = name, value: Any = value) -> Any:
            return prescribed_components[name][c] if prescribed_components is not None else \
                PETSc.ScalarType(value[c])

        if len(components) == 3:
            # the nodes no earlier boundary holds in any component take the vector condition (as a clamped one)
            whole = nodes[~taken[nodes].any(axis=1)].astype(np.int32)
            held = prescribed[name] if prescribed is not None else np.asarray(value, dtype=PETSc.ScalarType)
            own = [dolfinx.fem.dirichletbc(held, whole, V)]
            partly = nodes[taken[nodes].any(axis=1) & ~taken[nodes].all(axis=1)].astype(np.int32)
            if body.mesh.comm.allreduce(partly.size, op=MPI.SUM):
                own += hold_components(name, partly, components, component_value)
        else:  # "free" components: a condition on each held component (V.sub(i)) of the boundary's nodes
            own = hold_components(name, nodes.astype(np.int32), components, component_value)
        bcs.extend(own)
        groups[name] = own
        taken[nodes[:, None], np.asarray(components, dtype=np.int64)[None, :]] = True
    for name, components in scene.roller.items():
        nodes = boundary_nodes(V, body, [name], "roller")
        own = hold_components(name, nodes.astype(np.int32), [int(c) for c in components],
                              lambda c: PETSc.ScalarType(0.0))
        bcs.extend(own)
        groups[name] = own
        taken[nodes[:, None], np.asarray(components, dtype=np.int64)[None, :]] = True
    return bcs, groups


@dataclass
class Built:
    """A scene made concrete: the body, the forms (a, L), the boundary conditions and the problem (which
    owns the PETSc objects: destroy it, or use it as a context manager)."""

    body: Body
    forms: tuple[ufl.Form, ufl.Form]
    bcs: list[dolfinx.fem.DirichletBC]
    problem: ContactProblem
    #: Wall time of building the body (mesh and facet tags) on this rank.
    mesh_time: float = 0.0
    #: Local DOF blocks per Dirichlet boundary name (for the reactions).
    dirichlet_groups: dict[str, list[dolfinx.fem.DirichletBC]] | None = None
    #: The load coefficients (tractions, body force, prescribed values) a load path sets for each step.
    loads: StepLoads | None = None


def build_problem(scene: Scene, comm: MPI.Comm = MPI.COMM_WORLD, petsc_options_prefix: str = COMMAND_PREFIX,
                  petsc_options: dict[str, Any] | None = None) -> Built:
    """Turn a scene into its body, forms, boundary conditions and ContactProblem (collective)."""
    scene.validate()
    t0 = time.perf_counter()
    body = build_body(scene, comm)
    mesh_time = time.perf_counter() - t0
    material = scene.material.material()
    V = dolfinx.fem.functionspace(body.mesh, ("Lagrange", 1, (body.mesh.geometry.dim,)))
    per_body = {scene.bodies[name]: section.material() for name, section in scene.materials.items()}
    a, _ = isotropic_forms(V, material, body.facet_tags, {}, cell_tags=body.cell_tags, bodies=per_body)
    states = [step_state(scene, step) for step in scene.path]
    names = {name for state in states for name in state.tractions} | set(scene.traction_table())
    loads = StepLoads(V, body.facet_tags, {name: body.tag(name) for name in names}, scene_state(scene), states)
    L = loads.form(ufl.TestFunction(V))
    bcs, groups = dirichlet_conditions(V, body, scene, loads.prescribed, loads.prescribed_components)
    friction = float(scene.friction.coefficient)
    changes: dict[str, Any] = {}
    if scene.start in START_RULES and scene.solver.start != scene.start:  # a start file is the solve's u0 instead
        changes["start"] = scene.start
    if scene.solver.poisson_ratio is None:  # the preconditioner policy knows nearly incompressible bodies
        changes["poisson_ratio"] = max([float(material.poisson)] + [float(m.poisson) for m in per_body.values()])
    settings = dataclasses.replace(scene.solver, **changes) if changes else scene.solver
    if scene.contact_pairs:
        pairs = [ContactPair(body.facet_tags, slave=[body.tag(n) for n in q.slave],
                             master=[body.tag(n) for n in q.master],
                             friction=friction if q.friction is None else float(q.friction),
                             search_distance=q.search_distance, name=q.name, method=q.method)
                 for q in scene.contact_pairs]
        contact = (body.facet_tags, [body.tag(name) for name in body.contact]) if scene.obstacles else None
        problem = ContactProblem(a, L, bcs=bcs, contact=contact, friction=friction,
                                 obstacles=scene.obstacles or None, contact_pairs=pairs, settings=settings,
                                 petsc_options_prefix=petsc_options_prefix, petsc_options=petsc_options,
                                 sliding=scene.contact.sliding)
    else:
        contact = (body.facet_tags, [body.tag(name) for name in body.contact])
        problem = ContactProblem(a, L, bcs=bcs, contact=contact, friction=friction,
                                 obstacles=scene.obstacles or None, settings=settings,
                                 petsc_options_prefix=petsc_options_prefix, petsc_options=petsc_options,
                                 sliding=scene.contact.sliding)
    return Built(body, (a, L), bcs, problem, mesh_time, groups, loads)
