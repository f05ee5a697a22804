# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Two elastic bodies in frictional contact: a block pressed onto a larger block, then sheared
#
# A small aluminium block rests on a larger steel block. The large block's bottom is clamped; the small
# block's top is moved, first down (it is pressed onto the large block), then sideways in a few steps (it is
# sheared). Both bodies deform, their meshes do not match at the interface, and friction (F = 0.3) decides
# which part of the interface sticks and which slips.
#
# ```
# python3 demos/two_bodies.py --out out/two_bodies
# mpirun -n 2 python3 demos/two_bodies.py --out out/two_bodies
# ```
#
# `out/two_bodies/solution.xdmf` is a time series, one grid per load step with every field, on ONE mesh
# holding both bodies: open it in ParaView, apply *Warp By Vector* with `displacement`, colour by `body`,
# `contact_state` (on the slave surface), `contact_traction` or `master_reaction` (on the master surface)
# and step through the times. `summary.json` holds per step the force on each body, the contact states and
# the physics checks.
#
# ## The physics
#
# The bodies are disconnected parts of one mesh, with one vector Q1 space and one stiffness matrix; each has
# its own material through a subdomain integral over its cells. A **contact pair** names the slave surface S
# (the small block's bottom) and the master surface M (the large block's top). Once, in the reference
# configuration, the pair is discretized by **dual mortar** (the default, `fenics_coulomb/model/pairs/segmentation.py`):
# each slave facet is clipped against the master facets on an auxiliary plane, and with the dual
# (biorthogonal) basis ψ_j of the slave surface the mortar integrals give, per slave node j, the diagonal
# D_j = ∫ ψ_j N_j, the master weights M_jl = ∫ ψ_j N_l^m, the gap g_j = ∫ ψ_j g / D_j and the frame (t₁, t₂, n) of
# the slave nodal normal. With φ_jl = M_jl / D_j and the relative displacement
#
#     w_j = u_j − Σ_l φ_jl u_l
#
# the contact conditions of each slave node are those of a node against a rigid obstacle with u_j replaced
# by w_j: the gap g + n·w_j ≥ 0, the normal force λ ≥ 0, λ (g + n·w_j) = 0, and Coulomb's law on the slip
# T w_j (on a load path on its increment T(w_{j,k} − w_{j,k−1})). The slave node's force f_j acts on the
# slave body; the master nodes carry the reaction f_l = −Σ_j φ_jl f_j, so the two bodies feel equal and
# opposite forces, and a uniform pressure is transmitted exactly (the patch test, docs/two-bodies/patch.md).
# (`ContactPair(..., method="node-to-surface")` pairs each slave node with its closest master point instead:
# φ_jl are then the master shape functions there.)
#
# ## The change of variables
#
# Let Φ hold the slave-row, master-column blocks φ_jl I₃ and u = M z with M = I + Φ. No slave node is a
# node of a master facet (Φ² = 0), so M⁻¹ = I − Φ and z = u − Φ u: z equals u except on the slave nodes,
# where it is w_s. In z the potential energy reads ½ zᵀ(Mᵀ A M) z − ⟨Mᵀ l, z⟩ and the contact conditions act
# on single 3-blocks of z, so the problem is the one-body generalized equation of the reference paper
# (Remark 6.2) with Ã = Mᵀ A M (a PETSc PtAP) and load Mᵀ l: the SCD semismooth* Newton solver runs on it
# unchanged. The result reports u = M z (`displacement`), z (`relative_displacement`), f_s
# (`contact_force`) and f_j (`master_force`). Both bodies must be held against rigid motion by their own
# boundary conditions (here the clamped bottom and the prescribed top), so the problem is well posed
# without relying on contact.

# %%
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import ufl

from fenics_coulomb import CONTACT_STATES, ContactPair, ContactProblem, XDMFTimeSeries, contact_functions

from meshes.two_blocks import BODIES, TAGS, two_blocks  # noqa: E402

#: (E in GPa, ν) per body: a steel base and an aluminium block.
MATERIALS = {"lower": (210.0, 0.3), "upper": (70.0, 0.35)}
PHYSICS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction",
           "reaction_balance")

# %% [markdown]
# ## The two blocks
#
# The large block is [0, 1] × [0, 1] × [−0.5, 0], the small one [0.25, 0.75]² × [0, 0.25], resting on it (gap
# 0), both meshed with hexahedra of different sizes (`meshes/two_blocks.py` builds them as one DOLFINx mesh
# with cell tags per body and facet tags `lower_top`, `upper_bottom`, `lower_bottom`, `upper_top`, ...).
# Materials per body enter through subdomain integrals dx(body).


# %%
def lame(E: float, nu: float) -> tuple[float, float]:
    """(μ, λ) of an isotropic material."""
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def elasticity(V: dolfinx.fem.FunctionSpace, cell_tags: dolfinx.mesh.MeshTags,
               materials: dict[str, tuple[float, float]] = MATERIALS) -> ufl.Form:
    """The bilinear form of linear elasticity, body by body (dx(1) the lower, dx(2) the upper block)."""
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    dx = ufl.Measure("dx", domain=V.mesh, subdomain_data=cell_tags)

    def eps(w: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        return ufl.sym(ufl.grad(w))

    forms = []
    for body, (E, nu) in materials.items():
        mu, lmbda = lame(E, nu)
        sigma = 2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3)
        forms.append(ufl.inner(sigma, eps(v)) * dx(BODIES[body]))
    return sum(forms[1:], forms[0])


# %% [markdown]
# ## Boundary conditions and the contact pair
#
# The large block's bottom is clamped; the small block's whole top follows a prescribed displacement (a
# `dolfinx.fem.Constant`, changed between the load steps). The pair: slave = the small block's bottom,
# master = the large block's top (the finer mesh as the slave is the usual choice of node-to-surface
# contact).


# %%
def boundary_conditions(V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags,
                        top: dolfinx.fem.Constant) -> list[dolfinx.fem.DirichletBC]:
    fdim = V.mesh.topology.dim - 1
    bottom = dolfinx.fem.locate_dofs_topological(V, fdim, facet_tags.find(TAGS["lower_bottom"]))
    upper = dolfinx.fem.locate_dofs_topological(V, fdim, facet_tags.find(TAGS["upper_top"]))
    return [dolfinx.fem.dirichletbc(np.zeros(3), bottom, V), dolfinx.fem.dirichletbc(top, upper, V)]


# %% [markdown]
# ## The load path
#
# Step 1 presses the small block down by `press`; the next steps move its top sideways (x1) to the `shears`,
# keeping the press. Each `solve()` is one step: friction acts on the increment of the relative slip, and
# the step starts from the previous one. After each step the force on each body is the sum of its own
# residual K u − l over its contact nodes (slave nodes, and the master nodes of the facets they use): the two
# are equal and opposite. Every step is one grid of the XDMF time series.


# %%
def run(out: Path, n_lower: Sequence[int] = (8, 8, 4), n_upper: Sequence[int] = (7, 7, 3), press: float = 0.002,
        shears: Sequence[float] = (0.0005, 0.001, 0.0015, 0.002), friction: float = 0.3,
        comm: MPI.Comm = MPI.COMM_WORLD, settings: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Press, then shear; write ``solution.xdmf`` (one grid per step) and ``summary.json`` into ``out``.

    Returns:
        Per step: the top's displacement, the contact states, the physics checks and the pair forces.
    """
    blocks = two_blocks(comm, lower=(1.0, 1.0, 0.5), n_lower=n_lower, upper_origin=(0.25, 0.25),
                        upper=(0.5, 0.5, 0.25), n_upper=n_upper, gap=0.0)
    V = dolfinx.fem.functionspace(blocks.mesh, ("Lagrange", 1, (3,)))
    top = dolfinx.fem.Constant(blocks.mesh, np.array([0.0, 0.0, -press]))
    bcs = boundary_conditions(V, blocks.facet_tags, top)
    pair = ContactPair(blocks.facet_tags, slave=TAGS["upper_bottom"], master=TAGS["lower_top"], friction=friction)
    steps: list[dict[str, Any]] = []
    with ContactProblem(elasticity(V, blocks.cell_tags), None, bcs, contact_pairs=[pair],
                        settings=settings or {"rtol": 1e-10}, petsc_options_prefix="two_bodies_") as problem:
        with XDMFTimeSeries(out / "solution.xdmf", blocks.mesh) as xdmf:
            for k, shear in enumerate([0.0, *shears]):
                top.value[:] = (shear, 0.0, -press)
                _, result = problem.solve()
                checks = problem.checks(result)
                forces = problem.report(result).pair_forces
                xdmf.write(float(k + 1), contact_functions(problem, result),  # with `body`, 1 and 2
                           dtypes={"contact_state": np.int32, "body": np.int32},
                           information={"step": str(k + 1), "converged": str(result.converged).lower(),
                                        "contact_state": ", ".join(f"{c} {v}" for c, v in CONTACT_STATES.items())})
                steps.append({"step": k + 1, "top_displacement": [shear, 0.0, -press], "converged": result.converged,
                              "newton_iterations": result.iterations, "state_counts": result.counts,
                              "checks": {key: checks[key] for key in PHYSICS}, "pairs": forces})
                if comm.rank == 0:
                    f_s, f_m = forces[0]["force_on_slave_body"], forces[0]["force_on_master_body"]
                    print(f"step {k + 1}: top u = ({shear:.4f}, 0, {-press:.4f}), {result.iterations} Newton "
                          f"iterations, open/stick/slip {result.counts['open']}/{result.counts['stick']}/"
                          f"{result.counts['slip']}; force on the small block "
                          f"({f_s[0]:+.5f}, {f_s[1]:+.5f}, {f_s[2]:+.5f}), on the large block "
                          f"({f_m[0]:+.5f}, {f_m[1]:+.5f}, {f_m[2]:+.5f}), |sum|/|force| "
                          f"{forces[0]['balance']:.1e}", flush=True)
        data = {**result.summary(comm), "demo": "two_bodies", "materials": MATERIALS, "friction": friction,
                "steps": steps}
        if comm.rank == 0:
            (out / "summary.json").write_text(json.dumps(data, indent=2) + "\n")
        comm.barrier()
    return steps


# %%
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="A block pressed onto a larger block, then sheared")
    parser.add_argument("--n-lower", type=int, nargs=3, default=[8, 8, 4], help="cells of the large block")
    parser.add_argument("--n-upper", type=int, nargs=3, default=[7, 7, 3], help="cells of the small block")
    parser.add_argument("--press", type=float, default=0.002)
    parser.add_argument("--shear", type=float, default=0.002, help="the last step's sideways displacement")
    parser.add_argument("--steps", type=int, default=4, help="shear steps")
    parser.add_argument("--friction", type=float, default=0.3)
    parser.add_argument("--out", default="out/two_bodies")
    args = parser.parse_args(argv)
    out = Path(args.out)
    if MPI.COMM_WORLD.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    shears = [args.shear * (k + 1) / args.steps for k in range(args.steps)]
    steps = run(out, args.n_lower, args.n_upper, args.press, shears, args.friction)
    if MPI.COMM_WORLD.rank == 0:
        print(f"results in {out}/ (solution.xdmf: {len(steps)} steps; summary.json)")
        print(json.dumps(steps[-1]["pairs"][0], indent=1))
    return 0 if all(s["converged"] for s in steps) else 3


if __name__ == "__main__":
    sys.exit(main())
