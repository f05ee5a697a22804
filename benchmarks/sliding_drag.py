"""The finite-sliding drag patch test: a block dragged over a longer elastic block whose exact solution is uniform.

    container/run mpirun -n 2 python3 benchmarks/sliding_drag.py --out docs/sliding

Two blocks of tetrahedra in one mesh (meshes/two_blocks.py), non-matching: the lower (master) block
[0, 2] × [0, 1] × [−H, 0], the upper (slave) block [x₀, x₀ + a] × [y₀, y₀ + b] × [g, g + h] with g = 0.002 above it;
slave the upper bottom, master the lower top, friction F = 0.3. The upper top is prescribed (s, 0, −δ): pressed with
s = 0, then dragged along x; the lower bottom is clamped. The upper block stays above the lower top all the way.

**The exact solution, and the loads that make it uniform.** A dragged block on a longer block is not uniform by
itself: its free ends cannot carry the couple of the drag (the friction at the bottom and the drive at the top, a
moment F·P·h that tilts the pressure), and the lower top outside the footprint is free, so the lower block bends
under a patch load (a dish, not a plane). The patch test applies, on every face that is neither supported nor in
contact, the traction σ·n of the homogeneous state below (a patch test's prescribed boundary data), in particular
on the lower top outside the footprint — the footprint moves with the drag, so that load moves with it (a UFL
indicator of the footprint in the lower block's material coordinates, Constants set per state). The state: a
uniaxial strain along x₃ plus a simple shear in x₁x₃, the same stress in both blocks,

    σ = −p e₃⊗e₃ + τ (e₁⊗e₃ + e₃⊗e₁) − p λᵢ/Mᵢ (e₁⊗e₁ + e₂⊗e₂),   τ = F p (slipping),  τ = 0 (pressed),

u = (s + γᵤ (z − z_top), 0, −δ + p (z_top − z)/Mᵤ) in the upper block (γ = τ/μ) and u = (γₗ (z + H), 0,
−p (z + H)/Mₗ) in the lower one (M = λ + 2μ the P-wave modulus). It satisfies: equilibrium (constant σ); the
upper top's prescribed (s, 0, −δ) and the lower bottom's clamp (∂u/∂x₁ = ∂u/∂x₂ = 0: no strain in the plane);
contact: the upper bottom's traction σ·(−e₃) = (−τ, 0, p) is the lower top's σ·e₃ reversed, both faces stay
plane and horizontal (so the deformed normal is e₃ and finite sliding's gap is exact), and the gap closes,
g + u₃ᵤ(g) − u₃ₗ(0) = 0, at

    p = (δ − g) / (h/Mᵤ + H/Mₗ);

Coulomb: the traction on the upper block, −τ e₁ = −F p e₁, opposes its slip, which is along +e₁ at every node of a
drag step (each node's slip increment is the footprint's advance: the strains are the same in every dragged state).
The footprint's edges must lie on the lower mesh's grid lines for the indicator to be integrated exactly, so the top
is driven to s = k·Δ + γᵤ h + γₗ H (Δ the lower cell size along x): the upper bottom then sits, in the lower block's
material coordinates, exactly k cells on. (A fractional k, the scan of ``main``, puts the edges inside lower facets,
whose share of the moving load a degree-12 rule integrates nearly: there mortar shows that floor, node-to-surface
its oscillation as the slave nodes pass the master facets.) P1 reproduces the affine field, and dual mortar
transmits the uniform traction exactly (Σⱼ ψⱼ = 1: the master's nodal forces are the consistent loads of the uniform
traction over the footprint, which the moving load completes to the whole top). At every whole-cell state: every nodal
pressure λⱼ/Dⱼ is p, the normal force is P = p·a·b, every node slips with its traction on the cone and the
tangential force is F·P along −e₁ — the finite-sliding patch test. Node-to-surface transfers each slave force at one
point and does not pass it: its nodal pressures are off and its normal force oscillates as the slave nodes pass the
master facets (measured here and in docs/sliding/drag.md).
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from fenics_coulomb import ContactPair, ContactProblem, SolverError
from meshes.two_blocks import BODIES, TAGS, two_blocks

__all__ = ["DragPatch", "drag_patch", "exact_pressure", "main"]

LOG = logging.getLogger(__name__)

#: (E, ν) of the lower and the upper block.
MATERIALS = {"lower": (70.0, 0.3), "upper": (200.0, 0.25)}
LOWER = (2.0, 1.0, 0.5)
UPPER_ORIGIN = (0.2, 0.25)
UPPER = (0.6, 0.5, 0.5)
GAP = 0.002
PRESS = 0.01
FRICTION = 0.3
#: The solver's reduction target (the nodal pressures to about 1e-9; see DragPatch.solve).
RTOL = 1e-12


def lame(E: float, nu: float) -> tuple[float, float]:
    """(μ, λ) of (E, ν)."""
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def exact_pressure(press: float = PRESS, gap: float = GAP, materials: dict[str, tuple[float, float]] = MATERIALS,
                   heights: tuple[float, float] = (LOWER[2], UPPER[2])) -> float:
    """The uniform contact pressure p = (δ − g)/(h/Mᵤ + H/Mₗ) of the patch test's state (M = λ + 2μ)."""
    waves = {}
    for body in ("lower", "upper"):
        mu, lmbda = lame(*materials[body])
        waves[body] = lmbda + 2 * mu
    return (press - gap) / (heights[1] / waves["upper"] + heights[0] / waves["lower"])


class DragPatch:
    """The two blocks of the drag patch test as a ContactProblem, with the exact boundary tractions as loads.

    Args:
        comm: Communicator (collective).
        method: "mortar" or "node-to-surface".
        n_lower: Cells of the lower block per direction (its x spacing is the drag's step unit).
        n_upper: Cells of the upper block per direction.
        friction: Coulomb's F.
        rtol: The solver's reduction target (1e-12: the nodal pressures to 1e-9, see ``solve``).
        outside_load: Apply the state's traction on the lower top outside the footprint (False: that part free,
            which is not the patch test; the control case).
        load_degree: Quadrature degree of the moving load (2 integrates it exactly at whole-cell states; the
            benchmark's sub-cell scan uses 12).
        prefix: PETSc options prefix.
    """

    def __init__(self, comm: MPI.Comm, *, method: str = "mortar", n_lower: tuple[int, int, int] = (10, 4, 2),
                 n_upper: tuple[int, int, int] = (4, 3, 2), friction: float = FRICTION, rtol: float = RTOL,
                 outside_load: bool = True, load_degree: int = 2,
                 prefix: str = "drag_patch_"):
        self.friction = friction
        self.cell = LOWER[0] / n_lower[0]
        if abs(UPPER_ORIGIN[0] / self.cell - round(UPPER_ORIGIN[0] / self.cell)) > 1e-9 or abs(
                UPPER[0] / self.cell - round(UPPER[0] / self.cell)) > 1e-9 or any(
                abs(v * n_lower[1] / LOWER[1] - round(v * n_lower[1] / LOWER[1])) > 1e-9
                for v in (UPPER_ORIGIN[1], UPPER_ORIGIN[1] + UPPER[1])):
            raise ValueError(f"n_lower = {n_lower}: the upper block's footprint must lie on the lower grid lines")
        blocks = two_blocks(comm, lower=LOWER, n_lower=n_lower, upper_origin=UPPER_ORIGIN, upper=UPPER,
                            n_upper=n_upper, gap=GAP, cell_type="tetrahedron")
        msh = blocks.mesh
        V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
        self.p = exact_pressure()
        self.area = UPPER[0] * UPPER[1]
        self.top = dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -PRESS]))
        self.tau = dolfinx.fem.Constant(msh, 0.0)  # the shear stress of the state: 0 pressed, F·p dragged
        self.footprint = dolfinx.fem.Constant(msh, np.array([UPPER_ORIGIN[0], UPPER_ORIGIN[0] + UPPER[0]]))
        ft = blocks.facet_tags
        top = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["upper_top"]))
        bottom = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(TAGS["lower_bottom"]))
        bcs = [dolfinx.fem.dirichletbc(np.zeros(3), bottom, V), dolfinx.fem.dirichletbc(self.top, top, V)]
        a, L = self._forms(V, blocks.cell_tags, ft, outside_load, load_degree)
        self.pair = ContactPair(ft, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], friction=friction,
                                method=method)
        self.problem = ContactProblem(a, L, bcs, contact_pairs=[self.pair], settings={"rtol": rtol},
                                      petsc_options_prefix=prefix, sliding="finite")

    def _forms(self, V: dolfinx.fem.FunctionSpace, cell_tags: dolfinx.mesh.MeshTags,
               ft: dolfinx.mesh.MeshTags, outside_load: bool, load_degree: int) -> tuple[ufl.Form, ufl.Form]:
        """Elasticity per body, and the exact state's traction σ·n on the free faces and outside the footprint."""
        msh = V.mesh
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        dx = ufl.Measure("dx", domain=msh, subdomain_data=cell_tags)
        ds = ufl.Measure("ds", domain=msh, subdomain_data=ft, metadata={"quadrature_degree": 2})
        n, x = ufl.FacetNormal(msh), ufl.SpatialCoordinate(msh)
        e1, e2, e3 = (ufl.as_vector([float(i == j) for j in range(3)]) for i in range(3))

        def eps(w: Any) -> Any:
            return ufl.sym(ufl.grad(w))

        a, L = 0, 0
        for body, sides in (("lower", "lower_sides"), ("upper", "upper_sides")):
            mu, lmbda = lame(*MATERIALS[body])
            a += ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * dx(BODIES[body])
            lateral = -self.p * lmbda / (lmbda + 2 * mu)
            sigma = (-self.p * ufl.outer(e3, e3) + self.tau * (ufl.outer(e1, e3) + ufl.outer(e3, e1))
                     + lateral * (ufl.outer(e1, e1) + ufl.outer(e2, e2)))
            L += ufl.inner(ufl.dot(sigma, n), v) * ds(TAGS[sides])
        y0, y1 = UPPER_ORIGIN[1], UPPER_ORIGIN[1] + UPPER[1]
        inside = ufl.And(ufl.And(ufl.gt(x[0], self.footprint[0]), ufl.lt(x[0], self.footprint[1])),
                         ufl.And(ufl.gt(x[1], y0), ufl.lt(x[1], y1)))
        outside = ufl.conditional(inside, 0.0, 1.0)
        if outside_load:
            top = ufl.Measure("ds", domain=msh, subdomain_data=ft, metadata={"quadrature_degree": load_degree})
            L += outside * ufl.inner(self.tau * e1 - self.p * e3, v) * top(TAGS["lower_top"])
        return a, L

    def offset(self) -> float:
        """γᵤ h + γₗ H: how far the sheared blocks carry the upper bottom behind the top, relative to the lower top."""
        mu_u, mu_l = lame(*MATERIALS["upper"])[0], lame(*MATERIALS["lower"])[0]
        return self.friction * self.p * (UPPER[2] / mu_u + LOWER[2] / mu_l)

    def solve(self, cells: float) -> dict[str, Any]:
        """The state with the footprint ``cells`` lower cells on (0: the press; a whole number: the patch test's
        states; otherwise the footprint's edges cross lower facets, whose share of the moving load the quadrature of
        degree 12 integrates nearly, not exactly); its data (collective).

        Returns:
            The shift of the footprint, the contact nodes, the slipping nodes, the normal force P and the tangential
            force Q on the upper block, Σ|t_j| and F·Σ p_j, the nodal pressures' largest relative deviation from p
            and their spread, the geometry updates and the Newton iterations. The pressures' accuracy is the
            solve's: the geometry settles within 8·rtol·‖u‖∞ of the total u, which holds the slide (80× the elastic
            part): measured 3e-8, 1.2e-9, 1.8e-10 at rtol 1e-11, 1e-12, 1e-13.
        """
        shift = cells * self.cell
        dragged = cells > 0
        self.tau.value = self.friction * self.p if dragged else 0.0
        self.top.value[:] = [shift + (self.offset() if dragged else 0.0), 0.0, -PRESS]
        self.footprint.value[:] = [UPPER_ORIGIN[0] + shift, UPPER_ORIGIN[0] + UPPER[0] + shift]
        _, result = self.problem.solve()
        nodes = self.problem.report(result).nodes
        closed = nodes.normal_force > 0
        tangential = nodes.force - nodes.normal_force[:, None] * nodes.normal
        force = nodes.force.sum(axis=0)
        pressure = nodes.pressure[closed]
        return {"shift": shift, "converged": bool(result.converged), "nodes": int(closed.sum()),
                "contact_nodes": int(nodes.state.size), "slip": int(np.sum(nodes.state == 2)),
                "P": float(nodes.normal_force.sum()), "P_exact": self.p * self.area,
                "Q": float(np.linalg.norm(force[:2])), "Qx": float(force[0]),
                "sum_t": float(np.linalg.norm(tangential, axis=1).sum()),
                "F_sum_p": self.friction * float(nodes.normal_force.sum()),
                "p_exact": self.p, "pressure_error": float(np.abs(pressure / self.p - 1).max(initial=0.0)),
                "pressure_spread": float(np.ptp(pressure) / self.p) if pressure.size else 0.0,
                "updates": int(result.geometry_updates), "newton": int(result.iterations)}

    def destroy(self) -> None:
        """Free the problem's PETSc objects."""
        self.problem.destroy()


def drag_patch(comm: MPI.Comm, method: str = "mortar", cells: int = 4, substeps: int = 1, *,
               record_failures: bool = False, **kw: Any) -> list[dict[str, Any]]:
    """The press, then the drag over ``cells`` lower cells in ``substeps`` states per cell (collective).

    ``record_failures``: a state whose solve raises :class:`~fenics_coulomb.errors.SolverError` becomes a row with
    ``converged`` False and its message (the path goes on from the last converged state); otherwise it raises."""
    patch = DragPatch(comm, method=method, prefix=f"drag_patch_{method.replace('-', '_')}_", **kw)
    try:
        rows = []
        for k in range(cells * substeps + 1):
            t0 = time.perf_counter()
            try:
                row = patch.solve(k / substeps)
            except SolverError as error:
                if not record_failures:
                    raise
                row = {"shift": k / substeps * patch.cell, "converged": False, "message": str(error)}
            row["wall_s"] = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
            if not row["converged"]:
                rows.append(row)
                LOG.info("%s: shift %.4f failed: %s", method, row["shift"], row.get("message", "not converged"))
                continue
            rows.append(row)
            LOG.info("%s: shift %.3f, P/P_exact − 1 = %.2e, pressure error %.2e, %d updates", method,
                     row["shift"], row["P"] / row["P_exact"] - 1, row["pressure_error"], row["updates"])
        return rows
    finally:
        patch.destroy()


def _figure(scan: dict[str, list[dict[str, Any]]], cell: float, path: Path) -> None:
    """|P/P_exact − 1| and the largest nodal pressure error over the sub-cell scan, per method (log scales)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.2))
    for method, data in scan.items():
        data = [r for r in data if r["converged"]]
        s = [r["shift"] / cell for r in data]
        axes[0].semilogy(s, [max(abs(r["P"] / r["P_exact"] - 1), 1e-16) for r in data], "o-", label=method, ms=3)
        axes[1].semilogy(s, [max(r["pressure_error"], 1e-16) for r in data], "o-", label=method, ms=3)
    axes[0].set(xlabel="slid distance / lower cell", ylabel="|P / P_exact − 1|", title="normal force")
    axes[1].set(xlabel="slid distance / lower cell", ylabel="max |p_j / p − 1|", title="nodal pressures")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _rows(method: str, data: list[dict[str, Any]]) -> list[str]:
    """The Markdown rows of one method's states."""
    lines = []
    for r in data:
        if not r["converged"]:
            lines.append(f"| {method} | {r['shift']:.4f} | — | — | — | — | — | — | — | {r['wall_s']:.1f} |")
            continue
        cone = r["sum_t"] / r["F_sum_p"] - 1 if r["shift"] > 0 else float("nan")
        q = r["Q"] / r["F_sum_p"] - 1 if r["shift"] > 0 else float("nan")
        force = r["P"] / r["P_exact"] - 1
        lines.append(f"| {method} | {r['shift']:.4f} | {r['nodes']} / {r['slip']} | {force:+.2e} "
                     f"| {r['pressure_error']:.2e} | {r['pressure_spread']:.2e} | {cone:+.1e} | {q:+.1e} "
                     f"| {r['updates']} | {r['wall_s']:.1f} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    """The drag over 0.8 in whole lower cells (the patch test's states) and a scan of two lower cells in eighths
    (the footprint's edges between grid lines: the slave nodes over every relative position to the master facets,
    where node-to-surface's force oscillates), both methods; writes drag.md and drag.png."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/sliding")
    parser.add_argument("--n-lower", type=int, nargs=3, default=(40, 4, 2))
    parser.add_argument("--n-upper", type=int, nargs=3, default=(7, 3, 2))
    parser.add_argument("--substeps", type=int, default=8)
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("fenics_coulomb").setLevel(logging.WARNING)
    n_lower, n_upper = tuple(args.n_lower), tuple(args.n_upper)
    cell = LOWER[0] / n_lower[0]
    cells = round(0.8 / cell)
    methods = ("mortar", "node-to-surface")
    drag = {m: drag_patch(comm, m, cells, n_lower=n_lower, n_upper=n_upper, load_degree=12, record_failures=True)
            for m in methods}
    scan = {m: drag_patch(comm, m, 2, args.substeps, n_lower=n_lower, n_upper=n_upper, load_degree=12,
                          record_failures=True)[1:] for m in methods}
    if comm.rank != 0:
        return 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    _figure(scan, cell, out / "drag.png")
    header = ["| method | shift | closed / slip | P/P_exact − 1 | max abs p_j/p − 1 | (max − min p)/p "
              "| Σ abs t_j / (F Σ p_j) − 1 | abs Q/(F P) − 1 | updates | wall s |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    first = drag["mortar"][0]
    failures = [f"{m} at {r['shift']:.4f}: {r.get('message', 'not converged')}" for rows in (drag, scan)
                for m in methods for r in rows[m] if not r["converged"]]
    lines = [f"Written by `mpirun -n {comm.size} python3 benchmarks/sliding_drag.py` (the drag patch test of "
             "benchmarks/sliding_drag.py; the machine shared with other jobs, wall times indicative).", "",
             f"Lower block {n_lower[0]}×{n_lower[1]}×{n_lower[2]} cells (x cell {cell:g}), upper "
             f"{n_upper[0]}×{n_upper[1]}×{n_upper[2]} (×6 tetrahedra), F = {FRICTION}, exact p = "
             f"{first['p_exact']:.8f}, P = p·a·b = {first['P_exact']:.8f}; rtol {RTOL:g}.", "",
             "## The drag over 0.8 in whole cells (the patch test; shift 0 is the press)", "", *header]
    for method in methods:
        lines += _rows(method, drag[method])
    lines += ["", f"## Two cells in {args.substeps} substeps each (the footprint's edges between grid lines: the "
              "moving load's partly covered facets integrated by a degree-12 rule, mortar shows that floor)", "",
              *header]
    for method in methods:
        lines += _rows(method, scan[method])
    lines.append("")
    for title, rows in (("whole cells", drag), ("sub-cell scan", scan)):
        for method in methods:
            slid = [r for r in rows[method] if r["shift"] > 0 and r["converged"]]
            ps = np.array([r["P"] / r["P_exact"] - 1 for r in slid])
            lines.append(f"* {title}, {method}: over {len(slid)} slid states P/P_exact − 1 in [{ps.min():+.2e}, "
                         f"{ps.max():+.2e}] (oscillation {ps.max() - ps.min():.2e}), the largest nodal pressure "
                         f"error {max(r['pressure_error'] for r in slid):.2e}.")
    if failures:
        lines += ["", "States whose solve failed (the path went on from the last converged state):", ""]
        lines += [f"* {f}" for f in failures]
    (out / "drag.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
