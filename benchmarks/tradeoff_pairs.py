# ---
# jupytext:
#   text_representation:
#     extension: .py
#     format_name: light
# ---

# # The solver's displacement error per rtol on contact pairs
#
# docs/tradeoff measured the solver's relative displacement error on the paper's cuboid (one body) at most 3.9 rtol
# (2-norm), from which `--accuracy EPS` maps to rtol = EPS / ERROR_PER_RTOL (8) and finite sliding's geometry
# tolerance is ε = 8 rtol ‖u‖∞. This measures the same ratio on two-body scenes, with small sliding so that only the
# SCD solve is measured: every scene with `--pc gamg|ilu|hypre` at rtol 1e-5 … 1e-9 against LU at rtol 1e-12, the
# error taken over every step of a path, relative, in the 2-norm (docs/tradeoff's) and in the max-norm (ε's); and, at
# the same residual rule, `--accuracy EPS` with EPS = 8 rtol, which also asks the last Newton correction to be below
# EPS (fenics_coulomb/scd/stopping.py): its error against EPS, and what it costs in Newton and Krylov iterations.
#
#     container/run python3 benchmarks/tradeoff_pairs.py [--out docs/tradeoff]
#
# Scenes: demos/scenes/two_bodies.toml, demos/scenes/slide_off.toml, the same two bodies with the block's top clamped
# too, and docs/verification/incline_two_bodies.toml on a 3× finer mesh (meshes/incline_on_slope.py 12 12 6 /
# 18 9 6) with the scene's defaults, all written into a temporary directory.

from __future__ import annotations

import argparse
import csv
import json
import re
import tempfile
from pathlib import Path

import h5py
import numpy as np

from fenics_coulomb.cli import main
from fenics_coulomb.settings import ERROR_PER_RTOL

ROOT = Path(__file__).resolve().parents[1]
PCS = ("gamg", "ilu", "hypre")
RTOLS = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9)


def scenes(work: Path) -> dict[str, Path]:
    """The scene files (the derived ones written into ``work``)."""
    from meshes import incline_on_slope

    demos = ROOT / "demos" / "scenes"
    two = (demos / "two_bodies.toml").read_text().replace("../../meshes/", f"{ROOT}/meshes/")
    (work / "clamped_top.toml").write_text(re.sub(r"clamped = \[[^\]]*\]", 'clamped = ["block_bottom", "block_top"]',
                                                  two))
    mesh = work / "incline_3x.msh"
    incline_on_slope.build(mesh, (12, 12, 6), (18, 9, 6), 0.1)
    text = (ROOT / "docs" / "verification" / "incline_two_bodies.toml").read_text()
    text = re.sub(r'mesh = ".*"', f'mesh = "{mesh}"', text)
    (work / "incline_3x.toml").write_text(re.sub(r"\[contact\]\n[^\[]*|\[solver\]\n[^\[]*", "", text))
    return {"two_bodies": demos / "two_bodies.toml", "slide_off": demos / "slide_off.toml",
            "clamped_top": work / "clamped_top.toml", "incline_3x": work / "incline_3x.toml"}


def displacements(out: Path) -> dict[str, np.ndarray]:
    with h5py.File(out / "solution.h5", "r") as h5:
        group = h5["Function/displacement"]
        return {t: group[t][:] for t in group}


def iterations(out: Path) -> tuple[int, int]:
    """Newton and Krylov iterations over every solve of the run (a path's rows summed)."""
    if (out / "path.csv").exists():
        with open(out / "path.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        return sum(int(r["newton_iterations"]) for r in rows), sum(int(r["krylov_iterations"]) for r in rows)
    summary = json.loads((out / "summary.json").read_text())
    return int(summary["newton_iterations"]), int(summary["krylov_iterations"])


def solve(scene: Path, out: Path, pc: str, rtol: float, option: str = "--rtol") -> dict[str, np.ndarray]:
    status = main(["--scene", str(scene), "--sliding", "small", "--pc", pc, option, str(rtol), "--out", str(out),
                   "--quiet", "--no-plots"])
    if status != 0:
        raise SystemExit(f"{scene} --pc {pc} {option} {rtol}: exit {status}")
    return displacements(out)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(ROOT / "docs" / "tradeoff"))
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name, scene in scenes(work).items():
            reference = solve(scene, work / f"{name}_lu", "lu", 1e-12)
            for pc in PCS:
                for rtol in RTOLS:
                    steps = [t for t in reference if np.abs(reference[t]).max() > 0]
                    u = solve(scene, work / f"{name}_{pc}_{rtol:g}", pc, rtol)
                    two = max(np.linalg.norm(u[t] - reference[t]) / np.linalg.norm(reference[t]) for t in steps)
                    top = max(np.abs(u[t] - reference[t]).max() / np.abs(reference[t]).max() for t in steps)
                    # the same residual rule with --accuracy EPS = ERROR_PER_RTOL·rtol: also the Newton correction
                    eps = ERROR_PER_RTOL * rtol
                    v = solve(scene, work / f"{name}_{pc}_{rtol:g}_accuracy", pc, eps, "--accuracy")
                    met = max(np.linalg.norm(v[t] - reference[t]) / np.linalg.norm(reference[t]) for t in steps)
                    counts = (*iterations(work / f"{name}_{pc}_{rtol:g}"),
                              *iterations(work / f"{name}_{pc}_{rtol:g}_accuracy"))
                    rows.append((name, pc, rtol, two / rtol, top / rtol, two / eps, met / eps, *counts))
                    print(f"{name} {pc} {rtol:g}: error / rtol {two / rtol:.1f} (2-norm), {top / rtol:.1f} (max); "
                          f"--accuracy {eps:g}: error / EPS {met / eps:.3f} (rtol alone {two / eps:.2f}), "
                          f"Newton / Krylov {counts[0]} / {counts[1]} -> {counts[2]} / {counts[3]}", flush=True)
    lines = ["| scene | pc | rtol | error / rtol, 2-norm | error / rtol, max-norm | EPS = 8 rtol: error / EPS, "
             "rtol alone → --accuracy EPS | Newton / Krylov, rtol alone → --accuracy EPS |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {n} | {p} | {r:g} | {a:.1f} | {b:.1f} | {c:.2f} → {d:.3f} | {e} / {f} → {g} / {h} |"
              for n, p, r, a, b, c, d, e, f, g, h in rows]
    lines += ["", "| scene | largest 2-norm ratio (rtol ≤ 1e-6) | largest max-norm ratio (rtol ≤ 1e-6) "
              "| at rtol 1e-5 (2, max) | largest error / EPS, rtol = EPS/8 alone → --accuracy EPS | Newton, "
              "Krylov: --accuracy / rtol alone |", "|---|---|---|---|---|---|"]
    for name in dict.fromkeys(r[0] for r in rows):
        mine = [r for r in rows if r[0] == name]
        tight = [r for r in mine if r[2] <= 1e-6]
        loose = [r for r in mine if r[2] > 1e-6]
        lines.append(f"| {name} | {max(r[3] for r in tight):.1f} | {max(r[4] for r in tight):.1f} | "
                     f"{max(r[3] for r in loose):.1f}, {max(r[4] for r in loose):.1f} | "
                     f"{max(r[5] for r in mine):.2f} → {max(r[6] for r in mine):.3f} | "
                     f"{sum(r[9] for r in mine) / max(sum(r[7] for r in mine), 1):.2f}, "
                     f"{sum(r[10] for r in mine) / max(sum(r[8] for r in mine), 1):.2f} |")
    Path(args.out).mkdir(parents=True, exist_ok=True)
    (Path(args.out) / "pairs-table.md").write_text("\n".join(lines) + "\n")
