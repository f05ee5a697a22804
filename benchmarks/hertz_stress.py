"""The Hertz sub-surface shear from the stress output: a rigid sphere pressed into a block (benchmarks/hertz.py's
indentation, frictionless, ν = 0.3), the projected stress (:func:`fenics_coulomb.io.fields.stress_functions`)
and its largest shear τ = (σ₁ − σ₃)/2 on the axis under the contact, against Hertz: τ_max ≈ 0.31 p₀ at the
depth ≈ 0.48 a, with p₀ and a from the computed force (``hertz_from_force``)::

    mpirun -n 2 python3 benchmarks/hertz_stress.py 1      # mesh level 0, 1 or 2 of benchmarks/hertz.py

Measured on 2 ranks (the axis samples are the vertices within 0.3 h₀ of the axis, so the depth is resolved to
about one edge h₀): level 0 (h₀ = a/4): 0.285 p₀ at 0.62 a; level 1 (h₀ = a/8, 73 k unknowns, < 1 min):
0.300 p₀ at 0.39 a; level 2 (h₀ = a/11.3, 200 k unknowns, ~5 min under load): 0.303 p₀ (−2.3 %) at 0.41 a
(0.8 h₀ above 0.48 a); summary.json's global max_shear is 0.285, 0.302, 0.305 p₀ in the same place. The
nodal peak ``contact_pressure`` on these linear tetrahedra is +12 %, +6.5 %, +4.6 % above p₀."""

from __future__ import annotations

import importlib.util
import logging
import sys
from pathlib import Path

from mpi4py import MPI

import dolfinx
import numpy as np

from fenics_coulomb import ContactProblem, Sphere
from fenics_coulomb.io.fields import contact_statistics, stress_from_form, stress_functions, stress_statistics

__all__ = ["main", "sub_surface_shear"]

logger = logging.getLogger("hertz_stress")


def _demo():  # noqa: ANN202 - the demo module
    spec = importlib.util.spec_from_file_location("hertz", Path(__file__).resolve().parent / "hertz.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["hertz"] = module
    spec.loader.exec_module(module)
    return module


def sub_surface_shear(level: int, comm: MPI.Comm = MPI.COMM_WORLD) -> dict[str, float]:
    """Solve the indentation at ``level`` and return p₀, a, the peak contact pressure and the axis's largest shear
    τ/p₀ with its depth/a (the same on every rank)."""
    H = _demo()  # noqa: N806
    a = np.sqrt(H.R_INDENTER * H.DEPTH)
    h, growth = H.LEVELS[level][0] * a, H.LEVELS[level][1]
    msh, tags = H.block_mesh(comm, h, a, growth=growth)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, tags.find(H.BOTTOM)), V)
    sphere = Sphere(center=[0.0, 0.0, H.R_INDENTER], radius=H.R_INDENTER, displacement=[0.0, 0.0, -H.DEPTH],
                    name="indenter")
    with ContactProblem(H.elasticity(V), None, bcs=[bc], contact=(tags, [H.TOP]), friction=0.0, obstacles=[sphere],
                        settings=H.SETTINGS, petsc_options_prefix="hertz_stress_") as problem:
        uh, result = problem.solve()
        contact = contact_statistics(problem.model, result)
        stress = stress_statistics(problem.model, result)
        sigma, mises = stress_functions(stress_from_form(problem.model.a_ufl, uh), msh)
    hertz = H.hertz_from_force(H.R_INDENTER, -contact["obstacles"]["indenter"]["force"][2])
    owned = mises.function_space.dofmap.index_map.size_local
    x = mises.function_space.tabulate_dof_coordinates()[:owned]
    principal = np.linalg.eigvalsh(sigma.x.array[: 9 * owned].reshape(-1, 3, 3))
    tau = 0.5 * (principal[:, -1] - principal[:, 0])
    axis = np.hypot(x[:, 0], x[:, 1]) < 0.3 * h + 1e-12
    depth = np.concatenate(comm.allgather(-x[axis, 2]))
    tau = np.concatenate(comm.allgather(tau[axis]))
    k = int(np.argmax(tau))
    return {"h0_over_a": h / a, "p0": hertz["pressure"], "a": hertz["radius"],
            "peak_pressure_over_p0": contact["peak_pressure"] / hertz["pressure"],
            "axis_shear_over_p0": float(tau[k] / hertz["pressure"]), "depth_over_a": float(depth[k] / hertz["radius"]),
            "max_shear_over_p0": stress["max_shear"] / hertz["pressure"]}


def main(argv: list[str] | None = None) -> int:
    """``hertz_stress.py [LEVEL]``: print the numbers of one level on rank 0."""
    args = sys.argv[1:] if argv is None else argv
    numbers = sub_surface_shear(int(args[0]) if args else 1)
    if MPI.COMM_WORLD.rank == 0:
        print(", ".join(f"{k} {v:.4g}" for k, v in numbers.items()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
