# ---
# jupytext:
#   text_representation:
#     extension: .py
#     format_name: light
# ---

# # The slide-off blocks flush with the lower block's end, under friction
#
# `benchmarks/slide_matrix.py`'s blocks (coarse: 10 × 5 × 3 / 7 × 4 × 3) with the upper block at x1 ∈ [x0, x0 + 1]:
# flush with the lower block's ends (x0 = 0, 1), just inside and beyond them (0.995, 1.005) and in the middle (0.5),
# F = 0.3 and 0.8, pressed 0.01 and slid 0 or 0.1 in one static solve, finite sliding at rtol 1e-8 and 1e-10, both
# methods, tetrahedra and hexahedra: 160 solves. Where the slave's edge meets the master's, the contact geometry has no
# fixed point (docs/sliding/README.md, "Every cycle at a master edge"); each solve must converge, and the flush ends
# of the hexahedral meshes, which mirror each other, must give mirror-image forces.
#
#     container/run python3 benchmarks/flush_sweep.py --out docs/sliding   # flush.md, about 2 minutes
#
# Each row: the number of geometry updates, the contact nodes and the pair force on the slave body (normal,
# tangential x1), or the first words of the failure (exit 3 from the command line).

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from benchmarks.slide_matrix import Blocks
from fenics_coulomb.errors import SolverError

CELLS, METHODS = ("tetrahedron", "hexahedron"), ("node-to-surface", "mortar")
POSITIONS, FRICTIONS, RTOLS, SHIFTS = (0.0, 1.0, 0.995, 1.005, 0.5), (0.3, 0.8), (1e-8, 1e-10), (0.0, 0.1)


def solve(comm: MPI.Comm, cell: str, method: str, x0: float, friction: float, rtol: float, shift: float) -> dict:
    """One solve of the sweep (collective)."""
    blocks = Blocks(comm, cell, (10, 5, 3), (7, 4, 3), x0, method, "flush_sweep_", friction=friction, rtol=rtol)
    try:
        with blocks.problem:
            run = blocks.solve(shift)
        return {"ok": True, "updates": run["updates"], "nodes": len(run["nodes"]), "force": run["force"]}
    except SolverError as err:
        return {"ok": False, "message": str(err)[:90]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("docs/sliding"))
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    logging.disable(logging.WARNING)  # the edge's master-penetration warnings, one per solve
    t0 = time.perf_counter()
    lines = ["| cell | method | x0 | F | rtol | slide | updates | contact nodes | normal force [GPa·L²] "
             "| tangential x1 [GPa·L²] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    results = {}
    for cell in CELLS:
        for method in METHODS:
            for x0 in POSITIONS:
                for friction in FRICTIONS:
                    for rtol in RTOLS:
                        for shift in SHIFTS:
                            key = (cell, method, x0, friction, rtol, shift)
                            r = results[key] = solve(comm, *key)
                            lines.append(f"| {cell} | {method} | {x0:g} | {friction:g} | {rtol:g} | {shift:g} | " + (
                                f"{r['updates']} | {r['nodes']} | {r['force'][2]:.9f} | {r['force'][0]:.9f} |"
                                if r["ok"] else f"failed: {r['message']} | | | |"))
    failed = sum(not r["ok"] for r in results.values())
    mirror = []
    for method in METHODS:
        for friction in FRICTIONS:
            for rtol in RTOLS:
                a, b = (results[("hexahedron", method, x0, friction, rtol, 0.0)] for x0 in (1.0, 0.0))
                if a["ok"] and b["ok"]:
                    off = np.abs(a["force"] - b["force"] * np.array([-1.0, 1.0, 1.0])).max()
                    off /= np.linalg.norm(a["force"])
                    mirror.append(f"| {method} | {friction:g} | {rtol:g} | {off:.1e} |")
    wall = time.perf_counter() - t0
    if comm.rank == 0:
        text = ["# Flush and near-flush ends under friction (benchmarks/flush_sweep.py)", "",
                f"{len(results)} solves on {comm.size} rank(s), {failed} failed, {wall:.0f} s wall. The pair force on "
                "the slave body (E in GPa, lengths in L).", "",
                "Hexahedral flush ends x0 = 1 against x0 = 0 (mirror images): the largest component difference of "
                "the mirrored pair forces over the force's norm.", "",
                "| method | F | rtol | mirror difference |", "|---|---|---|---|", *mirror, "", *lines, ""]
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / ("flush.md" if comm.size == 1 else f"flush-{comm.size}-ranks.md")).write_text("\n".join(text))
        print(f"{failed} of {len(results)} failed; {wall:.0f} s")


if __name__ == "__main__":
    main()
