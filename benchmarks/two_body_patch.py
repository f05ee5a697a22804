"""The contact patch test between two elastic blocks (issue 18): uniform pressure through non-matching meshes.

    container/run mpirun -n 2 python3 benchmarks/two_body_patch.py --out docs/two-bodies

Two blocks of the same footprint [0, 1]², the lower one [0, 1]² × [−0.5, 0] (E = 210 GPa; the master surface
is its top), the upper one [0, 1]² × [0, 0.5] (E = 70 GPa; the slave surface is its bottom), both with ν = 0,
resting on each other (gap 0), meshed independently (meshes/two_blocks.py). Roller sides (the normal
displacement component is zero on every side face), the lower block's bottom on rollers (u₃ = 0), and the
uniform pressure applied through the upper block's top as the uniform displacement u₃ = −δ that produces it
(every body needs boundary conditions that remove its rigid motions; contact alone does not hold the upper
block). The exact solution is a uniaxial strain in each block with the same stress σ₃₃ = −p in both,

    p = δ / (H₁/M₁ + H₂/M₂),   M = E(1 − ν)/((1 + ν)(1 − 2ν)) (the P-wave modulus), H the heights,

so the contact pressure is uniform: λᵢ = p Aᵢ at every slave node (Aᵢ = ∫ φᵢ ds, the lumped nodal area) and
no tangential force. The slave surface's perimeter nodes are left out of the rollers (a node with any
constrained component is never a contact node). Why ν = 0: then σ₁₁ = σ₂₂ = 0 and the exact state needs no
side reaction at those perimeter nodes. With ν ≠ 0 it needs one (σ₁₁ = ν/(1 − ν) σ₃₃ on the side faces),
which frictionless contact cannot supply, so even matching meshes fail (the row "matching, ν ≠ 0"): a
consequence of "a Dirichlet node is never a contact node" (full bodies, no symmetry cuts through the slave
surface), not of the transfer between the meshes.

Node-to-surface contact does NOT pass this patch test on non-matching meshes: each slave node is constrained
against the master surface at one point, and the nodal forces it transfers to the master nodes through φ_sj
do not reproduce the master's consistent nodal loads of a uniform pressure, so the pressure oscillates
(mortar methods pass it). On matching meshes it passes to round-off (the control case). Reported: the relative
error of the nodal pressures λᵢ/Aᵢ (largest and RMS over the slave nodes), of the total force, and the
largest |tangential force|/(p Aᵢ).

Writes ``patch.csv`` and ``patch.md`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from meshes.two_blocks import BODIES, TAGS, two_blocks  # noqa: E402

from fenics_coulomb import ContactPair, ContactProblem  # noqa: E402
from fenics_coulomb.model.checks import physics_residuals  # noqa: E402
from fenics_coulomb.model.forces import contact_areas
from fenics_coulomb.model.pairs.forces import pair_forces
from fenics_coulomb.io.summary import software_versions  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

#: (E in GPa, ν) of the lower and the upper block.
MATERIALS = ((210.0, 0.0), (70.0, 0.0))
POISSON = ((210.0, 0.3), (70.0, 0.35))
HEIGHT = 0.5
CHECKS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "reaction_balance")
#: (label, cell type, cells of the lower block, cells of the upper block, materials)
CASES = [
    ("matching (control)", "hexahedron", (4, 4, 2), (4, 4, 2), MATERIALS),
    ("matching (control)", "tetrahedron", (4, 4, 2), (4, 4, 2), MATERIALS),
    ("slave finer", "hexahedron", (4, 4, 2), (5, 5, 2), MATERIALS),
    ("slave coarser", "hexahedron", (5, 5, 2), (4, 4, 2), MATERIALS),
    ("slave finer, 7 on 4", "hexahedron", (4, 4, 2), (7, 7, 2), MATERIALS),
    ("slave finer, 8 on 4 (nested)", "hexahedron", (4, 4, 2), (8, 8, 2), MATERIALS),
    ("slave finer, refined twice", "hexahedron", (8, 8, 2), (10, 10, 2), MATERIALS),
    ("slave finer", "tetrahedron", (4, 4, 2), (5, 5, 2), MATERIALS),
    ("slave coarser", "tetrahedron", (5, 5, 2), (4, 4, 2), MATERIALS),
    ("matching, ν ≠ 0", "hexahedron", (4, 4, 2), (4, 4, 2), POISSON),
]


def p_wave(E: float, nu: float) -> float:
    return E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))


def exact_pressure(delta: float, materials=MATERIALS) -> float:
    """The uniform contact pressure of the uniaxial strain state."""
    return delta / sum(HEIGHT / p_wave(*m) for m in materials)


def elasticity(V: dolfinx.fem.FunctionSpace, cell_tags: dolfinx.mesh.MeshTags, materials=MATERIALS) -> ufl.Form:
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    dx = ufl.Measure("dx", domain=V.mesh, subdomain_data=cell_tags)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    forms = []
    for body, (E, nu) in zip(("lower", "upper"), materials, strict=True):
        mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
        forms.append(ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * dx(BODIES[body]))
    return forms[0] + forms[1]


def rollers(V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags, delta: float) -> list:
    """Roller sides (not at the slave surface's perimeter), the lower bottom on rollers, u₃ = −δ on the top."""
    msh = V.mesh
    x = V.tabulate_dof_coordinates()
    bcs = []
    sides = np.concatenate([facet_tags.find(TAGS["lower_sides"]), facet_tags.find(TAGS["upper_sides"])])
    upper_sides = np.isin(sides, facet_tags.find(TAGS["upper_sides"]))
    mid = dolfinx.mesh.compute_midpoints(msh, 2, sides)
    for axis in (0, 1):
        on = np.isclose(mid[:, axis], 0.0) | np.isclose(mid[:, axis], 1.0)
        for facets, upper in ((sides[on & ~upper_sides], False), (sides[on & upper_sides], True)):
            dofs = dolfinx.fem.locate_dofs_topological(V.sub(axis), 2, facets)
            if upper:  # not the slave surface's perimeter (x₃ = 0 on the upper block)
                dofs = dofs[x[dofs // 3, 2] > 1e-9]
            bcs.append(dolfinx.fem.dirichletbc(0.0, dofs, V.sub(axis)))
    for tag, value in (("lower_bottom", 0.0), ("upper_top", -delta)):
        dofs = dolfinx.fem.locate_dofs_topological(V.sub(2), 2, facet_tags.find(TAGS[tag]))
        bcs.append(dolfinx.fem.dirichletbc(value, dofs, V.sub(2)))
    return bcs


def run(comm: MPI.Comm, cell: str, n_lower: tuple[int, ...], n_upper: tuple[int, ...], materials=MATERIALS,
        delta: float = 0.001, friction: float = 0.0, method: str = "mortar") -> dict[str, Any]:
    """One case: the pressure errors against the exact uniform pressure (nodal pressure λᵢ/Dᵢ for mortar, λᵢ/Aᵢ
    with the lumped area Aᵢ = ∫ φᵢ ds for node-to-surface)."""
    blocks = two_blocks(comm, lower=(1.0, 1.0, HEIGHT), n_lower=n_lower, upper_origin=(0.0, 0.0),
                        upper=(1.0, 1.0, HEIGHT), n_upper=n_upper, gap=0.0, cell_type=cell)
    V = dolfinx.fem.functionspace(blocks.mesh, ("Lagrange", 1, (3,)))
    pair = ContactPair(blocks.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], friction=friction,
                       method=method)
    with ContactProblem(elasticity(V, blocks.cell_tags, materials), None, rollers(V, blocks.facet_tags, delta),
                        contact_pairs=[pair], settings={"rtol": 1e-12, "tol": 1e-14},
                        petsc_options_prefix="patch_") as problem:
        _, result = problem.solve()
        model = problem.model
        checks = physics_residuals(model, result.relative_displacement)
        (forces,) = pair_forces(model, result, [pair])
        areas = contact_areas(model)
        mortar = np.isfinite(model.pairing.area)  # the pairing's nodes are the contact nodes (ascending blocks)
        areas[mortar] = model.pairing.area[mortar]
        p = exact_pressure(delta, materials)
        normal = np.einsum("ij,ij->i", result.contact_force, model.contact.normals)
        tangential = np.linalg.norm(result.contact_force - normal[:, None] * model.contact.normals, axis=1)
        error = normal / areas / p - 1
        local = np.array([np.abs(error).max(initial=0.0), (tangential / (p * areas)).max(initial=0.0)])
        worst = [comm.allreduce(float(v), op=MPI.MAX) for v in local]
        rms = np.sqrt(comm.allreduce(float(np.sum(error**2)), op=MPI.SUM) / result.p)
    P = forces["force_on_slave_body"][2]
    return {"case": "", "method": method, "cell": cell, "nu": "/".join(f"{m[1]:g}" for m in materials),
            "lower": "×".join(map(str, n_lower)), "upper": "×".join(map(str, n_upper)),
            "contact_nodes": int(result.p), "converged": bool(result.converged), "p_exact": p,
            "max_pressure_error": float(worst[0]), "rms_pressure_error": float(rms), "force_error": P / p - 1,
            "max_tangential": float(worst[1]), "balance": forces["balance"],
            "checks": max(checks[k] for k in CHECKS)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "two-bodies"))
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    for method in ("mortar", "node-to-surface"):
        for label, cell, n_lower, n_upper, materials in CASES:
            row = run(comm, cell, n_lower, n_upper, materials, method=method)
            row["case"] = label
            rows.append(row)
            if comm.rank == 0:
                print(row, flush=True)
    if comm.rank == 0:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        keys = list(rows[0])
        (out / "patch.csv").write_text("\n".join([",".join(keys)] + [",".join(
            f"{r[k]:.6g}" if isinstance(r[k], float) else str(r[k]) for k in keys) for r in rows]) + "\n")
        table = ["| method | case | cells | lower (master) | upper (slave) | slave nodes | max pressure error | "
                 "RMS pressure "
                 "error | total force error | max tangential / (p Aᵢ) | balance | physics checks |", "|" + "---|" * 12]
        for r in rows:
            table.append(f"| {r['method']} | {r['case']} | {r['cell']} | {r['lower']} | {r['upper']} | "
                         f"{r['contact_nodes']} | "
                         f"{100 * r['max_pressure_error']:.3g} % | {100 * r['rms_pressure_error']:.3g} % | "
                         f"{100 * r['force_error']:+.2g} % | {r['max_tangential']:.1e} | {r['balance']:.1e} | "
                         f"{r['checks']:.1e} |")
        doc = __doc__.split("\n\n", 2)[2].split("Writes ``patch.csv``")[0].strip()
        (out / "patch.md").write_text(f"""# Contact patch test between two elastic blocks

`container/run mpirun -n 2 python3 benchmarks/two_body_patch.py --out docs/two-bodies` ({comm.size} MPI ranks).

{doc}

Frictionless, δ = 0.001, p = {rows[0]['p_exact']:.6g} GPa (ν = 0). "cells": per direction (x₁ × x₂ × x₃) of each
block. **Dual mortar** (the default) passes the patch test on every mesh pair: the nodal pressures λᵢ/Dᵢ equal p
to round-off and the tangential forces vanish (Σⱼ ψⱼ = 1 makes the master's nodal forces the consistent loads
p ∫ N_l of the uniform pressure; `model/pairs/segmentation.py`). **Node-to-surface**: a slave mesh nested in
the master mesh (every slave node at a master vertex, edge midpoint or facet centre of a bilinear facet) passes
like the matching one; on non-matching meshes the largest nodal pressure error is several per cent on
hexahedra and over 10 % on tetrahedra and does not fall when both meshes are refined (the row "refined
twice"), while the total force stays within 0.3 %. Pressure: λᵢ/Dᵢ (mortar), λᵢ/Aᵢ (node-to-surface, Aᵢ the
lumped area ∫ φᵢ ds; equal to Dᵢ on a fully covered node). "balance" is |force on the upper + force on the
lower block| / |force on the upper block|, each from its own residual (on a supported master node the contact
force it receives, `fenics_coulomb.model.pairs.forces.pair_forces`).

{chr(10).join(table)}

Software: {json.dumps(software_versions())}.
""")
    return 0 if all(r["converged"] for r in rows) else 3


if __name__ == "__main__":
    sys.exit(main())
