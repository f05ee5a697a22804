"""The Hertz sub-surface shear and the peak contact pressure from the output fields: a rigid sphere pressed into
a block (benchmarks/hertz_quarter.py: the quarter model on symmetry rollers, a structured core of edge h₀ under
the contact, W = 1000 a, frictionless, ν = 0.3, a/R = 0.005), the projected stress
(:func:`fenics_coulomb.io.fields.stress_functions`, the ``stress`` field of solution.xdmf) and its largest
shear τ = (σ₁ − σ₃)/2 at the vertices on the axis under the contact (an edge of the quarter: sampled exactly,
h₀ apart), against Hertz: τ_max = 0.310 p₀ at the depth 0.481 a (Johnson eq. 4.23), with p₀ and a from the
computed force; and the largest ``contact_pressure`` of solution.xdmf against p₀::

    mpirun -n 2 python3 benchmarks/hertz_stress.py 1      # a level of benchmarks/hertz_quarter.py (0 … 3)

Measured (one rank, the machine shared, load 7–8):

| level | h₀ | unknowns | peak contact_pressure | axis τ_max | at depth (vertex of the parabola) |
|---|---|---|---|---|---|
| 0 | a/16 (core 1.2 a, growth 0.15) | 37 407 | +1.55 % | 0.3083 p₀ (−0.56 %) | 0.439 a (0.450 a) |
| 1 | a/12 | 53 661 | +2.01 % | 0.3060 p₀ (−1.30 %) | 0.415 a (0.441 a) |
| 2 | a/17 | 97 275 | +1.39 % | 0.3084 p₀ (−0.53 %) | 0.460 a (0.454 a) |
| 3 | a/24 | 196 880 | +1.00 % | 0.3094 p₀ (−0.18 %) | 0.457 a (0.462 a) |

(level 3 on 2 ranks, 127 s: docs/verification §2's table; summary.json's global max_shear is the axis's).
The earlier full block of benchmarks/hertz.py (unstructured tetrahedra of edge h₀ within 1.2 a) gave a peak
contact_pressure +12 %, +6.5 %, +4.6 % over p₀ at h₀ = a/4, a/8, a/11.3 (the scatter of nodal pressures on
unstructured cells) and τ_max 0.285/0.300/0.303 p₀ at 0.62/0.39/0.41 a; the structured core under the contact
removes the scatter. The sampled maximum of τ sits 0.5–0.8 h₀ above 0.481 a (the lumped projection averages
each vertex's cells, ±h₀ in depth, and Hertz's τ(z) is flat at its maximum)."""

from __future__ import annotations

import sys
from pathlib import Path

from mpi4py import MPI

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.hertz_quarter import indent_quarter  # noqa: E402

__all__ = ["main", "sub_surface_shear"]


def sub_surface_shear(level: int, comm: MPI.Comm = MPI.COMM_WORLD, out: str | None = None) -> dict[str, float]:
    """Solve the quarter indentation at ``level`` and return p₀, a, the peak contact pressure over p₀ (and the
    XDMF's when ``out`` is given) and the axis's largest shear τ/p₀ with its depth/a (the same on every rank)."""
    r = indent_quarter(comm, level, out=out)
    return {"h0_over_a": r["h_over_a"], "unknowns": r["unknowns"], "p0": r["pressure_ref"], "a": r["radius_ref"],
            "peak_pressure_over_p0": r["peak_pressure"] / r["pressure_ref"],
            "xdmf_peak_over_p0": r["xdmf_peak"] / r["pressure_ref"],
            "axis_shear_over_p0": r["axis_tau"], "depth_over_a": r["axis_depth"],
            "vertex_depth_over_a": r["vertex_depth"], "wall_s": r["wall"]}


def main(argv: list[str] | None = None) -> int:
    """``hertz_stress.py [LEVEL [OUT]]``: print the numbers of one level on rank 0 (OUT: also write the result
    set there)."""
    args = sys.argv[1:] if argv is None else argv
    numbers = sub_surface_shear(int(args[0]) if args else 1, out=args[1] if len(args) > 1 else None)
    if MPI.COMM_WORLD.rank == 0:
        print(", ".join(f"{k} {v:.4g}" for k, v in numbers.items()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
