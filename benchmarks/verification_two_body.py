"""The two-body cases of the verification table: Hertz between two elastic bodies, and Cattaneo–Mindlin with β = 0.

Both use the elastic hemisphere on the elastic block of meshes/hemisphere_on_block.py (gmsh tetrahedra refined
toward the contact point, the two bodies meshed apart: non-matching), dual mortar, finite sliding, built through the
API (``ContactProblem`` with a ``ContactPair``, ``problem.report``). The hemisphere (radius R = 1, the slave: its
curved face) is pressed by moving its flat face; the block's bottom is clamped. The derivations are in
docs/verification/README.md (§9 and §6); benchmarks/verification.py puts the rows into the table.

* :func:`hertz_two_bodies`: frictionless, E₁ = 70, ν₁ = 0.35 (hemisphere) on E₂ = 210, ν₂ = 0.3 (block): the
  contact radius a and the peak pressure p₀ against Hertz with the effective modulus 1/E* = Σ (1 − νᵢ²)/Eᵢ for the
  measured force P.
* :func:`cattaneo_mindlin`: a hemisphere of radius 4 on a block, both of ONE material (E = 70, ν = 0.3), so
  Dundurs' β = 0 and the normal and tangential problems uncouple — the condition of Cattaneo's and Mindlin's closed
  form. Pressed with friction F, then the flat face is moved tangentially in increasing steps (a monotonic
  loading): per step the stick radius c against c/a = (1 − Q/(F P))^{1/3} for the measured Q and P.
"""

from __future__ import annotations

import time
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.io.gmshio
import numpy as np
import ufl

from benchmarks.mindlin import separating_radius
from fenics_coulomb import ContactPair, ContactProblem, ContactState
from meshes.hemisphere_on_block import BODIES, TAGS, build

__all__ = ["HERTZ2_LEVELS", "MINDLIN_LEVELS", "LOAD_RATIOS", "hertz_two_bodies", "cattaneo_mindlin",
           "effective_modulus", "hemisphere_mesh", "mindlin_steps"]

R = 1.0
SLIDING = "finite"
#: (E, ν) of the hemisphere (slave) and the block (master) of the Hertz case.
HERTZ_MATERIALS = ((70.0, 0.35), (210.0, 0.3))
#: One material for both bodies in Cattaneo–Mindlin (Dundurs β = 0).
MINDLIN_MATERIAL = (70.0, 0.3)
MINDLIN_FRICTION = 0.3
#: Mesh levels: (element size at the contact, radius of the refined ball / R, largest size).
HERTZ2_LEVELS = {0: (0.06, 0.3, 0.4), 1: (0.04, 0.4, 0.3), 2: (0.028, 0.3, 0.3)}
#: Cattaneo–Mindlin: a hemisphere of radius 4 (a/R ≈ 0.06: on R = 1, a/R = 0.23, the press alone slipped at 10 of
#: 21 closed nodes and c/a came out 14–28 % low); the refined ball 0.35 around the contact (0.0875 R).
MINDLIN_RADIUS = 4.0
#: Level 0 (the fast test's) grows its elements 1.0 per unit distance (to 2.0) instead of 0.22 (to 1.0).
MINDLIN_LEVELS = {0: (0.12, 0.0875, 2.0, 1.0), 1: (0.08, 0.0875, 1.0), 2: (0.04, 0.0875, 1.0)}
#: The approach of the Hertz case and of Cattaneo–Mindlin's press (the flat face moved down).
HERTZ_DELTA, MINDLIN_DELTA = 0.03, 0.0125
#: The tangential loads aimed at (Q/(F P)); the steps are set from Mindlin's compliance, Q is measured.
LOAD_RATIOS = (0.3, 0.7)


def effective_modulus(materials: tuple[tuple[float, float], ...]) -> float:
    """E* of two bodies: 1/E* = Σ (1 − νᵢ²)/Eᵢ."""
    return 1.0 / sum((1 - nu**2) / E for E, nu in materials)


def hemisphere_mesh(comm: MPI.Comm, level: tuple[float, ...], radius: float = R
                    ) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """The hemisphere of ``radius`` on the block [−2R, 2R]² × [−2R, 0] meshed by gmsh on rank 0 at ``level`` =
    (contact size, refined radius / R, largest size[, growth of the size per unit distance]) and distributed
    (collective)."""
    import gmsh

    contact, refined, size = level[:3]
    growth = level[3] if len(level) > 3 else None
    if comm.rank == 0:
        build(contact, None, size=size, radius=radius, half_width=2 * radius, depth=2 * radius, refined=refined,
              growth=growth)
    msh, cell_tags, facet_tags = dolfinx.io.gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0,
                                                                 gdim=3)
    if comm.rank == 0:
        gmsh.finalize()
    return msh, cell_tags, facet_tags


def _elasticity(V: dolfinx.fem.FunctionSpace, cell_tags: dolfinx.mesh.MeshTags,
                materials: tuple[tuple[float, float], tuple[float, float]]) -> ufl.Form:
    """Linear elasticity, (E, ν) of the hemisphere then of the block."""
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    dx = ufl.Measure("dx", domain=V.mesh, subdomain_data=cell_tags)

    def eps(w: Any) -> Any:
        return ufl.sym(ufl.grad(w))

    form = 0
    for body, (E, nu) in zip(("hemisphere", "block"), materials, strict=True):
        mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
        form += ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * dx(BODIES[body])
    return form


class _Hemisphere:
    """The hemisphere on the block as a ContactProblem; the flat face prescribed through ``self.flat``."""

    def __init__(self, comm: MPI.Comm, level: tuple[float, ...],
                 materials: tuple[tuple[float, float], tuple[float, float]], friction: float, prefix: str,
                 rtol: float, radius: float = R):
        msh, cell_tags, facet_tags = hemisphere_mesh(comm, level, radius)
        V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
        bottom = dolfinx.fem.locate_dofs_topological(V, 2, facet_tags.find(TAGS["block_bottom"]))
        flat = dolfinx.fem.locate_dofs_topological(V, 2, facet_tags.find(TAGS["flat"]))
        self.flat = dolfinx.fem.Constant(msh, np.zeros(3))
        bcs = [dolfinx.fem.dirichletbc(np.zeros(3), bottom, V), dolfinx.fem.dirichletbc(self.flat, flat, V)]
        self.pair = ContactPair(facet_tags, slave=TAGS["curved"], master=TAGS["block_top"], friction=friction,
                                search_distance=0.25 * radius, name="hemisphere", method="mortar")
        self.problem = ContactProblem(_elasticity(V, cell_tags, materials), None, bcs, contact_pairs=[self.pair],
                                      settings={"rtol": rtol}, petsc_options_prefix=prefix, sliding=SLIDING)

    def solve(self, displacement: tuple[float, float, float]) -> dict[str, Any]:
        """Solve with the flat face moved by ``displacement``: the forces on the hemisphere, the contact and stick
        radii (the best separating radii of the slave nodes' reference positions), the unknowns (collective)."""
        self.flat.value[:] = displacement
        _, result = self.problem.solve()
        report = self.problem.report(result)
        nodes = report.nodes
        force = np.asarray(report.pair_forces[0]["force_on_slave_body"], dtype=np.float64)
        r = np.hypot(nodes.coordinates[:, 0], nodes.coordinates[:, 1])
        closed = nodes.state != ContactState.OPEN
        stick = nodes.state == ContactState.STICK
        return {"converged": bool(result.converged), "P": float(force[2]), "Q": float(np.hypot(*force[:2])),
                "a": separating_radius(r, closed), "c": separating_radius(r[closed], stick[closed]),
                "closed": int(closed.sum()), "stick": int(stick.sum()), "r": r, "pressure": nodes.pressure,
                "unknowns": int(self.problem.model.num_dofs_global),
                "updates": int(result.geometry_updates)}

    def destroy(self) -> None:
        self.problem.destroy()


def hertz_reference(P: float, radius: float, materials: tuple[tuple[float, float], ...] = HERTZ_MATERIALS
                    ) -> tuple[float, float]:
    """Hertz's contact radius a = (3PR/4E*)^{1/3} and p₀ = 3P/(2πa²) for the measured P (Johnson §4.2)."""
    a_ref = (3 * P * radius / (4 * effective_modulus(materials))) ** (1 / 3)
    return a_ref, 3 * P / (2 * np.pi * a_ref**2)


def _pressed(model: Any, depth: float) -> dict[str, Any]:
    """``model`` (a _Hemisphere or _CoreModel) solved once with its flat face moved ``depth`` down, then
    destroyed (collective)."""
    try:
        return model.solve((0.0, 0.0, -depth))
    finally:
        model.destroy()


def hertz_two_bodies(comm: MPI.Comm, level: int | tuple[float, float, float], rtol: float = 1e-10) -> dict[str, Any]:
    """The frictionless hemisphere on the block (different materials) pressed δ = ``HERTZ_DELTA``: a and p₀
    against Hertz for the measured P (a³ = 3PR/(4E*), p₀ = 3P/(2πa²)); p₀ from the least-squares fit of
    p₀ √(1 − r²/a²) to the nodal pressures λⱼ/Dⱼ over r < a/2 (the measured a), as in case 2."""
    t0 = time.perf_counter()
    spec = HERTZ2_LEVELS[level] if isinstance(level, int) else level
    s = _pressed(_Hemisphere(comm, spec, HERTZ_MATERIALS, 0.0, "hertz2v_", rtol), HERTZ_DELTA)
    a_ref, p0_ref = hertz_reference(s["P"], R)
    core = s["r"] < s["a"]
    shape = np.sqrt(1 - (s["r"][core] / s["a"]) ** 2)
    p0 = float(shape @ s["pressure"][core] / (shape @ shape))
    return {"P": s["P"], "radius": s["a"], "radius_ref": a_ref, "err_radius": s["a"] / a_ref - 1,
            "pressure": p0, "pressure_ref": p0_ref, "err_pressure": p0 / p0_ref - 1, "h": spec[0],
            "h_over_a": spec[0] / a_ref, "unknowns": s["unknowns"], "closed": s["closed"],
            "converged": s["converged"], "updates": s["updates"], "wall": time.perf_counter() - t0}


def mindlin_steps(P: float, a: float, friction: float = MINDLIN_FRICTION, ratios: tuple[float, ...] = LOAD_RATIOS,
                  material: tuple[float, float] = MINDLIN_MATERIAL) -> list[float]:
    """The tangential displacements aimed at Q/(F P) = ``ratios``: Mindlin's δ_t = δ* (1 − (1 − Q/FP)^{2/3}) with
    δ* = 3 F P (2 − ν)/(8 G a) for two bodies of one material, times 1.3 for the hemisphere's own shear (its flat
    face is R above the contact). Q is measured; only the spread of the loads depends on this estimate (with
    R = 4 the loads came out 0.37 and 0.83 for 0.3 and 0.7)."""
    E, nu = material
    G = E / (2 * (1 + nu))
    star = 3 * friction * P * (2 - nu) / (8 * G * a)
    return [1.3 * star * (1 - (1 - q) ** (2 / 3)) for q in ratios]


def cattaneo_mindlin(comm: MPI.Comm, level: int | tuple[float, ...],
                     ratios: tuple[float, ...] = LOAD_RATIOS, rtol: float = 1e-9) -> dict[str, Any]:
    """Two bodies of one material (β = 0) pressed δ = ``MINDLIN_DELTA`` with friction, then the flat face moved
    along x in increasing steps: per step Q/(F P), the stick radius c/a (a and c the best separating radii of
    closed/open and stick/slip slave nodes) against (1 − Q/(F P))^{1/3}, and the normal force's change (0 for
    β = 0)."""
    t0 = time.perf_counter()
    spec = MINDLIN_LEVELS[level] if isinstance(level, int) else level
    body = _Hemisphere(comm, spec, (MINDLIN_MATERIAL, MINDLIN_MATERIAL), MINDLIN_FRICTION, "mindlin2v_", rtol,
                       MINDLIN_RADIUS)
    steps = []
    try:
        pressed = body.solve((0.0, 0.0, -MINDLIN_DELTA))
        for shift in mindlin_steps(pressed["P"], pressed["a"], ratios=ratios):
            s = body.solve((shift, 0.0, -MINDLIN_DELTA))
            q = s["Q"] / (MINDLIN_FRICTION * s["P"])
            reference = (1 - q) ** (1 / 3) if q < 1 else 0.0
            steps.append({"shift": shift, "load": q, "c_over_a": s["c"] / s["a"], "reference": reference,
                          "c_error": s["c"] - reference * s["a"],
                          "error": (s["c"] / s["a"]) / reference - 1 if reference > 0 else float("nan"),
                          "P_change": s["P"] / pressed["P"] - 1, "a": s["a"], "c": s["c"], "closed": s["closed"],
                          "stick": s["stick"], "converged": s["converged"], "updates": s["updates"]})
    finally:
        body.destroy()
    E_star = effective_modulus((MINDLIN_MATERIAL, MINDLIN_MATERIAL))
    a_ref = (3 * pressed["P"] * MINDLIN_RADIUS / (4 * E_star)) ** (1 / 3)
    return {"steps": steps, "P": pressed["P"], "a": pressed["a"], "a_ref": a_ref, "h": spec[0],
            "press_stick": pressed["stick"],
            "h_over_a": spec[0] / a_ref, "unknowns": pressed["unknowns"], "closed": pressed["closed"],
            "converged": pressed["converged"] and all(s["converged"] for s in steps),
            "wall": time.perf_counter() - t0}


# --- the half and quarter models with structured cores in both bodies (meshes/sphere_on_block_half.py) -------------
#
# A sphere of radius R = 100 (a/R = 0.005, as docs/verification §2) on a block [−W, W] × [0, W] × [−W, 0],
# W = 200 a (a = 0.5): x2 = 0 a symmetry plane (rollers u2 = 0 in both bodies; the tangential load along x1 keeps
# that symmetry), and for the frictionless Hertz case also x1 = 0 (a quarter). The full model's forces are 2× (4×)
# the half's (quarter's).

#: The contact radius aimed at and the sphere's radius (the flat face is pressed δ = a²/R).
A_CORE, R_CORE = 0.5, 100.0
CORE_DELTA = A_CORE**2 / R_CORE
#: Levels: h₀/a, the growth of the edge per unit distance beyond the cores, the cores' size L/a.
CORE_LEVELS: dict[int, tuple[float, float, float]] = {
    0: (1 / 8, 0.2, 1.2), 1: (1 / 12, 0.15, 1.2), 2: (1 / 16, 0.15, 1.2), 3: (1 / 20, 0.15, 1.2)}
CORE_SETTINGS = {"pc": "gamg", "rtol": 1e-12}


def core_mesh(comm: MPI.Comm, level: int | tuple[float, float, float], quarter: bool
              ) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """meshes/sphere_on_block_half.py at ``level`` (meshed on rank 0, distributed; collective)."""
    import tempfile
    from pathlib import Path

    from fenics_coulomb.scenes.meshes import read_gmsh_tags
    from meshes import sphere_on_block_half

    fraction, growth, fine = CORE_LEVELS[level] if isinstance(level, int) else level
    with tempfile.TemporaryDirectory() as tmp:
        path = comm.bcast(str(Path(tmp) / "core.msh") if comm.rank == 0 else None)
        if comm.rank == 0:
            sphere_on_block_half.build(path, A_CORE, fraction * A_CORE, R_CORE, fine=fine, growth=growth,
                                       quarter=quarter)
        return read_gmsh_tags(path, comm)


class _CoreModel:
    """The sphere cap on the block (half or quarter model) as a ContactProblem; the flat face prescribed through
    ``self.flat``; ``copies`` the full model's multiple of the forces (2 or 4); ``settings`` the solver's (default
    ``CORE_SETTINGS``)."""

    def __init__(self, comm: MPI.Comm, mesh: tuple[Any, Any, Any], quarter: bool,
                 materials: tuple[tuple[float, float], tuple[float, float]], friction: float, prefix: str,
                 settings: dict[str, Any] | None = None):
        from meshes.sphere_on_block_half import BODIES as CB
        from meshes.sphere_on_block_half import TAGS as CT

        msh, cell_tags, facet_tags = mesh
        self.copies = 4 if quarter else 2
        V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
        bottom = dolfinx.fem.locate_dofs_topological(V, 2, facet_tags.find(CT["bottom"]))
        flat = dolfinx.fem.locate_dofs_topological(V, 2, facet_tags.find(CT["flat"]))
        self.flat = dolfinx.fem.Constant(msh, np.zeros(3))
        bcs = [dolfinx.fem.dirichletbc(np.zeros(3), bottom, V), dolfinx.fem.dirichletbc(self.flat, flat, V)]
        for i, name in ((1, "sym_y"), (0, "sym_x")) if quarter else ((1, "sym_y"),):
            dofs = dolfinx.fem.locate_dofs_topological(V.sub(i), 2, facet_tags.find(CT[name]))
            bcs.append(dolfinx.fem.dirichletbc(np.float64(0.0), dofs, V.sub(i)))
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.Measure("dx", domain=msh, subdomain_data=cell_tags)
        form = 0
        for body, (E, nu) in zip(("upper", "block"), materials, strict=True):
            mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
            eps_u, eps_v = ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))
            form += ufl.inner(2 * mu * eps_u + lmbda * ufl.tr(eps_u) * ufl.Identity(3), eps_v) * dx(CB[body])
        self.pair = ContactPair(facet_tags, slave=CT["top"], master=CT["cap"], friction=friction,
                                search_distance=0.5 * A_CORE, name="cap", method="mortar")
        self.problem = ContactProblem(form, None, bcs, contact_pairs=[self.pair],
                                      settings=CORE_SETTINGS if settings is None else settings,
                                      petsc_options_prefix=prefix, sliding=SLIDING)

    def solve(self, displacement: tuple[float, float, float]) -> dict[str, Any]:
        """Solve with the flat face moved by ``displacement``: the full model's forces on the upper body (P up,
        Q = −F₁ the tangential force resisting the move), the contact and stick radii, the nodal pressures."""
        self.flat.value[:] = displacement
        _, result = self.problem.solve()
        report = self.problem.report(result)
        nodes = report.nodes
        force = -self.copies * np.asarray(report.pair_forces[0]["force_on_slave_body"], dtype=np.float64)
        r = np.hypot(nodes.coordinates[:, 0], nodes.coordinates[:, 1])
        closed = nodes.state != ContactState.OPEN
        stick = nodes.state == ContactState.STICK
        return {"converged": bool(result.converged), "P": float(force[2]), "Q": float(-force[0]),
                "Q_side": float(force[1]), "a": separating_radius(r, closed),
                "c": separating_radius(r[closed], stick[closed]), "closed": int(closed.sum()),
                "stick": int(stick.sum()), "r": r, "pressure": np.asarray(nodes.pressure),
                "x": np.asarray(nodes.coordinates), "force": np.asarray(nodes.force), "area": np.asarray(nodes.area),
                "state": np.asarray(nodes.state),
                "on_plane": np.min(np.abs(nodes.coordinates[:, :2]), axis=1) < 1e-9 * A_CORE,
                "unknowns": int(self.problem.model.num_dofs_global), "iterations": int(result.iterations)}

    def destroy(self) -> None:
        self.problem.destroy()


def _mean_pressure_p0(r: np.ndarray, pressure: np.ndarray, a_ref: float) -> float:
    """p₀ as docs/verification §2 reads it: the mean nodal pressure over r < a/2 divided by Hertz's mean of
    √(1 − r²/a²) there (0.9346)."""
    kappa = 8.0 / 3.0 * (1.0 - 0.75**1.5)
    return float(np.mean(pressure[r < 0.5 * a_ref]) / kappa)


def hertz_core(comm: MPI.Comm, level: int | tuple[float, float, float]) -> dict[str, Any]:
    """Case 9 on the quarter model: the frictionless cap (E 70, ν 0.35) pressed δ = a²/R onto the block (E 210,
    ν 0.3): a and p₀ against Hertz with 1/E* = Σ(1 − νᵢ²)/Eᵢ for the measured P (collective)."""
    t0 = time.perf_counter()
    spec = CORE_LEVELS[level] if isinstance(level, int) else level
    s = _pressed(_CoreModel(comm, core_mesh(comm, spec, True), True, HERTZ_MATERIALS, 0.0, "hertz9q_"), CORE_DELTA)
    a_ref, p0_ref = hertz_reference(s["P"], R_CORE)
    p0 = _mean_pressure_p0(s["r"], s["pressure"], a_ref)
    off = ~s["on_plane"]
    p0_off = _mean_pressure_p0(s["r"][off], s["pressure"][off], a_ref)
    return {"P": s["P"], "radius": s["a"], "radius_ref": a_ref, "err_radius": s["a"] / a_ref - 1,
            "pressure": p0, "pressure_ref": p0_ref, "err_pressure": p0 / p0_ref - 1,
            "pressure_off": p0_off, "err_pressure_off": p0_off / p0_ref - 1,
            "peak": float(s["pressure"].max()), "err_peak": float(s["pressure"].max()) / p0_ref - 1,
            "h_over_a": spec[0], "unknowns": s["unknowns"], "closed": s["closed"], "converged": s["converged"],
            "wall": time.perf_counter() - t0}


def mindlin_compliance(x: np.ndarray | float, P: float, a: float, friction: float = MINDLIN_FRICTION,
                       material: tuple[float, float] = MINDLIN_MATERIAL) -> Any:
    """Mindlin (1949), Johnson §7.2 (eq. 7.42 for two bodies of one material): the relative tangential
    displacement of distant points δ = (3μP(2 − ν)/(8Ga)) [1 − (1 − Q/μP)^{2/3}] at x = Q/μP."""
    E, nu = material
    G = E / (2 * (1 + nu))
    return 3 * friction * P * (2 - nu) / (8 * G * a) * (1 - (1 - np.asarray(x)) ** (2 / 3))


def mindlin_slip(x: np.ndarray | float, P: float, a: float) -> Any:
    """The slip-induced part of Mindlin's δ: δ(x) − x δ'(0), δ'(0) = (2/3)·3μP(2 − ν)/(8Ga) per unit x."""
    star = mindlin_compliance(1.0, P, a)
    return star * (1 - (1 - np.asarray(x)) ** (2 / 3) - 2 * np.asarray(x) / 3)


def unloading_slip(x_star: float, x: float, P: float, a: float) -> float:
    """Mindlin–Deresiewicz: from Q* down to Q, δ = δ* − 2 δ_load((Q* − Q)/2); its slip part (the linear term
    C·Q passes through the rule unchanged: C Q* − 2C (Q* − Q)/2 = C Q)."""
    return float(mindlin_slip(x_star, P, a) - 2 * mindlin_slip((x_star - x) / 2, P, a))
