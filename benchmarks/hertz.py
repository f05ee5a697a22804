# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Hertz contact: a rigid sphere pressed into a block, an elastic hemisphere pressed onto a plane
#
# Two classical Hertz problems solved with `fenics_coulomb.ContactProblem` and compared with the formulas:
#
# 1. **Indentation.** A rigid sphere of radius R is pushed a depth δ into an elastic block through the
#    obstacle's rigid `displacement` (0, 0, −δ): the sphere then overlaps the undeformed block, and the
#    solution pushes the block's surface out of it (displacement control, no load on the body).
# 2. **Elastic sphere.** An elastic hemisphere of radius R rests with its apex on the rigid plane x3 = 0;
#    its flat top is moved down by δ (a prescribed displacement), so that the curved face is pressed onto
#    the plane.
#
# ```
# python3 benchmarks/hertz.py                                  # the coarse level, F = 0 and 0.3 (about 30 s)
# mpirun -n 2 python3 benchmarks/hertz.py --levels 0 1 2 --out docs/hertz   # the numbers of docs/hertz (~15 min)
# ```
#
# ## Hertz's solution
#
# For a rigid sphere on an elastic half-space (or an elastic sphere on a rigid plane) with Young's modulus
# E and Poisson ratio ν, frictionless, with the contact radius a small against R:
#
#     E* = E/(1 − ν²),   P = (4/3) E* √R δ^{3/2},   a = √(R δ),   p₀ = 3P/(2π a²) = (2E*/π) √(δ/R),
#
# equivalently a³ = 3PR/(4E*) from the force. The pressure is p(r) = p₀ √(1 − r²/a²) for r ≤ a and 0
# outside. δ is the approach of points far from the contact. A finite body lacks the half-space's
# compliance beyond its size: a support at the distance W from the contact removes about 0.7 (a/W) δ
# (ν = 0.3; the Boussinesq displacement there), so the body is slightly stiffer than Hertz's δ says. The
# relation between P and a (and p₀) is local and hardly sees it.
#
# With friction (F > 0) the surface can no longer slide inward freely: for a rigid indenter on a
# compressible solid (ν < 0.5) Spence's solution has a central stick zone, a slightly stiffer response and
# a slightly smaller contact radius for the same load; the 3 % criterion of the comparison is for the
# frictionless case, the frictional numbers are reported next to it.

# %%
from __future__ import annotations

import argparse
import csv
import logging
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.io.gmshio
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb import ContactProblem, Sphere, create_partitioner, read_gmsh

ROOT = Path(__file__).resolve().parents[1]
#: Mean of √(1 − r²/a²) over the disc r < a/2.
KAPPA = 8.0 / 3.0 * (1.0 - 0.75**1.5)

#: Material (GPa) and geometry (lengths in mm: forces in kN, pressures in GPa).
E, NU = 70.0, 0.3
E_STAR = E / (1 - NU**2)
#: Indentation: sphere radius, depth, hence the Hertz contact radius a = √(Rδ) = 0.5.
R_INDENTER, DEPTH = 10.0, 0.025
#: Elastic hemisphere: radius and approach (a = √(Rδ) = 1 for R = 10).
R_HEMISPHERE, APPROACH = 10.0, 0.1

#: Facet tags of the block.
TOP, BOTTOM, SIDES = 1, 2, 3

#: Mesh levels: (edge h₀ at the contact relative to the Hertz contact radius a, growth of the edge per unit
#: distance beyond 1.2 a). The hemisphere's far size is ``FAR[level]``·R.
LEVELS = {0: (1 / 4, 0.15), 1: (1 / 8, 0.10), 2: (1 / (8 * np.sqrt(2)), 0.07)}
FAR = {0: 0.1, 1: 0.07, 2: 0.05}
#: Solver settings: ILU-preconditioned GMRES (GAMG stagnates on these strongly graded tetrahedra), the
#: residual reduced by 1e-10 so that the support reactions balance the contact force to ~1e-6 or better.
SETTINGS = {"pc": "ilu", "rtol": 1e-10}


# %% [markdown]
# ## Hertz's formulas


# %%
def hertz(radius: float, approach: float, e_star: float = E_STAR) -> dict[str, float]:
    """Hertz's force, contact radius and peak pressure for the approach δ (rigid sphere on a half-space or
    elastic sphere on a rigid plane; E* = E/(1 − ν²))."""
    force = 4.0 / 3.0 * e_star * np.sqrt(radius) * approach**1.5
    a = np.sqrt(radius * approach)
    return {"force": force, "radius": a, "pressure": 3.0 * force / (2.0 * np.pi * a**2)}


def hertz_from_force(radius: float, force: float, e_star: float = E_STAR) -> dict[str, float]:
    """Hertz's contact radius a = (3PR/(4E*))^(1/3) and peak pressure p₀ = 3P/(2πa²) for the force P."""
    a = (3.0 * force * radius / (4.0 * e_star)) ** (1.0 / 3.0)
    return {"force": force, "radius": a, "pressure": 3.0 * force / (2.0 * np.pi * a**2)}


# %% [markdown]
# ## The meshes
#
# **Block.** The elastic block is [−W, W]² × [−W, 0] with W = 100 a (a = √(Rδ) the Hertz contact radius),
# large enough that its finite size changes the force by about +0.5 % only: in a half-space the Boussinesq
# displacement under the force P at depth W is about 0.7 (a/W) δ (for ν = 0.3), which a clamped bottom at
# that depth removes (measured: W = 50 a gives a force 0.55 % higher than W = 100 a on the same mesh
# grading). The linear tetrahedra (gmsh, a background size field) have the edge h₀ within 1.2 a of the
# initial contact point and grow linearly with the distance beyond (`LEVELS`: growth 0.15, 0.10, 0.07
# per unit distance), so the mesh stays small: 20 k, 73 k and 200 k unknowns for h₀ = a/4, a/8, a/11.3.
# Linear tetrahedra are stiff: the far field's grading matters as much as h₀ (h₀ = a/8 with growth 0.15
# gives +4.5 % in the force, with 0.10 +3.5 %, with 0.07 +3.0 %). The bottom is clamped, the sides are
# free, the top is the contact boundary.
#
# **Hemisphere.** `meshes/hemisphere.py` (gmsh) with its grading toward the apex: its size at the apex is
# `size/grading`. The flat top is the face of the prescribed displacement; the curved face (with the
# small apex disc, which is not clamped here) is the contact boundary.


# %%
def block_mesh(comm: MPI.Comm, h0: float, a: float = np.sqrt(R_INDENTER * DEPTH), width: float = 100.0,
               growth: float = 0.1) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """The block [−W, W]² × [−W, 0], W = ``width``·a, in tetrahedra of edge ``h0`` near the origin
    (collective; meshed on rank 0, distributed by the deterministic partitioner)."""
    import gmsh

    W = width * a
    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("block")
        gmsh.model.occ.addBox(-W, -W, -W, 2 * W, 2 * W, W)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [v for _, v in gmsh.model.getEntities(3)], 1)
        groups: dict[int, list[int]] = {TOP: [], BOTTOM: [], SIDES: []}
        for _, surface in gmsh.model.getEntities(2):
            z = gmsh.model.occ.getCenterOfMass(2, surface)[2]
            groups[TOP if np.isclose(z, 0.0) else BOTTOM if np.isclose(z, -W) else SIDES].append(surface)
        for tag, surfaces in groups.items():
            gmsh.model.addPhysicalGroup(2, surfaces, tag)
        field = gmsh.model.mesh.field.add("MathEval")
        gmsh.model.mesh.field.setString(
            field, "F", f"Min({W / 4}, {h0} + {growth}*Max(0, Sqrt(x*x + y*y + z*z) - {1.2 * a}))")
        gmsh.model.mesh.field.setAsBackgroundMesh(field)
        for option in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
            gmsh.option.setNumber(f"Mesh.{option}", 0)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.optimize()
    x = dolfinx.io.gmshio.extract_geometry(gmsh.model) if comm.rank == 0 else np.zeros((0, 3))
    msh, _, facet_tags = dolfinx.io.gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0,
                                                         gdim=3, partitioner=create_partitioner(comm, x))
    if comm.rank == 0:
        gmsh.finalize()
    return msh, facet_tags


def hemisphere_mesh(comm: MPI.Comm, size: float, grading: float) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """The hemisphere of meshes/hemisphere.py (radius R_HEMISPHERE; tags top 1, bottom 2, apex 3)."""
    from meshes import hemisphere as module

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hemisphere.msh"
        if comm.rank == 0:
            module.build(size * R_HEMISPHERE, path, radius=R_HEMISPHERE, grading=grading)
        return read_gmsh(str(path), comm)  # read on rank 0 only


# %% [markdown]
# ## The elastic form
#
# Isotropic linear elasticity in UFL, σ = 2μ ε + λ tr(ε) I.


# %%
def elasticity(V: dolfinx.fem.FunctionSpace) -> ufl.Form:
    mu, lmbda = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    return ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx


# %% [markdown]
# ## Measuring P, a and p₀ on the solution
#
# * **P**: the total contact force, the sum of the nodal contact forces (its component along the loading
#   axis). Equilibrium makes it the reaction of the support (checked: `reaction`).
# * **p₀**: from the normal contact traction, the normal nodal force over the node's share of the contact
#   surface (∫φᵢ ds, the definition of the `contact_traction` output). On linear tetrahedra the nodal
#   tractions scatter by tens of % from node to node (the largest one overshoots p₀ by 40–70 % on these
#   meshes; it is in the CSV as `max_traction`), so p₀ is read from their mean over the central disc
#   r < a_H/2 (a_H Hertz's radius for the measured force): p̄ = Σλᵢ/ΣAᵢ there, and p₀ = p̄/κ with
#   κ = (8/3)(1 − (3/4)^{3/2}) = 0.9346, the mean of √(1 − r²/a²) over that disc.
# * **a**: the radius that best separates the contact nodes (closed: stick or slip) from the open ones: the
#   threshold r* that minimizes the number of closed nodes beyond r* plus open nodes within it (ties: the
#   mean of the tied thresholds), each threshold midway between two consecutive node radii. On a mesh whose
#   contact edge runs between a ring of closed and a ring of open nodes this is the midpoint between the
#   outermost contact node and the innermost open node; on unstructured meshes it averages over the whole
#   edge, so a few stray nodes do not move it.


# %%
def contact_radius(r: npt.ArrayLike, closed: npt.ArrayLike) -> float:
    """The radius separating the closed nodes (inside) from the open ones (outside) best (see above)."""
    r = np.asarray(r, dtype=np.float64)
    closed = np.asarray(closed, dtype=bool)
    order = np.argsort(r, kind="stable")
    rs, cs = r[order], closed[order]
    if not cs.any():
        return 0.0
    # threshold k: the first k nodes inside; misclassified = open among them + closed among the rest
    open_inside = np.concatenate([[0], np.cumsum(~cs)])
    closed_outside = cs.sum() - np.concatenate([[0], np.cumsum(cs)])
    errors = open_inside + closed_outside
    ks = np.flatnonzero(errors == errors.min())
    ks = ks[(ks > 0) & (ks < rs.size)] if np.any((ks > 0) & (ks < rs.size)) else ks
    mids = np.where(ks < rs.size, 0.5 * (rs[np.maximum(ks - 1, 0)] + rs[np.minimum(ks, rs.size - 1)]), rs[-1])
    return float(np.mean(mids))


@dataclass
class Measured:
    """One solve compared with Hertz (lengths mm, forces kN, pressures GPa)."""

    case: str
    level: int
    friction: float
    h_contact: float
    unknowns: int
    contact_nodes: int
    newton_iterations: int
    wall_time_s: float
    approach: float
    force: float
    radius: float
    pressure: float
    hertz_force: float
    hertz_radius: float
    hertz_pressure: float
    err_force: float
    err_radius: float
    err_pressure: float
    radius_from_force: float
    err_radius_from_force: float
    pressure_from_force: float
    err_pressure_from_force: float
    reaction: float
    reaction_balance: float
    min_pressure: float
    max_traction: float
    max_physics_residual: float


def measure(case: str, level: int, friction: float, h: float, problem: ContactProblem, result, approach: float,
            radius: float, sign: float, reaction_blocks: npt.NDArray[np.int32], wall: float) -> Measured:
    """P, a, p₀ of the solution against Hertz for the approach (collective; same on all ranks)."""
    report = problem.report(result, reactions={"support": reaction_blocks})  # the same on every rank
    nodes = report.nodes
    r = np.hypot(nodes.coordinates[:, 0], nodes.coordinates[:, 1])
    a = contact_radius(r, nodes.closed)
    force = sign * float(report.total_force[2])
    pmax = float(np.max(nodes.pressure, initial=0.0))
    ref_p = hertz_from_force(radius, force)
    central = r < 0.5 * ref_p["radius"]
    p0 = float(nodes.normal_force[central].sum() / nodes.area[central].sum()) / KAPPA
    pmin = float(np.min(nodes.pressure, initial=0.0))
    checks = problem.checks(result)
    reaction = report.reactions["support"]
    ref = hertz(radius, approach)
    worst = max(v for k, v in checks.items() if k not in ("contact_resultant", "reaction_balance"))
    return Measured(
        case=case, level=level, friction=friction, h_contact=h, unknowns=problem.n, contact_nodes=problem.p,
        newton_iterations=result.iterations, wall_time_s=wall, approach=approach,
        force=force, radius=a, pressure=p0,
        hertz_force=ref["force"], hertz_radius=ref["radius"], hertz_pressure=ref["pressure"],
        err_force=force / ref["force"] - 1, err_radius=a / ref["radius"] - 1, err_pressure=p0 / ref["pressure"] - 1,
        radius_from_force=ref_p["radius"], err_radius_from_force=a / ref_p["radius"] - 1,
        pressure_from_force=ref_p["pressure"], err_pressure_from_force=p0 / ref_p["pressure"] - 1,
        reaction=-sign * float(reaction[2]), reaction_balance=checks["reaction_balance"], min_pressure=pmin,
        max_traction=pmax, max_physics_residual=worst)


# %% [markdown]
# ## Case 1: a rigid sphere indenting the block
#
# The sphere (centre (0, 0, R), radius R) touches the block's top x3 = 0 at the origin at its scene
# position; its `displacement` (0, 0, −δ) moves it δ into the block. The bottom is clamped; nothing else
# loads the body.


# %%
def indent_block(level: int, friction: float = 0.0, comm: MPI.Comm = MPI.COMM_WORLD,
                 settings: dict | None = None) -> Measured:
    """Solve the sphere indentation at mesh ``level`` (``LEVELS``) and compare with Hertz."""
    a = np.sqrt(R_INDENTER * DEPTH)
    h, growth = LEVELS[level][0] * a, LEVELS[level][1]
    t0 = time.perf_counter()
    msh, tags = block_mesh(comm, h, a, growth=growth)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    bottom = dolfinx.fem.locate_dofs_topological(V, 2, tags.find(BOTTOM))
    bc = dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), bottom, V)
    sphere = Sphere(center=[0.0, 0.0, R_INDENTER], radius=R_INDENTER, displacement=[0.0, 0.0, -DEPTH],
                    name="indenter")
    with ContactProblem(elasticity(V), None, bcs=[bc], contact=(tags, [TOP]), friction=friction, obstacles=[sphere],
                        settings=settings or SETTINGS, petsc_options_prefix="hertz_block_") as problem:
        _, result = problem.solve()
        wall = time.perf_counter() - t0
        return measure("sphere into block", level, friction, h, problem, result, DEPTH, R_INDENTER, -1.0,
                       bottom, wall)


# %% [markdown]
# ## Case 2: the elastic hemisphere pressed onto the plane
#
# The top face x3 = R gets the prescribed displacement (0, 0, −δ) in all three components (it holds the
# body against rigid motions as well); the apex rests on the default obstacle, the plane x3 = 0.
# The body is not a half-space: its top, held at the distance R from the contact, removes the half-space's
# compliance beyond R, about 0.7 (a/R) δ = 7 % of δ for a/R = 0.1 (the same estimate as for the block), so
# the force for the given δ lies about 10 % above Hertz's even on a fine mesh. P against a and p₀
# (a³ = 3PR/(4E*), p₀ = 3P/(2πa²)) is the local Hertz relation to compare here.


# %%
def press_hemisphere(level: int, friction: float = 0.0, comm: MPI.Comm = MPI.COMM_WORLD,
                     settings: dict | None = None) -> Measured:
    """Solve the hemisphere pressed by its top at mesh ``level`` and compare with Hertz."""
    a = np.sqrt(R_HEMISPHERE * APPROACH)
    h = LEVELS[level][0] * a
    size = FAR[level]  # relative to R, far from the apex
    t0 = time.perf_counter()
    msh, tags = hemisphere_mesh(comm, size, grading=size * R_HEMISPHERE / h)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    top = dolfinx.fem.locate_dofs_topological(V, 2, tags.find(1))
    bc = dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -APPROACH], dtype=PETSc.ScalarType), top, V)
    with ContactProblem(elasticity(V), None, bcs=[bc], contact=(tags, [2, 3]), friction=friction,
                        settings=settings or SETTINGS, petsc_options_prefix="hertz_hemisphere_") as problem:
        _, result = problem.solve()
        wall = time.perf_counter() - t0
        return measure("elastic hemisphere on plane", level, friction, h, problem, result, APPROACH,
                       R_HEMISPHERE, 1.0, top, wall)


# %% [markdown]
# ## Output: a table, a CSV file and a figure


# %%
def write_results(out: Path, rows: list[Measured]) -> None:
    """hertz.csv (every field), hertz.md (the table) and hertz.png (errors against h₀/a) in ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    with open(out / "hertz.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(asdict(rows[0])))
        writer.writeheader()
        for m in rows:
            writer.writerow(asdict(m))
    lines = ["| case | F | level | h₀/a | unknowns | Newton | P | P (Hertz, δ) | err P | a | a (Hertz, δ) | err a "
             "| a (Hertz, P) | err | p₀ | p₀ (Hertz, δ) | err p₀ | p₀ (Hertz, P) | err | time s |",
             "|" + "---|" * 20]
    for m in rows:
        lines.append(
            f"| {m.case} | {m.friction:g} | {m.level} | {m.h_contact / m.hertz_radius:.3f} | {m.unknowns} "
            f"| {m.newton_iterations} | {m.force:.4g} | {m.hertz_force:.4g} | {m.err_force:+.2%} | {m.radius:.4g} "
            f"| {m.hertz_radius:.4g} | {m.err_radius:+.2%} | {m.radius_from_force:.4g} "
            f"| {m.err_radius_from_force:+.2%} "
            f"| {m.pressure:.4g} | {m.hertz_pressure:.4g} | {m.err_pressure:+.2%} | {m.pressure_from_force:.4g} "
            f"| {m.err_pressure_from_force:+.2%} | {m.wall_time_s:.1f} |")
    (out / "hertz.md").write_text("\n".join(lines) + "\n")
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    for ax, (key, label) in zip(axes, [("err_force", "P vs (4/3)E*√R δ^{3/2}"), ("err_radius", "a vs √(Rδ)"),
                                       ("err_pressure_from_force", "p₀ vs 3P/(2πa²), a³ = 3PR/(4E*)")], strict=True):
        for case, marker in (("sphere into block", "o"), ("elastic hemisphere on plane", "s")):
            for F, style in ((0.0, "-"), (0.3, "--")):
                sel = [m for m in rows if m.case == case and m.friction == F]
                if sel:
                    ax.plot([m.h_contact / m.hertz_radius for m in sel], [100 * abs(getattr(m, key)) for m in sel],
                            marker=marker, linestyle=style, label=f"{case}, F = {F:g}")
        ax.axhline(3.0, color="grey", linewidth=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("h₀ / a (element edge at the contact)")
        ax.set_ylabel("|relative error| %")
        ax.set_title(label, fontsize=10)
    axes[0].legend(fontsize=7)
    fig.savefig(out / "hertz.png", dpi=120)
    plt.close(fig)


# %% [markdown]
# ## Run
#
# `--levels` lists the mesh levels (`LEVELS`: h₀ = a/4, a/8, a/11.3 at the contact), `--friction` the
# coefficients, `--cases` the problems. The table, a CSV file and the figure go to `--out` when given.
# Each line printed gives the relative errors against Hertz for the approach δ and, after "vs P", against
# Hertz for the measured force.


# %%
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Hertz contact: sphere into a block, hemisphere onto a plane")
    parser.add_argument("--levels", type=int, nargs="+", default=[0], choices=sorted(LEVELS))
    parser.add_argument("--friction", type=float, nargs="+", default=[0.0, 0.3])
    parser.add_argument("--cases", nargs="+", default=["block", "hemisphere"], choices=["block", "hemisphere"])
    parser.add_argument("--out", default=None, help="write hertz.csv, hertz.md (the table) and hertz.png here")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    for case in args.cases:
        for F in args.friction:
            for level in args.levels:
                m = (indent_block if case == "block" else press_hemisphere)(level, F, comm)
                rows.append(m)
                if comm.rank == 0:
                    print(f"{m.case:28s} F={F:.2f} lev {level} h={m.h_contact:.4f} n={m.unknowns:6d} "
                          f"P={m.force:.5g} ({m.err_force:+.2%})  a={m.radius:.4f} ({m.err_radius:+.2%}; "
                          f"vs P: {m.err_radius_from_force:+.2%})  p0={m.pressure:.4f} ({m.err_pressure:+.2%}; "
                          f"vs P: {m.err_pressure_from_force:+.2%})  it={m.newton_iterations} "
                          f"{m.wall_time_s:.1f}s", flush=True)
    if args.out and comm.rank == 0:
        write_results(Path(args.out), rows)
    return 0


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING)
    sys.exit(main())
