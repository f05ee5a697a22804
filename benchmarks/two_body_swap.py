"""Swapping slave and master, and a slave larger than its master (edge dropping), for both pair methods (issue 28).

    container/run mpirun -n 2 python3 benchmarks/two_body_swap.py --out docs/two-bodies

**Swap.** The two blocks of tests/model/test_two_body.py with the full footprint [0, 2] × [0, 1] (hexahedra; the
lower block's top 5 × 3 cells, the upper block's bottom 4 × 4), the lower block's bottom clamped, the upper
block's top moved by (0.0008, 0, −0.004); E 70/20 GPa, ν 0.2/0.45; F = 0 and 0.3. Solved with slave = the
upper bottom and with slave = the lower top; reported: ‖u₁ − u₂‖/‖u₁‖ over all nodes and the total normal
force of each.

**Edge dropping.** The lower block [0, 2] × [0, 1] × [−1, 0] with a finer top (10 × 6 cells) as the SLAVE under
the smaller upper block [0.2, 1.8] × [0.1, 0.9] (4 × 4), pressed by 0.004, frictionless, tetrahedra: a dual
mortar slave node whose facets reach past the master's border is free (full coverage rule), so the larger
slave loses its contact nodes along the master's border, where node-to-surface keeps them; the same bodies
with the smaller surface as the slave for comparison. Reported: contact nodes, closed nodes (λ > 0), the total
force, and the free slave nodes that penetrate (the warning after a solve).

Writes ``swap.md`` and ``swap.csv`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
from meshes.two_blocks import TAGS, two_blocks  # noqa: E402

from fenics_coulomb import ContactPair, ContactProblem  # noqa: E402
from fenics_coulomb.io.summary import software_versions  # noqa: E402
from fenics_coulomb.model.checks import physics_residuals  # noqa: E402
from fenics_coulomb.model.dof_values import owned_values  # noqa: E402

SETTINGS = {"rtol": 1e-12, "tol": 1e-12}


def _elasticity(V):
    import ufl

    def lame(E, nu):
        return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))

    above = ufl.SpatialCoordinate(V.mesh)[2] > 0.0
    (mu1, l1), (mu2, l2) = lame(70.0, 0.2), lame(20.0, 0.45)
    mu, lmbda = ufl.conditional(above, mu2, mu1), ufl.conditional(above, l2, l1)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    return ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx


def _solve(blocks, top, slave, master, friction, method, prefix):
    comm = blocks.mesh.comm
    ft = blocks.facet_tags
    V = dolfinx.fem.functionspace(blocks.mesh, ("Lagrange", 1, (3,)))
    bcs = [dolfinx.fem.dirichletbc(np.asarray(top, float), dolfinx.fem.locate_dofs_topological(
               V, 2, ft.find(TAGS["upper_top"])), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(
               V, 2, ft.find(TAGS["lower_bottom"])), V)]
    pair = ContactPair(ft, slave=slave, master=master, friction=friction, search_distance=0.05, method=method)
    with ContactProblem(_elasticity(V), None, bcs, contact_pairs=[pair], settings=SETTINGS,
                        petsc_options_prefix=prefix) as problem:
        _, result = problem.solve()
        checks = physics_residuals(problem.model, result.relative_displacement)
        u = owned_values(problem.u)
        normal = comm.allreduce(float(np.sum(result.normal_force)), op=MPI.SUM)
        closed = comm.allreduce(int(np.sum(result.normal_force > 0)), op=MPI.SUM)
        free = problem.model.free_slave_penetrations(result.displacement)
        return dict(u=u, p=int(result.p), closed=closed, force=normal, converged=bool(result.converged),
                    checks=max(checks[k] for k in ("equilibrium", "penetration", "negative_pressure",
                                                   "complementarity")),
                    penetrating=int(free))


def swap(comm: MPI.Comm, method: str, friction: float) -> dict[str, Any]:
    """The full-footprint blocks with either surface as the slave: the relative displacement difference."""
    blocks = two_blocks(comm, lower=(2.0, 1.0, 1.0), n_lower=(5, 3, 2), upper_origin=(0.0, 0.0),
                        upper=(2.0, 1.0, 1.0), n_upper=(4, 4, 2), gap=1e-3)
    a = _solve(blocks, (0.0008, 0.0, -0.004), TAGS["upper_bottom"], TAGS["lower_top"], friction, method, "swap1_")
    b = _solve(blocks, (0.0008, 0.0, -0.004), TAGS["lower_top"], TAGS["upper_bottom"], friction, method, "swap2_")
    norm = lambda x: np.sqrt(comm.allreduce(float(x @ x), op=MPI.SUM))  # noqa: E731
    return {"study": "swap", "method": method, "friction": friction, "difference": norm(a["u"] - b["u"]) / norm(a["u"]),
            "nodes": f"{a['p']} / {b['p']}", "force": f"{a['force']:.6g} / {b['force']:.6g}",
            "converged": a["converged"] and b["converged"], "checks": max(a["checks"], b["checks"])}


def edge_dropping(comm: MPI.Comm, method: str, larger_slave: bool) -> dict[str, Any]:
    blocks = two_blocks(comm, lower=(2.0, 1.0, 1.0), n_lower=(10, 6, 2), upper_origin=(0.2, 0.1),
                        upper=(1.6, 0.8, 1.0), n_upper=(4, 4, 2), gap=1e-3, cell_type="tetrahedron")
    slave, master = (TAGS["lower_top"], TAGS["upper_bottom"]) if larger_slave else \
        (TAGS["upper_bottom"], TAGS["lower_top"])
    r = _solve(blocks, (0.0, 0.0, -0.004), slave, master, 0.0, method, "drop_")
    return {"study": "edge dropping", "method": method, "slave": "larger (lower top)" if larger_slave else
            "smaller (upper bottom)", "contact_nodes": r["p"], "closed": r["closed"], "force": r["force"],
            "penetrating": r["penetrating"], "converged": r["converged"], "checks": r["checks"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "two-bodies"))
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    swaps = [swap(comm, m, f) for m in ("mortar", "node-to-surface") for f in (0.0, 0.3)]
    drops = [edge_dropping(comm, m, s) for m in ("mortar", "node-to-surface") for s in (True, False)]
    if comm.rank == 0:
        for row in swaps + drops:
            print(row, flush=True)
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        lines = ["study,method,case,value"]
        lines += [f"swap,{r['method']},F={r['friction']:g},{r['difference']:.6g}" for r in swaps]
        lines += [f"edge dropping,{r['method']},{r['slave']},{r['contact_nodes']}" for r in drops]
        (out / "swap.csv").write_text("\n".join(lines) + "\n")
        t1 = ["| method | F | ‖u₁ − u₂‖/‖u₁‖ | contact nodes (1 / 2) | normal force (1 / 2) | physics checks |",
              "|---|---|---|---|---|---|"]
        t1 += [f"| {r['method']} | {r['friction']:g} | {100 * r['difference']:.3g} % | {r['nodes']} | {r['force']} | "
               f"{r['checks']:.1e} |" for r in swaps]
        t2 = ["| method | slave | contact nodes | closed (λ > 0) | normal force | free slave nodes penetrating | "
              "physics checks |", "|---|---|---|---|---|---|---|"]
        t2 += [f"| {r['method']} | {r['slave']} | {r['contact_nodes']} | {r['closed']} | {r['force']:.6g} | "
               f"{r['penetrating']} | {r['checks']:.1e} |" for r in drops]
        doc = __doc__.split("\n\n", 2)[2].split("Writes ``swap.md``")[0].strip()
        (out / "swap.md").write_text(f"""# Swapping slave and master; a slave larger than its master

`container/run mpirun -n 2 python3 benchmarks/two_body_swap.py --out docs/two-bodies` ({comm.size} MPI ranks).

{doc}

## Swap

{chr(10).join(t1)}

## Edge dropping

{chr(10).join(t2)}

Software: {json.dumps(software_versions())}.
""")
    ok = all(r["converged"] for r in swaps + drops)
    return 0 if ok else 3


if __name__ == "__main__":
    sys.exit(main())
