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
# error taken over every step of a path, relative, in the 2-norm (docs/tradeoff's) and in the max-norm (ε's).
#
#     container/run python3 benchmarks/tradeoff_pairs.py [--out docs/tradeoff]
#
# Scenes: demos/scenes/two_bodies.toml, demos/scenes/slide_off.toml, the same two bodies with the block's top clamped
# too, and docs/verification/incline_two_bodies.toml on a 3× finer mesh (meshes/incline_on_slope.py 12 12 6 /
# 18 9 6) with the scene's defaults, all written into a temporary directory.

from __future__ import annotations

import argparse
import re
import tempfile
from pathlib import Path

import h5py
import numpy as np

from fenics_coulomb.cli import main

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


def solve(scene: Path, out: Path, pc: str, rtol: float) -> dict[str, np.ndarray]:
    status = main(["--scene", str(scene), "--sliding", "small", "--pc", pc, "--rtol", str(rtol), "--out", str(out),
                   "--quiet", "--no-plots"])
    if status != 0:
        raise SystemExit(f"{scene} --pc {pc} --rtol {rtol}: exit {status}")
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
                    u = solve(scene, work / f"{name}_{pc}_{rtol:g}", pc, rtol)
                    steps = [t for t in reference if np.abs(reference[t]).max() > 0]
                    two = max(np.linalg.norm(u[t] - reference[t]) / np.linalg.norm(reference[t]) for t in steps)
                    top = max(np.abs(u[t] - reference[t]).max() / np.abs(reference[t]).max() for t in steps)
                    rows.append((name, pc, rtol, two / rtol, top / rtol))
                    print(f"{name} {pc} {rtol:g}: error / rtol {two / rtol:.1f} (2-norm), {top / rtol:.1f} (max)",
                          flush=True)
    lines = ["| scene | pc | rtol | error / rtol, 2-norm | error / rtol, max-norm |", "|---|---|---|---|---|"]
    lines += [f"| {n} | {p} | {r:g} | {a:.1f} | {b:.1f} |" for n, p, r, a, b in rows]
    lines += ["", "| scene | largest 2-norm ratio (rtol ≤ 1e-6) | largest max-norm ratio (rtol ≤ 1e-6) "
              "| at rtol 1e-5 (2, max) |", "|---|---|---|---|"]
    for name in dict.fromkeys(r[0] for r in rows):
        mine = [r for r in rows if r[0] == name]
        tight = [r for r in mine if r[2] <= 1e-6]
        loose = [r for r in mine if r[2] > 1e-6]
        lines.append(f"| {name} | {max(r[3] for r in tight):.1f} | {max(r[4] for r in tight):.1f} | "
                     f"{max(r[3] for r in loose):.1f}, {max(r[4] for r in loose):.1f} |")
    Path(args.out).mkdir(parents=True, exist_ok=True)
    (Path(args.out) / "pairs-table.md").write_text("\n".join(lines) + "\n")
