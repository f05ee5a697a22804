"""Tractive rolling of a rigid roller on an elastic block against Carter's solution (issue 26).

    container/run mpirun -n 2 python3 benchmarks/rolling_carter.py --out docs/rolling

A rigid roller (radius R = 1, axis along x2, spanning the block) is pressed into the block
[−0.5, 1.0] × [0, W] × [−H, 0] (E = 70 GPa, ν = 0.49, the bottom clamped; hexahedra refined toward the top and the
rolling track) and then rolled along +x1 in N steps: step k translates it by k Δ and turns it about its own axis
by k Δ (1 + ξ)/R — rolling with the creep ξ (ξ = 0: free rolling, the roller's surface has no velocity relative
to the block at the contact; ξ > 0: the roller drives, its surface moves backwards against the block). Coulomb
friction μ = 0.3. After rolling a distance of several contact widths the contact is steady.

Carter (1926; Johnson, Contact Mechanics §8.2) for a cylinder rolling on an elastically similar half-space —
here a rigid roller on an (almost) incompressible block: the normal and tangential problems uncouple (Dundurs'
β = (1 − 2ν)/(2(1 − ν)) = 0.0196) — under the tangential force Q < μP: the contact strip |x| <= a has a STICK zone
at its LEADING edge, a − 2a' <= x <= a, and slips over the rest, with

    a'/a = √(1 − Q/(μP)),   ξ = (μ a / R)(1 − a'/a).

Measured on the block's mid-plane x2 = W/2 (plane strain there, the free ends of the strip aside) at the last
step: a (the closed nodes' half-extent), the stick zone's extent [x_s, x_e] and its width 2a' (the stick nodes'
extent plus one node spacing: the zone's edges lie between nodes), and on the whole contact Q/P. Compared:
a'/a against √(1 − Q/(μP)) from the measured Q/P (Carter's traction distribution: the stick zone's size for the
tangential force carried), and the stick zone at the leading edge. The creep ξ that Carter gives for the
measured a and Q/P is listed against the prescribed one for information only: the block (clamped at depth
H ≈ 13 a, 1.5 long) is a shear spring in series with the contact, so under a prescribed creep Q keeps growing
long after the first 2a of rolling (ξ = 0.01: Q/(μP) = 0.35 after 20 steps, 0.45 after 25; Carter's steady
value 0.70); a'/a against Q/(μP) holds along the way (the traction follows the stick zone's history, which is
short), the creep–force law only in the steady state. Obstacles: the analytic cylinder and the same
roller as a triangulated surface (an STL prism of 720 facets, ``fenics_coulomb.Surface``).

Writes ``carter.md``, ``carter.csv`` and ``carter.png`` (the mid-plane's tangential and normal tractions) into
``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

ROOT = Path(__file__).resolve().parents[1]
from meshes.surfaces import cylinder, write_stl  # noqa: E402

from fenics_coulomb import ContactProblem, ContactState, Cylinder, Surface  # noqa: E402
from fenics_coulomb.io.summary import software_versions  # noqa: E402
from fenics_coulomb.scenes.partition import box_partitioner  # noqa: E402

E, NU, MU, R = 70.0, 0.49, 0.3, 1.0
X0, X1, W, H = -0.5, 1.0, 0.5, 1.0


def block(comm: MPI.Comm, n: tuple[int, int, int]) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """The block, its hexahedra refined toward the top (z = −H ζ²) and toward the track x ∈ [−0.12, 0.42]."""
    corners = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]
    msh = dolfinx.mesh.create_box(comm, corners, list(n), dolfinx.mesh.CellType.hexahedron,
                                  partitioner=box_partitioner(corners, list(n), dolfinx.mesh.GhostMode.none))
    x = msh.geometry.x
    # x: 70 % of the cells on the track [−0.12, 0.42], the rest on either side (piecewise linear, monotone)
    s = x[:, 0].copy()
    knots_s, knots_x = [0.0, 0.15, 0.85, 1.0], [X0, -0.12, 0.42, X1]
    x[:, 0] = np.interp(s, knots_s, knots_x)
    x[:, 1] *= W
    x[:, 2] = -H * (1.0 - x[:, 2]) ** 2
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda p: np.isclose(p[2], 0.0))
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda p: np.isclose(p[2], -H))
    facets = np.concatenate([top, bottom])
    values = np.concatenate([np.full(top.size, 1, np.int32), np.full(bottom.size, 2, np.int32)])
    order = np.argsort(facets)
    return msh, dolfinx.mesh.meshtags(msh, 2, facets[order].astype(np.int32), values[order])


def roller(kind: str, out: Path, depth: float, comm: MPI.Comm) -> Any:
    centre = (0.0, 0.0, R)
    if kind == "cylinder":
        return Cylinder(point=centre, axis=(0, 1, 0), radius=R, displacement=(0, 0, -depth), name="roller")
    path = out / "carter_roller.stl"
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        write_stl(path, cylinder(R, (0.0, -0.5, R), W + 1.0, segments=720, axis=1), binary=True)
    comm.barrier()
    return Surface(file=str(path), displacement=(0, 0, -depth), name="roller")


def run(comm: MPI.Comm, kind: str, creep: float, out: Path, n=(156, 6, 24), depth=0.01, step=0.01,
        steps=20) -> dict[str, Any]:
    msh, tags = block(comm, n)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, tags.find(2)), V)
    mu, lmbda = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    a = ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx
    t0 = time.perf_counter()
    with ContactProblem(a, None, bcs=[clamp], contact=(tags, [1]), friction=MU,
                        obstacles=[roller(kind, out, depth, comm)], settings={"rtol": 1e-9},
                        petsc_options_prefix="carter_") as problem:
        _, result = problem.solve()
        for k in range(1, steps + 1):
            angle = math.degrees(k * step * (1 + creep) / R)
            problem.move("roller", (k * step, 0.0, -depth), rotation=[angle, [0.0, 1.0, 0.0], [0.0, 0.0, R]])
            _, result = problem.solve()
            if not result.converged:
                raise RuntimeError(f"step {k}: {result.reason}")
        report = problem.report(result)
    seconds = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    nodes = report.nodes
    force = report.total_force  # on the body
    P, Q = -float(force[2]), -float(force[0])  # the roller's push (down on the block) and its traction
    centre = steps * step
    mid = np.isclose(nodes.coordinates[:, 1], 0.5 * W, atol=1e-9)
    x = nodes.coordinates[mid, 0] - centre
    state = nodes.state[mid]
    order = np.argsort(x)
    x, state = x[order], state[order]
    pressure = nodes.pressure[mid][order]
    traction = nodes.force[mid][order] / np.maximum(nodes.area[mid][order], 1e-300)[:, None]
    closed = state != ContactState.OPEN
    spacing = float(np.min(np.diff(x))) if x.size > 1 else 0.0
    a = 0.5 * (x[closed].max() - x[closed].min() + spacing)
    stick = state == ContactState.STICK
    xs, xe = (float(x[stick].min()), float(x[stick].max())) if stick.any() else (math.nan, math.nan)
    a_stick = 0.5 * (xe - xs + spacing) if stick.any() else 0.0
    ratio = Q / (MU * P)
    theory = math.sqrt(max(1.0 - ratio, 0.0))
    return {"obstacle": kind, "creep": creep, "P": P, "Q": Q, "Q/(muP)": ratio, "a": a, "centre_offset":
            float(0.5 * (x[closed].max() + x[closed].min())), "stick_from": xs, "stick_to": xe,
            "a_stick/a": a_stick / a, "theory a'/a": theory,
            "creep (theory)": MU * a / R * (1 - theory), "spacing": spacing, "seconds": seconds,
            "profile": (x, pressure, traction[:, 0])}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "rolling"))
    parser.add_argument("--creeps", type=float, nargs="+", default=[0.005, 0.01])
    parser.add_argument("--obstacles", nargs="+", default=["cylinder", "surface"])
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    out = Path(args.out)
    rows = []
    for kind in args.obstacles:
        for creep in args.creeps:
            row = run(comm, kind, creep, out)
            rows.append(row)
            if comm.rank == 0:
                print({k: v for k, v in row.items() if k != "profile"}, flush=True)
    if comm.rank == 0:
        write(out, rows, comm)
        (out / "carter_roller.stl").unlink(missing_ok=True)  # the roller's STL: made by the run, not a result
    return 0


def write(out: Path, rows: list[dict[str, Any]], comm: MPI.Comm) -> None:
    out.mkdir(parents=True, exist_ok=True)
    keys = [k for k in rows[0] if k != "profile"]
    (out / "carter.csv").write_text("\n".join([",".join(keys)] + [",".join(
        str(r[k]) if isinstance(r[k], str) else f"{r[k]:.6g}" for k in keys) for r in rows]) + "\n")
    table = ["| obstacle | creep ξ | P | Q | Q/(μP) | a | stick zone [x_s, x_e] − centre | a'/a measured | "
             "√(1 − Q/(μP)) | ξ from Carter | node spacing | time |", "|" + "---|" * 12]
    for r in rows:
        theory = r["theory a'/a"]
        table.append(f"| {r['obstacle']} | {r['creep']:g} | {r['P']:.4g} | {r['Q']:.4g} | {r['Q/(muP)']:.3f} | "
                     f"{r['a']:.4f} | [{r['stick_from']:.4f}, {r['stick_to']:.4f}] | {r['a_stick/a']:.3f} | "
                     f"{theory:.3f} | {r['creep (theory)']:.4f} | {r['spacing']:.4f} | "
                     f"{r['seconds']:.0f} s |")
    doc = __doc__.split("\n\n", 2)[2].split("Writes ``carter.md``")[0].strip()
    (out / "carter.md").write_text(f"""# Tractive rolling against Carter's solution

`container/run mpirun -n {comm.size} python3 benchmarks/rolling_carter.py --out docs/rolling`.

**The steady state and Carter's creep law are case 8 of the verification table** (docs/verification/README.md §8,
`benchmarks/verification_rolling.py`): a plane-strain slice of this block, pre-loaded by a turn of the roller in
place and rolled until Q changes by less than 0.1 % over five steps. This page is the 3D model's transient (20
steps from Q = 0; not the steady state) and the STL roller's agreement with the analytic one.

{doc}

{chr(10).join(table)}

![mid-plane tractions](carter.png)

Software: {json.dumps(software_versions())}; {comm.size} MPI ranks.
""")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    for r in rows:
        x, p, t = r["profile"]
        line = ax.plot(x / r["a"], p, "-", lw=1, label=f"{r['obstacle']}, ξ = {r['creep']:g}: pressure")[0]
        ax.plot(x / r["a"], t, "--", lw=1, color=line.get_color(), label="tangential traction")
        ax.plot(x / r["a"], MU * p, ":", lw=0.8, color=line.get_color())
    ax.set_xlim(-1.5, 1.5)
    ax.set_xlabel("x / a (rolling towards +x)")
    ax.set_ylabel("traction on the block (GPa)")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out / "carter.png", dpi=120)


if __name__ == "__main__":
    sys.exit(main())
