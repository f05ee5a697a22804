"""Contact quantities as mesh fields and totals: the point fields written to the XDMF file and the contact
statistics of summary.json (contact area, peak pressure and where it is, per obstacle and per contact pair).

One meaning per name, in the XDMF file, summary.json, the CSV files, the figures and
:class:`~fenics_coulomb.report.ContactReport` (units: E's unit, GPa in the scenes, and the mesh's length unit L):

* ``contact_force`` — the nodal contact force on the body, a Cartesian 3-vector (the solver's −Rᵢ zⁱ; GPa·L²);
* ``contact_pressure`` — the normal contact traction, force per area: λ / aᵢ with λ ≥ 0 the normal part of the
  nodal force and aᵢ the node's contact area (:func:`~fenics_coulomb.model.forces.contact_areas`: the lumped
  tributary area ∫ φᵢ ds over the contact boundary, the mortar D_j on a dual mortar pair's slave nodes; GPa) —
  the same numbers as ``problem.report(result).nodes.pressure``;
* ``contact_traction`` — the traction vector, the nodal force per area (GPa);
* ``tangential_force`` — the tangential part of the nodal force (GPa·L²);
* ``contact_area`` — Σ aᵢ over the nodes in contact (stick or slip; L²): each node in contact counts its whole
  tributary area, so on a mesh the area resolves the true one to about half an element ring.
"""

from __future__ import annotations

import weakref
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.dof_values import set_owned_values
from fenics_coulomb.model.forces import block_to_scalar_dofs, contact_areas
from fenics_coulomb.model.obstacles import obstacle_names
from fenics_coulomb.report import nodal_pressure
from fenics_coulomb.io.units import Units
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scd.resolvent import NOT_CONTACT, OPEN, SLIP, STICK, ContactState

__all__ = ["CONTACT_STATES", "FIELD_UNITS", "UNITS", "contact_functions", "contact_statistics", "group_names",
           "stress_from_form", "stress_functions", "stress_statistics"]

#: The units of the outputs by default (the scenes give E in GPa; the mesh's length unit is L): :class:`Units`.
UNITS: dict[str, str] = Units().table()

#: The unit of every point field of solution.xdmf by default ("" for a dimensionless or categorical field).
FIELD_UNITS: dict[str, str] = Units().fields()


def contact_functions(model: Any, result: SolveResult) -> tuple[dolfinx.fem.Function, ...]:
    """The output Functions: displacement, contact_state, contact_pressure (force per area), contact_force
    (nodal force vector), tangential_force, contact_traction (traction vector), gap, contact_normal, stress and
    von_mises (when the bilinear form gives the stress: :func:`stress_from_form`), body (a mesh of several
    bodies: 1, 2, … per connected component, numbered by its smallest mesh-file node index) and master_reaction
    for contact pairs; see the module docstring and :mod:`fenics_coulomb.io.xdmf`.

    ``model``: the ContactProblem that solved ``result`` — which checks that the result is of its last solve, as
    ``report`` does — or its ``model`` (a result of another problem of other sizes is refused; one of an earlier
    state of the same problem cannot be told from it: pass the problem). InputError otherwise, on every rank."""
    from fenics_coulomb.problem import ContactProblem

    if isinstance(model, ContactProblem):
        model.check_result(result, "contact_functions")
        model = model.model
    elif not isinstance(model, ContactModel):
        raise InputError(f"contact_functions: {type(model).__name__} given: give the ContactProblem that solved the "
                         "result")
    elif not isinstance(result, SolveResult):  # (the problem's check_result asks this too)
        raise InputError(f"contact_functions: result = {type(result).__name__}: give the SolveResult of the solve")
    fits = (np.size(result.displacement) == model.V.dofmap.index_map.size_local * 3
            and np.size(result.states) == model.contact.size)
    check_all(model.comm, fits, "contact_functions: the result is not one of this model's (other sizes)")
    V = model.V
    S = model.scalar_space
    cmap = model.contact
    to_scalar = block_to_scalar_dofs(V, S)
    scalar_dofs = to_scalar[cmap.blocks]
    vector_dofs = cmap.local_dofs.ravel()

    def point_field(space: dolfinx.fem.FunctionSpace, name: str, dofs: npt.NDArray[np.int32],
                    values: npt.ArrayLike, fill: float = 0.0) -> dolfinx.fem.Function:
        f = dolfinx.fem.Function(space, name=name)
        f.x.array[:] = fill
        f.x.array[dofs] = np.ravel(values)
        f.x.scatter_forward()  # owned contact nodes were set on their owner: make the ghosts agree
        return f

    u = set_owned_values(dolfinx.fem.Function(V, name="displacement"), result.displacement)
    tangential = np.einsum("iab,ib->ia", cmap.frames[:, :, :2], result.tangential_force)  # t₁, t₂ → x, y, z
    areas = contact_areas(model)
    force = _nodal_forces(result, cmap.size)
    traction = np.divide(force, areas[:, None], out=np.zeros_like(force), where=areas[:, None] > 0)
    fields: tuple[dolfinx.fem.Function, ...] = (
        u,
        point_field(S, "contact_state", scalar_dofs, result.states, fill=float(NOT_CONTACT)),
        point_field(S, "contact_pressure", scalar_dofs, nodal_pressure(result.normal_force, areas)),
        point_field(V, "contact_force", vector_dofs, force),
        point_field(V, "tangential_force", vector_dofs, tangential),
        point_field(V, "contact_traction", vector_dofs, traction),
        point_field(S, "gap", scalar_dofs, result.gap),
        point_field(V, "contact_normal", vector_dofs, cmap.normals),
    )
    stress = _model_stress(model, result)
    if stress is not None:
        fields = (*fields, *stress)
    return (*fields, *model.coupling.output_fields(model, result, S, to_scalar))  # contact pairs: body, reaction


def stress_statistics(model: ContactModel, result: SolveResult) -> dict[str, Any]:
    """The largest von Mises stress and the largest shear stress τ = (σ₁ − σ₃)/2 of the projected stress
    (:func:`stress_functions`) and the reference positions of their vertices (ties: the first in x₁, x₂, x₃;
    collective). Empty when the bilinear form gives no stress (:func:`stress_from_form`)."""
    stress = _model_stress(model, result)
    if stress is None:
        return {}
    sigma, mises = stress
    S = mises.function_space
    owned = S.dofmap.index_map.size_local
    x = S.tabulate_dof_coordinates()[:owned]
    shear = shear_candidates(comm=model.comm, tensors=sigma.x.array[: 9 * owned].reshape(-1, 3, 3),
                             von_mises=np.asarray(mises.x.array[:owned], dtype=np.float64))
    none = np.full(owned, -1, dtype=np.int64)
    out: dict[str, Any] = {}
    for key, values in (("max_von_mises", mises.x.array[:owned]), ("max_shear", shear)):
        peak, where = _peaks(model.comm, np.asarray(values, dtype=np.float64), x, none, 0)
        out[key] = float(peak[0])
        out[f"{key}_at"] = [float(c) for c in where[0]] if peak[0] > 0 else None
    return out


def shear_candidates(comm: MPI.Comm, tensors: npt.NDArray[np.float64],
                     von_mises: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """τ = (σ₁ − σ₃)/2 of the symmetric ``tensors`` (n × 3 × 3) wherever it can be the largest over all ranks, 0
    elsewhere; NaN for a tensor with a non-finite entry (a diverged iterate's; collective).

    With d = σ₁ − σ₃ the two other differences of the principal stresses add up to d, so the von Mises stress
    √(½ Σ differences²) lies in [√3/2 d, d]: τ lies in [σ_vm/2, σ_vm/√3], and a node with σ_vm < √3/2 max σ_vm
    has τ below the largest τ. The eigenvalues are computed where σ_vm ≥ 0.8 max σ_vm (room for round-off):
    the same values at those nodes, far fewer nodes."""
    finite: npt.NDArray[np.bool_] = np.asarray(np.isfinite(tensors).all(axis=(1, 2)))
    largest = comm.allreduce(float(np.max(von_mises, initial=0.0, where=np.isfinite(von_mises))), op=MPI.MAX)
    candidates = ~finite | (von_mises >= 0.8 * largest)
    shear = np.zeros(len(tensors))
    principal = np.linalg.eigvalsh(np.where(finite[candidates, None, None], tensors[candidates], 0.0))
    shear[candidates] = np.where(finite[candidates], 0.5 * (principal[:, -1] - principal[:, 0]), np.nan)
    return shear


def group_names(model: ContactModel) -> tuple[list[str], list[str]]:
    """The names of the obstacles (``name``, or "KIND N" by position as in the report) and of the contact pairs
    (``name``, or "pair N")."""
    obstacles = obstacle_names(model.obstacles)
    pairs = [getattr(q, "name", None) or f"pair {k + 1}" for k, q in enumerate(model.pairs)]
    return obstacles, pairs


def contact_statistics(model: ContactModel, result: SolveResult) -> dict[str, Any]:
    """Contact area, peak pressure and its location, in total, per obstacle and per contact pair (collective;
    the same on every rank).

    The peak's location is the reference position of the node with the largest ``contact_pressure``; among
    nodes within 1e-9 of the peak (a symmetric patch) the lexicographically smallest position (x₁, x₂, x₃, each
    rounded to 1e-9 of the mesh's extent), so that the location does not depend on the partition.

    Returns:
        ``{"contact_area", "contact_nodes" (nodes in contact), "peak_pressure", "peak_pressure_at" (or None
        without contact), "obstacles": {name: {the same keys, "force", the group's keys}}, "contact_pairs":
        [{"name", the same keys, the group's keys}]}``, the group's keys being "nodes", "normal_force" (Σ λ, the
        normal parts of the nodal forces), "tangential_force" (the length of the sum of their tangential parts),
        "open", "stick", "slip" (nodes); units :data:`UNITS`.
    """
    comm = model.comm
    cmap = model.contact
    area = contact_areas(model)
    pressure = nodal_pressure(result.normal_force, area)
    state = np.asarray(result.states, dtype=np.int64).reshape(-1)
    closed = (state != OPEN) & (state != NOT_CONTACT)
    obstacle_names, pair_names = group_names(model)
    n_obstacles = len(obstacle_names)
    group = model.coupling.contact_groups(np.asarray(cmap.obstacle_index, dtype=np.int64), n_obstacles)
    groups = n_obstacles + len(pair_names)
    force = _nodal_forces(result, cmap.size)
    normal = np.asarray(result.normal_force, dtype=np.float64).reshape(-1)
    normal = normal if normal.size == cmap.size else np.zeros(cmap.size)
    tangential = np.asarray(result.tangential_force, dtype=np.float64).reshape(-1, 2) \
        if np.size(result.tangential_force) == 2 * cmap.size else np.zeros((cmap.size, 2))
    tangential = np.einsum("iab,ib->ia", cmap.frames[:, :, :2], tangential)  # t₁, t₂ → x, y, z
    # per group (and the total as the last row): area in contact, nodes in contact, nodes, force, Σ λ, the
    # tangential force vector, open / stick / slip nodes
    local = np.zeros((groups + 1, 13))
    valid = (group >= 0) & (group < groups)
    for target, mask in ((group[valid], valid), (np.full(int(np.count_nonzero(valid)), groups), valid)):
        np.add.at(local[:, 0], target, np.where(closed[mask], area[mask], 0.0))
        np.add.at(local[:, 1], target, closed[mask].astype(float))
        np.add.at(local[:, 2], target, 1.0)
        np.add.at(local[:, 3:6], target, force[mask])
        np.add.at(local[:, 6], target, normal[mask])
        np.add.at(local[:, 7:10], target, tangential[mask])
        for column, code in ((10, OPEN), (11, STICK), (12, SLIP)):
            np.add.at(local[:, column], target, (state[mask] == code).astype(float))
    totals = np.asarray(comm.allreduce(local, op=MPI.SUM))
    peaks, where = _peaks(comm, pressure, np.asarray(cmap.coordinates, dtype=np.float64).reshape(-1, 3),
                          np.where(valid, group, -1), groups)

    def entry(g: int) -> dict[str, Any]:
        return {"contact_area": float(totals[g, 0]), "contact_nodes": int(round(totals[g, 1])),
                "peak_pressure": float(peaks[g]) + 0.0,  # no -0.0 (a pressure of -0 read as a tension)
                "peak_pressure_at": None if peaks[g] <= 0.0 else [float(c) for c in where[g]]}

    def group_entry(g: int) -> dict[str, Any]:
        return {**entry(g), "nodes": int(round(totals[g, 2])), "normal_force": float(totals[g, 6]),
                "tangential_force": float(np.linalg.norm(totals[g, 7:10])),
                **{key: int(round(totals[g, column])) for column, key in ((10, "open"), (11, "stick"), (12, "slip"))}}

    data = entry(groups)
    data["obstacles"] = {name: {**group_entry(i), "force": [float(c) for c in totals[i, 3:6]]}
                         for i, name in enumerate(obstacle_names)}
    data["contact_pairs"] = [{"name": name, **group_entry(n_obstacles + k)} for k, name in enumerate(pair_names)]
    return data


def _peaks(comm: MPI.Comm, pressure: npt.NDArray[np.float64], x: npt.NDArray[np.float64],
           group: npt.NDArray[np.int64], groups: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The largest pressure per group (the last row: over all groups) and the reference position of its node
    (the lexicographically smallest among the nodes within 1e-9 of it; collective)."""
    rows = np.concatenate([group, np.full(group.size, groups)])
    values = np.concatenate([pressure, pressure])
    points = np.concatenate([x, x])
    keep = rows >= 0
    rows, values, points = rows[keep], values[keep], points[keep]
    local = np.zeros(groups + 1)
    np.maximum.at(local, rows, values)
    peak = np.empty_like(local)
    comm.Allreduce(local, peak, op=MPI.MAX)
    near = (peak[rows] > 0.0) & (values >= peak[rows] * (1.0 - 1e-9))
    # positions compared rounded to 1e-9 of the mesh's extent: a generator's round-off (−5e-17 for 0) must not
    # decide which of the tied nodes is first
    scale = comm.allreduce(float(np.abs(x).max(initial=0.0)), op=MPI.MAX) or 1.0
    candidates = np.full((groups + 1, 6), np.inf)
    if near.any():
        r, p = rows[near], points[near]
        key = np.round(p / scale, 9)
        order = np.lexsort((key[:, 2], key[:, 1], key[:, 0], r))  # by group, then lexicographically by position
        r, p, key = r[order], p[order], key[order]
        first = np.r_[True, r[1:] != r[:-1]]
        candidates[r[first], :3] = key[first]
        candidates[r[first], 3:] = p[first]
    every = np.stack(comm.allgather(candidates))  # (ranks, groups + 1, 6)
    where = np.empty((groups + 1, 3))
    for g in range(groups + 1):  # a handful of groups
        c = every[:, g]
        where[g] = c[np.lexsort((c[:, 2], c[:, 1], c[:, 0]))[0], 3:]
    return peak, where


def _nodal_forces(result: SolveResult, size: int) -> npt.NDArray[np.float64]:
    """The Cartesian contact force on the body per owned contact node (zeros when the result has none)."""
    force = np.asarray(result.contact_force, dtype=np.float64)
    return force.reshape(size, 3) if force.size == 3 * size else np.zeros((size, 3))


def stress_from_form(a: ufl.Form, u: dolfinx.fem.Function) -> ufl.core.expr.Expr | None:
    """The stress tensor σ(u) of the constitutive law in the bilinear form ``a`` (a UFL expression, 3 × 3).

    The cell integrand f(w, v) of a(w, v) is linear in the test function v: f = A(w) : ∇v + b(w)·v. With the
    trial function replaced by ``u`` and v by the linear field eᵢ xⱼ (∇v = eᵢ ⊗ eⱼ) and by the constant eᵢ,
    A_ij = f(u, eᵢ xⱼ) − xⱼ f(u, eᵢ) exactly; for elasticity a = ∫ σ(w) : ε(v) dx that is σ_ij(u) (any
    law, per-cell material fields included). Integrals over cell subdomains (a law per body, ``dx(k)``) enter
    with the indicator of their cells (a DG0 field from the measure's cell tags), ``dx`` without an id everywhere.
    Returns None when ``a`` has no cell integral or a subdomain integral without cell tags."""
    cells = [i for i in a.integrals() if i.integral_type() == "cell"]
    if not cells:
        return None
    msh = u.function_space.mesh
    parts = []
    for integral in cells:
        ids = integral.subdomain_id()
        if ids == "everywhere":
            parts.append(integral.integrand())
            continue
        tags = integral.subdomain_data()
        if not isinstance(tags, dolfinx.mesh.MeshTags) or ids == "otherwise":
            return None
        Q = dolfinx.fem.functionspace(msh, ("DG", 0))
        indicator = dolfinx.fem.Function(Q)
        marked = np.isin(tags.values, np.atleast_1d(np.asarray(ids, dtype=np.int64)))
        indicator.x.array[Q.dofmap.list[tags.indices[marked], 0]] = 1.0
        indicator.x.scatter_forward()
        parts.append(indicator * integral.integrand())
    test, trial = sorted(a.arguments(), key=lambda w: w.number())
    integrand = sum(parts[1:], parts[0])
    x = ufl.SpatialCoordinate(msh)
    dim = len(x)

    def unit(i: int, factor: ufl.core.expr.Expr | float) -> ufl.core.expr.Expr:
        return ufl.as_vector([factor if k == i else 0.0 for k in range(dim)])

    def f(v: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        return ufl.replace(integrand, {trial: u, test: v})

    return ufl.as_matrix([[f(unit(i, x[j])) - x[j] * f(unit(i, 1.0)) for j in range(dim)] for i in range(dim)])


def stress_functions(stress: ufl.core.expr.Expr,
                     mesh: dolfinx.mesh.Mesh) -> tuple[dolfinx.fem.Function, dolfinx.fem.Function]:
    """The Cauchy stress and the von Mises stress as point (P1) fields ``stress`` (3 × 3, GPa) and ``von_mises``
    (GPa) by a lumped L2 projection (collective).

    σᵢ = ∫ φᵢ σ dx / ∫ φᵢ dx at every vertex i: the mean of the cellwise stress over the vertex's cells weighted
    by φᵢ. On P1/Q1 the stress of a displacement is discontinuous across cells (constant on a tetrahedron,
    varying within a hexahedron); the lumped projection has positive weights, so it neither overshoots nor
    oscillates at boundaries and kinks like the consistent L2 projection does, needs no linear solve, and
    reproduces a uniform stress exactly. The von Mises stress √(3/2 s : s), s = σ − tr σ / 3 I, is evaluated at
    the vertices from the projected tensor. Like every nodal recovery it smooths a peak over one element."""
    return _StressRecovery(stress, mesh).functions()


def _recovery_quadrature(mesh: dolfinx.mesh.Mesh) -> dict[str, int]:
    """The quadrature of the lumped stress projection: UFL's estimate on simplices (degree 1 for P1: exact), degree 2
    (two Gauss points per direction, exact to degree 3 in each) on hexahedra, where UFL estimates degree 5 (σ(u) of
    :func:`stress_from_form` holds the spatial coordinate).

    Exact on every trilinear hexahedron: in ∫ φᵢ σ dx = ∫ φᵢ C : sym(∑ₐ ∂u/∂Xₐ ⊗ cofₐ(J)) dX the Jacobian's
    determinant cancels, ∂u/∂Xₐ has degree (0, 1, 1) in (Xₐ, X_b, X_c) and the cofactor ∂x/∂X_b × ∂x/∂X_c degree
    (2, 1, 1), so with φᵢ of degree 1 in each the integrand has degree ≤ 3 in each direction; ∫ φᵢ det J dX
    likewise. The same projection, the moments assembled 2.2× faster (the cuboid at lev 8, 1 rank: 0.070 s against
    0.157 s; tests/io/test_stress_recovery.py against a degree-8 rule on distorted cells)."""
    return {} if mesh.topology.cell_type in (dolfinx.mesh.CellType.tetrahedron, dolfinx.mesh.CellType.triangle) \
        else {"quadrature_degree": 2}


class _StressRecovery:
    """The compiled forms of :func:`stress_functions` for one stress expression, assembled again for every state
    of its displacement Function (the load path's steps: no form compiled per step). Holds no PETSc object
    between calls (a cached PETSc vector freed by the collector at different times on different ranks would
    desynchronize them: docs/testing.md)."""

    def __init__(self, stress: ufl.core.expr.Expr, mesh: dolfinx.mesh.Mesh) -> None:
        self.T = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (3, 3)))
        self.S = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))
        dx = ufl.dx(domain=mesh, metadata=_recovery_quadrature(mesh))
        self.moments = dolfinx.fem.form(ufl.inner(stress, ufl.TestFunction(self.T)) * dx)
        mass = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(ufl.TestFunction(self.S) * dx))
        mass.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.mass = mass.getArray(readonly=True).copy()
        mass.destroy()
        #: The owned displacement and the fields of the last :func:`_model_stress` call.
        self.last: tuple[npt.NDArray[np.float64], tuple[dolfinx.fem.Function, dolfinx.fem.Function]] | None = None

    def functions(self) -> tuple[dolfinx.fem.Function, dolfinx.fem.Function]:
        """(stress, von_mises) of the expression's displacement as it is now (collective)."""
        moments = dolfinx.fem.petsc.assemble_vector(self.moments)
        moments.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        # T and S share the scalar P1 dofmap: block k of T is DOF k of S
        sigma = moments.getArray(readonly=True).reshape(-1, 9) / self.mass[:, None]
        moments.destroy()
        owned = sigma.shape[0]
        tensor = dolfinx.fem.Function(self.T, name="stress")
        tensor.x.array[: 9 * owned] = sigma.ravel()
        tensor.x.scatter_forward()
        deviator = (sigma.reshape(-1, 3, 3)
                    - np.einsum("nii->n", sigma.reshape(-1, 3, 3))[:, None, None] / 3 * np.eye(3))
        mises = dolfinx.fem.Function(self.S, name="von_mises")
        mises.x.array[:owned] = np.sqrt(1.5 * np.einsum("nij,nij->n", deviator, deviator))
        mises.x.scatter_forward()
        return tensor, mises


#: Per model: (the displacement Function its stress expression reads, the compiled recovery); None when the
#: bilinear form gives no stress. Weak keys: an entry goes with its model.
_RECOVERIES: weakref.WeakKeyDictionary[ContactModel, tuple[dolfinx.fem.Function, _StressRecovery] | None] = \
    weakref.WeakKeyDictionary()


def _model_stress(model: ContactModel,
                  result: SolveResult) -> tuple[dolfinx.fem.Function, dolfinx.fem.Function] | None:
    """(stress, von_mises) of ``result``'s displacement through the model's compiled recovery (built on first
    use; collective), or None when the bilinear form gives no stress."""
    if model not in _RECOVERIES:
        u = dolfinx.fem.Function(model.V)
        stress = stress_from_form(model.a_ufl, u)
        _RECOVERIES[model] = None if stress is None else (u, _StressRecovery(stress, model.V.mesh))
    entry = _RECOVERIES[model]
    if entry is None:
        return None
    u, recovery = entry
    displacement = np.asarray(result.displacement, dtype=np.float64)
    # the same displacement as the last call (the XDMF fields and summary.json's maxima of one result): its fields
    # again, decided on every rank together (a rank whose part did not move must not skip the collective assembly)
    same = recovery.last is not None and np.array_equal(recovery.last[0], displacement)
    if model.comm.allreduce(same, op=MPI.LAND):
        assert recovery.last is not None
        return recovery.last[1]
    set_owned_values(u, displacement)
    fields = recovery.functions()
    recovery.last = (displacement.copy(), fields)
    return fields


#: Categories of the (categorical) ``contact_state`` field.
CONTACT_STATES: dict[int, str] = {NOT_CONTACT: "not a contact node",
                                  **{int(s): s.name.lower() for s in ContactState}}
