"""Hertz on a quarter model: a rigid sphere pressed into a large, strongly graded block on symmetry rollers.

    container/run mpirun -n 2 python3 benchmarks/hertz_quarter.py 2     # a level of LEVELS (0 … 3)

The indentation of benchmarks/hertz.py (R = 10, δ = 0.025, a = √(Rδ) = 0.5, E = 70, ν = 0.3, frictionless) on
the quarter block of meshes/hertz_quarter.py: [0, W]² × [−W, 0], rollers u1 = 0 on x1 = 0 and u2 = 0 on x2 = 0
(their contact nodes stay contact nodes: the held component is tangential to the sphere there), the bottom
clamped, the sides free. The full model's force is four times the quarter's. Measured against Hertz
(Johnson, Contact Mechanics (1985), §4.2 and §3.4):

* a: the radius separating the closed from the open contact nodes (resolution ±h₀/2), against
  a = (3PR/4E*)^{1/3} for the measured P; p₀: the mean nodal pressure over r < a/2 divided by Hertz's mean of
  √(1 − r²/a²) there (0.9346), against 3P/(2πa²);
* the peak nodal ``contact_pressure`` (the XDMF field, = ``report.nodes.pressure``) against p₀;
* the largest shear τ = (σ₁ − σ₃)/2 of the projected stress at the vertices on the x3 axis (an edge of the
  quarter: the axis is sampled exactly, at spacing h₀ under the contact) and its depth, against Hertz's
  τ_max = 0.31 p₀ at 0.48 a for ν = 0.3 (computed here from Hertz's axis stresses, :func:`axis_shear`);
* P(δ), two ways. (i) For the imposed δ, against P = (4/3)E*√R δ^{3/2}: the block is not a half-space, its
  clamped bottom at the depth W removes the compliance beyond (about the Boussinesq displacement
  P(3 − 2ν)/(4πG W) of δ), and the graded far field of linear tetrahedra is stiff. (ii) The approach of the
  sphere relative to the body's point on the axis at the depth d (δ − w(d), w the downward displacement
  there), against the same quantity in Hertz's half-space: δ_H(P) − w_H(d; P), w_H the axis displacement
  under Hertz's pressure (:func:`axis_displacement`; for d ≫ a Boussinesq's P(3 − 2ν)/(4πG d)). (ii) sees
  only the body above d, so neither the support nor the far field's discretisation enters: it is the
  Hertz relation P(δ) with δ the approach of "distant points" at the depth d, with the half-space below d
  added in closed form.
"""

from __future__ import annotations

import logging
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import numpy as np
import ufl

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from fenics_coulomb import ContactProblem, Sphere, read_gmsh, write_results  # noqa: E402
from fenics_coulomb.io.fields import stress_from_form, stress_functions  # noqa: E402

__all__ = ["LEVELS", "axis_displacement", "axis_shear", "hertz_force", "indent_quarter", "main"]

LOG = logging.getLogger("hertz_quarter")

#: Material (GPa), Hertz's contact radius a, the sphere's radius R and its depth δ = a²/R (mm; forces kN).
#: a/R = 0.005: Hertz's theory is the limit a/R → 0, and the contact here acts along the sphere's normal,
#: whose radial part r/R couples the surface's inward displacement u_r into the gap, a term of relative size
#: O(a/R) in P that Hertz drops: measured +1.0 % in P(δ) at a/R = 0.05 (R = 10, benchmarks/hertz.py's
#: sphere), +0.1 % at a/R = 0.005 (docs/verification §2).
E, NU = 70.0, 0.3
G = E / (2.0 * (1.0 + NU))
E_STAR = E / (1.0 - NU**2)
A_HERTZ = 0.5
R_INDENTER = 100.0
DEPTH = A_HERTZ**2 / R_INDENTER
#: Mean of √(1 − r²/a²) over the disc r < a/2.
KAPPA = 8.0 / 3.0 * (1.0 - 0.75**1.5)
#: Mesh levels (meshes/hertz_quarter.py): h₀/a, the growth of the edge per unit distance beyond the structured
#: core, W/a, the core's size L/a. Level 0 is the tests' (tests/problems/test_hertz_quarter.py).
LEVELS: dict[int, tuple[float, float, float, float]] = {
    0: (1 / 16, 0.15, 1000.0, 1.2),
    1: (1 / 12, 0.1, 1000.0, 1.5),
    2: (1 / 17, 0.1, 1000.0, 1.5),
    3: (1 / 24, 0.1, 1000.0, 1.5),
}
#: The depth d/a of the reference point of the relative approach (P(δ), measure (ii)).
REFERENCE_DEPTH = 4.0
SETTINGS = {"pc": "ilu", "rtol": 1e-13}
CONTACT, BOTTOM, SIDES, SYM_X, SYM_Y, TOP = 1, 2, 3, 4, 5, 6


def hertz_force(approach: float, radius: float = R_INDENTER) -> float:
    """Hertz: P = (4/3)E*√R δ^{3/2}."""
    return 4.0 / 3.0 * E_STAR * np.sqrt(radius) * approach**1.5


def hertz_from_force(force: float, radius: float = R_INDENTER) -> tuple[float, float, float]:
    """Hertz for the force P: a = (3PR/4E*)^{1/3}, p₀ = 3P/(2πa²), δ = a²/R."""
    a = (3.0 * force * radius / (4.0 * E_STAR)) ** (1.0 / 3.0)
    return a, 3.0 * force / (2.0 * np.pi * a**2), a**2 / radius


def axis_displacement(force: float, depth: float, n: int = 4000, radius: float = R_INDENTER) -> float:
    """The downward displacement on the axis at ``depth`` of a half-space under Hertz's pressure for ``force``:
    Boussinesq's point-load kernel (Johnson §3.2: u_z = P/(4πG) (z²/ρ³ + 2(1 − ν)/ρ), ρ the distance) integrated
    over p(s) = p₀√(1 − s²/a²) (midpoint rule in s = a sin θ, which removes the square root's end). At the
    surface it is Hertz's δ = πp₀a/(2E*); for depth ≫ a, P(3 − 2ν)/(4πG depth)."""
    a, p0, _ = hertz_from_force(force, radius)
    theta = (np.arange(n) + 0.5) * (0.5 * np.pi / n)
    s = a * np.sin(theta)
    ds = a * np.cos(theta) * (0.5 * np.pi / n)
    p = p0 * np.cos(theta)
    rho = np.hypot(s, depth)
    with np.errstate(divide="ignore", invalid="ignore"):
        kernel = np.where(rho > 0, depth**2 / rho**3 + 2.0 * (1.0 - NU) / rho, 0.0)
    return float(np.sum(p * 2.0 * np.pi * s * ds * kernel) / (4.0 * np.pi * G))


def axis_shear(n: int = 20001) -> tuple[float, float]:
    """Hertz's largest shear on the axis (Johnson §4.2, eq. 4.23): σ_r/p₀ = −(1 + ν)(1 − ζ arctan(1/ζ)) +
    1/(2(1 + ζ²)), σ_z/p₀ = −1/(1 + ζ²), ζ = z/a; τ = |σ_z − σ_r|/2. Returns (τ_max/p₀, z/a there): 0.310 at
    0.481 for ν = 0.3."""
    zeta = np.linspace(1e-6, 3.0, n)
    sr = -(1.0 + NU) * (1.0 - zeta * np.arctan(1.0 / zeta)) + 0.5 / (1.0 + zeta**2)
    sz = -1.0 / (1.0 + zeta**2)
    tau = 0.5 * np.abs(sz - sr)
    k = int(np.argmax(tau))
    return float(tau[k]), float(zeta[k])


def contact_radius(r: np.ndarray, closed: np.ndarray) -> float:
    """The radius separating the closed nodes (inside) from the open ones best (benchmarks/hertz.py's rule)."""
    order = np.argsort(r, kind="stable")
    rs, cs = r[order], closed[order]
    if not cs.any():
        return 0.0
    errors = np.concatenate([[0], np.cumsum(~cs)]) + cs.sum() - np.concatenate([[0], np.cumsum(cs)])
    ks = np.flatnonzero(errors == errors.min())
    ks = ks[(ks > 0) & (ks < rs.size)] if np.any((ks > 0) & (ks < rs.size)) else ks
    mids = np.where(ks < rs.size, 0.5 * (rs[np.maximum(ks - 1, 0)] + rs[np.minimum(ks, rs.size - 1)]), rs[-1])
    return float(np.mean(mids))


def quarter_mesh(comm: MPI.Comm, h0_over_a: float, growth: float, width: float, fine: float = 1.5
                 ) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """meshes/hertz_quarter.py's block (meshed on rank 0, read and distributed by read_gmsh)."""
    from meshes import hertz_quarter

    with tempfile.TemporaryDirectory() as tmp:
        path = comm.bcast(str(Path(tmp) / "hertz_quarter.msh") if comm.rank == 0 else None)
        if comm.rank == 0:
            hertz_quarter.build(path, A_HERTZ, h0_over_a * A_HERTZ, width=width, growth=growth, fine=fine)
        return read_gmsh(path, comm)


def elasticity(V: dolfinx.fem.FunctionSpace) -> ufl.Form:
    """σ = 2G ε + λ tr(ε) I."""
    lmbda = E * NU / ((1 + NU) * (1 - 2 * NU))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    return ufl.inner(2 * G * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx


def indent_quarter(comm: MPI.Comm, level: int | tuple[float, float, float], out: Path | str | None = None,
                   radius: float = R_INDENTER) -> dict[str, Any]:
    """Solve the quarter indentation at ``level`` (a key of ``LEVELS`` or (h₀/a, growth, W/a)) and measure it
    against Hertz (collective; the same numbers on every rank). ``out``: also write the result set there
    (write_results: solution.xdmf …) and read the peak of its ``contact_pressure`` back. ``radius``: the
    sphere's R, pressed δ = a²/R (the same Hertz contact radius a = 0.5 for every R)."""
    depth = A_HERTZ**2 / radius
    t0 = time.perf_counter()
    fraction, growth, width, *rest = LEVELS[level] if isinstance(level, int) else level
    fine = rest[0] if rest else 1.5
    h0 = fraction * A_HERTZ
    msh, tags = quarter_mesh(comm, fraction, growth, width, fine)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType),
                                    dolfinx.fem.locate_dofs_topological(V, 2, tags.find(BOTTOM)), V)
    rollers = [dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0),
                                       dolfinx.fem.locate_dofs_topological(V.sub(i), 2, tags.find(tag)), V.sub(i))
               for i, tag in ((0, SYM_X), (1, SYM_Y))]
    sphere = Sphere(center=[0.0, 0.0, radius], radius=radius, displacement=[0.0, 0.0, -depth],
                    name="indenter")
    with ContactProblem(elasticity(V), None, bcs=[clamp, *rollers], contact=(tags, [CONTACT]), friction=0.0,
                        obstacles=[sphere], settings=SETTINGS, petsc_options_prefix="hertz_quarter_") as problem:
        uh, result = problem.solve()
        solve_wall = time.perf_counter() - t0
        report = problem.report(result, reactions={"bottom": clamp})
        nodes = report.nodes
        sigma, _ = stress_functions(stress_from_form(problem.model.a_ufl, uh), msh)
        xdmf_peak, summary = np.nan, {}
        if out is not None:
            data = write_results(out, problem, result)
            summary = comm.bcast({k: data.get(k) for k in ("max_shear", "max_shear_at", "peak_pressure",
                                                              "peak_pressure_at")} if comm.rank == 0 else None)
            xdmf_peak = _xdmf_peak(comm, Path(out))
        checks = problem.checks(result)
        physics = max(v for k, v in checks.items() if k not in ("contact_resultant", "reaction_balance"))
        unknowns, contact_nodes, held = problem.n, problem.p, int(comm.allreduce(
            int(np.sum(problem.model.contact.held_components.any(axis=1))), op=MPI.SUM))
        converged = bool(result.converged)
        # the displacement on the axis (a mesh edge): its vertices, owned ones, gathered
        owned = V.dofmap.index_map.size_local
        x = V.tabulate_dof_coordinates()[:owned]
        on_axis = np.hypot(x[:, 0], x[:, 1]) < 1e-9 * A_HERTZ
        axis_z = np.concatenate(comm.allgather(x[on_axis, 2]))
        axis_w = np.concatenate(comm.allgather(-uh.x.array[: 3 * owned].reshape(-1, 3)[on_axis, 2]))
        # the projected stress's largest shear at the axis vertices
        S = sigma.x.array[: 9 * owned].reshape(-1, 3, 3)[on_axis]
        principal = np.linalg.eigvalsh(S)
        axis_tau = np.concatenate(comm.allgather(0.5 * (principal[:, -1] - principal[:, 0])))
    force = 4.0 * float(report.total_force[2]) * -1.0  # the sphere pushes down: the force on the body is −e3
    a_ref, p0_ref, _ = hertz_from_force(force, radius)
    r = np.hypot(nodes.coordinates[:, 0], nodes.coordinates[:, 1])
    a_measured = contact_radius(r, nodes.closed)
    central = r < 0.5 * a_ref
    p0 = float(nodes.normal_force[central].sum() / nodes.area[central].sum()) / KAPPA
    k = int(np.argmax(nodes.pressure))
    # P(δ) (ii): the approach relative to the axis vertex nearest the reference depth
    j = int(np.argmin(np.abs(axis_z + REFERENCE_DEPTH * A_HERTZ)))
    d, w_d = float(-axis_z[j]), float(axis_w[j])
    relative = depth - w_d
    reference = hertz_force(depth, radius)
    for _ in range(50):  # P with δ_H(P) − w_H(d; P) = δ − w(d): a fixed point, w_H ∝ P nearly
        reference = hertz_force(relative + axis_displacement(reference, d, radius=radius), radius)
    tau_ref, depth_ref = axis_shear()
    m = int(np.argmax(axis_tau))
    vertex = _vertex(-axis_z, axis_tau)
    return {
        "h_over_a": fraction, "growth": growth, "width": width, "fine": fine, "h0": h0, "unknowns": int(unknowns),
        "contact_nodes": int(contact_nodes), "held": held, "closed": int(np.sum(nodes.closed)),
        "converged": converged, "iterations": int(result.iterations), "physics": physics,
        "radius_sphere": radius, "depth": depth,
        "force": force, "force_ref": hertz_force(depth, radius), "err_force": force / hertz_force(depth, radius) - 1.0,
        "relative_depth": d, "relative_depth_over_a": d / A_HERTZ, "relative_w": w_d, "force_ref_relative": reference,
        "err_force_relative": force / reference - 1.0,
        "bottom_reaction": 4.0 * float(report.reactions["bottom"][2]),
        "radius": a_measured, "radius_ref": a_ref, "err_radius": a_measured / a_ref - 1.0,
        "pressure": p0, "pressure_ref": p0_ref, "err_pressure": p0 / p0_ref - 1.0,
        "peak_pressure": float(nodes.pressure[k]), "peak_at": float(r[k]), "summary": summary,
        "err_peak": float(nodes.pressure[k]) / p0_ref - 1.0, "xdmf_peak": float(xdmf_peak),
        "axis_tau": float(axis_tau[m] / p0_ref), "axis_depth": float(-axis_z[m] / a_ref),
        "tau_ref": tau_ref, "depth_ref": depth_ref, "err_tau": float(axis_tau[m] / p0_ref) / tau_ref - 1.0,
        "axis_spacing": _spacing(axis_z, -axis_z[m]) / a_ref, "vertex_depth": vertex / a_ref,
        "profile": (r[nodes.closed], nodes.pressure[nodes.closed]),
        "axis_profile": (-axis_z / a_ref, axis_tau / p0_ref),
        "solve_wall": solve_wall, "wall": time.perf_counter() - t0,
    }


def _vertex(depth: np.ndarray, tau: np.ndarray) -> float:
    """The depth of the largest shear on the axis: the vertex of the parabola through the sampled largest value
    and its two neighbours on the axis (the samples are one edge apart; Hertz's τ(z) is flat at its maximum, so
    the largest sample alone places it only to ± one spacing)."""
    order = np.argsort(depth)
    z, t = depth[order], tau[order]
    k = int(np.clip(np.argmax(t), 1, t.size - 2))
    (z0, z1, z2), (t0, t1, t2) = z[k - 1: k + 2], t[k - 1: k + 2]
    denominator = (z0 - z1) * (z0 - z2) * (z1 - z2)
    A = (z2 * (t1 - t0) + z1 * (t0 - t2) + z0 * (t2 - t1)) / denominator
    B = (z2**2 * (t0 - t1) + z1**2 * (t2 - t0) + z0**2 * (t1 - t2)) / denominator
    return float(-B / (2.0 * A)) if A < 0 else float(z1)


def _spacing(z: np.ndarray, depth: float) -> float:
    """The spacing of the axis vertices around ``depth`` (the resolution of the shear's depth)."""
    zs = np.sort(-z)
    k = int(np.argmin(np.abs(zs - depth)))
    gaps = np.diff(zs)[max(k - 1, 0): k + 1]
    return float(gaps.max()) if gaps.size else np.nan


def _xdmf_peak(comm: MPI.Comm, out: Path) -> float:
    """The largest ``contact_pressure`` in the result set's solution.h5 (read on rank 0, broadcast)."""
    peak = np.nan
    if comm.rank == 0:
        import h5py

        with h5py.File(out / "solution.h5", "r") as h5:
            peak = float(np.max(h5["Function/contact_pressure/0"][:]))
    return float(comm.bcast(peak))


def main(argv: list[str] | None = None) -> int:
    """``hertz_quarter.py [LEVEL]``: print one level's numbers on rank 0."""
    args = sys.argv[1:] if argv is None else argv
    level = int(args[0]) if args else 1
    r = indent_quarter(MPI.COMM_WORLD, level, out=args[1] if len(args) > 1 else None)
    if MPI.COMM_WORLD.rank == 0:
        print(", ".join(f"{k} {v:.5g}" for k, v in r.items() if isinstance(v, float | int)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
