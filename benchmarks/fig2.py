"""Fig. 2 of the paper: the contact states of the six Section 7 cases (open blue, slip yellow, stick red).

    container/run mpirun -n 2 python3 benchmarks/fig2.py --lev 6 --out docs/fig2
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np
from common import CASES, run_case

from fenics_coulomb.io.figures import STATE_COLOURS, gather_contact
from fenics_coulomb.settings import SolverSettings


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lev", type=int, default=6)
    parser.add_argument("--out", default="docs/fig2")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    panels = []
    for gap, load in CASES:
        run = run_case(comm, args.lev, gap, load, SolverSettings(rtol=1e-12))
        gathered = gather_contact(comm, run.model.contact.coordinates, run.result.states)
        counts = run.result.state_counts(comm)
        panels.append((f"{gap}/{load}", gathered, counts))
        run.destroy()
    if comm.rank != 0:
        return 0
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 2, figsize=(11, 9))
    for ax, (label, (x, states), counts) in zip(axes.ravel(), panels, strict=True):
        size = float(np.clip(12000.0 / states.size, 2.0, 40.0))
        for state, (name, colour) in STATE_COLOURS.items():
            mask = states == state
            ax.scatter(x[mask, 0], x[mask, 1], s=size, c=colour, marker="s", edgecolors="none", label=name)
        ax.set_title(f"{label}: open/stick/slip {counts['open']}/{counts['stick']}/{counts['slip']}", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xticks([0, 0.5, 1, 1.5, 2])
        ax.set_yticks([0, 0.5, 1])
    axes[0, 0].legend(loc="lower left", fontsize=7, ncol=3)
    fig.suptitle(f"Contact states of the six cases, lev {args.lev} (blue open, yellow slip, red stick)")
    fig.tight_layout()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "fig2.png", dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
