# ---
# jupytext:
#   text_representation:
#     extension: .py
#     format_name: light
# ---

# # Finite sliding on 1, 2 and 3 ranks: the same answer, and the same bits on a rerun
#
# The slide-off path of demos/scenes/slide_off.toml (pressed, slid 0.8 off the lower block's edge in 4 substeps,
# held) with finite sliding, as the real command (`mpirun --oversubscribe -n R python3 -m fenics_coulomb --scene
# ...`, run from outside the repository, rtol 1e-13): dual mortar and node-to-surface, frictionless and with F = 0.3
# (the drag). After the slide the master facets beneath a slave node may live on another rank than the node:
# the pairing must find them. Per variant: once on 1 rank, twice on 2 and twice on 3 ranks;
#
# * 1 vs 2 vs 3 ranks: every step's displacement, matched by vertex coordinates, relative to the largest |u| of the
#   path, and every step's pair normal force and contact node count (path.csv);
# * a rerun on the same ranks: solution.h5 byte for byte, and path.csv without its wall-time column.
#
# Writes docs/sliding/ranks.md.
#
#     container/run python3 benchmarks/sliding_ranks.py [--out docs/sliding]

from __future__ import annotations

import argparse
import csv
import filecmp
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "demos" / "scenes" / "slide_off.toml"
#: (name, pair method, friction)
VARIANTS = [("mortar, F = 0", "mortar", 0.0), ("node-to-surface, F = 0", "node-to-surface", 0.0),
            ("mortar, F = 0.3", "mortar", 0.3), ("node-to-surface, F = 0.3", "node-to-surface", 0.3)]
#: The runs of each variant: (ranks, repeat).
RUNS = [(1, 0), (2, 0), (2, 1), (3, 0), (3, 1)]
RTOL = "1e-13"


def scene_text(method: str, friction: float) -> str:
    """The slide-off scene with the mesh's absolute path, the pair's method and friction."""
    text = SCENE.read_text().replace('mesh = "../../meshes/slide_off.msh"',
                                     f'mesh = "{(ROOT / "meshes" / "slide_off.msh").as_posix()}"')
    text = text.replace("friction = 0.0", f"friction = {friction!r}").replace('method = "mortar"',
                                                                            f'method = "{method}"')
    assert f'method = "{method}"' in text and f"friction = {friction!r}" in text
    return text


def run(scene: Path, ranks: int, out: Path) -> float:
    """The command on ``ranks`` ranks; its wall time."""
    cmd = ["mpirun", "--oversubscribe", "-n", str(ranks), sys.executable, "-m", "fenics_coulomb", "--scene",
           str(scene), "--rtol", RTOL, "--out", str(out), "--no-plots", "--quiet"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=out.parent, capture_output=True, text=True, timeout=1800)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {proc.returncode}\n{proc.stdout}\n{proc.stderr}")
    return time.perf_counter() - t0


def displacements(path: Path) -> tuple[np.ndarray, list[np.ndarray]]:
    """(vertex coordinates, every step's displacement) of solution.h5, in the lexicographic vertex order."""
    with h5py.File(path, "r") as f:
        x = f["Mesh/mesh/geometry"][...]
        steps = sorted(f["Function/displacement"], key=float)
        values = [f[f"Function/displacement/{s}"][...] for s in steps]
    order = np.lexsort(np.round(x, 10).T[::-1])
    return x[order], [v[order] for v in values]


def path_rows(path: Path) -> list[dict[str, str]]:
    """path.csv without the wall-time column."""
    with open(path, newline="") as f:
        return [{k: v for k, v in row.items() if k != "wall_time_s"} for row in csv.DictReader(f)]


def measure(work: Path, name: str, method: str, friction: float) -> dict[str, object]:
    """Every run of one variant, compared."""
    scene = work / f"{method}_{friction}.toml"
    scene.write_text(scene_text(method, friction))
    outs, walls = {}, {}
    for ranks, repeat in RUNS:
        out = work / f"{method}_{friction}_{ranks}_{repeat}"
        walls[(ranks, repeat)] = run(scene, ranks, out)
        outs[(ranks, repeat)] = out
    x1, u1 = displacements(outs[(1, 0)] / "solution.h5")
    rows1 = path_rows(outs[(1, 0)] / "path.csv")
    scale = max(float(np.abs(u).max()) for u in u1)
    force_key = next(k for k in rows1[0] if k.startswith("normal_force_pair"))
    nodes_key = next(k for k in rows1[0] if k.startswith("contact_nodes_pair"))
    result: dict[str, object] = {"name": name, "steps": len(u1), "scale": scale,
                                 "updates": [int(r["geometry_updates"]) for r in rows1],
                                 "nodes": [int(r[nodes_key]) for r in rows1]}
    for ranks in (2, 3):
        x, u = displacements(outs[(ranks, 0)] / "solution.h5")
        rows = path_rows(outs[(ranks, 0)] / "path.csv")
        assert np.allclose(x, x1, rtol=0, atol=1e-12) and len(u) == len(u1)
        result[f"u_{ranks}"] = max(float(np.abs(a - b).max()) for a, b in zip(u, u1, strict=True)) / scale
        result[f"force_{ranks}"] = max(abs(float(a[force_key]) - float(b[force_key])) / abs(float(b[force_key]))
                                       for a, b in zip(rows, rows1, strict=True))
        result[f"nodes_{ranks}"] = [int(r[nodes_key]) for r in rows] == result["nodes"]
        result[f"updates_{ranks}"] = [int(r["geometry_updates"]) for r in rows]
        result[f"rerun_{ranks}"] = (filecmp.cmp(outs[(ranks, 0)] / "solution.h5", outs[(ranks, 1)] / "solution.h5",
                                                shallow=False)
                                    and rows == path_rows(outs[(ranks, 1)] / "path.csv"))
    result["wall"] = {f"{r}.{k}": round(w, 1) for (r, k), w in walls.items()}
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "sliding")
    args = parser.parse_args()
    load_before = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="sliding-ranks-") as tmp:
        results = []
        for name, method, friction in VARIANTS:
            results.append(measure(Path(tmp), name, method, friction))
            print(f"{name}: done", flush=True)  # noqa: T201 (a benchmark's progress line)
    load_after = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    lines = ["# Finite sliding on 1, 2 and 3 ranks", "",
             "`container/run python3 benchmarks/sliding_ranks.py` (its docstring says what is compared): the slide-off "
             "path of demos/scenes/slide_off.toml, finite sliding, as the real command at rtol 1e-13, once on 1 rank, "
             "twice on 2 and twice on 3 ranks (oversubscribed on the 2-core machine). u: the largest difference of any "
             "step's displacement from 1 rank's, over the path's largest |u|; P: the largest relative difference of a "
             "step's pair normal force; nodes: every step's contact node count equal; rerun: solution.h5 byte for byte "
             "and path.csv (wall times aside) equal on the same ranks.",
             "", f"Load before: `{load_before}`; after: `{load_after}`; {time.perf_counter() - t0:.0f} s in all.", "",
             "| variant | steps | contact nodes per step (1 rank) | geometry updates per step (1 / 2 / 3 ranks) | "
             "u 2 vs 1 | u 3 vs 1 | P 2 vs 1 | P 3 vs 1 | nodes equal 2, 3 | rerun identical 2, 3 | wall s |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        updates = " / ".join(",".join(map(str, u)) for u in (r["updates"], r["updates_2"], r["updates_3"]))
        lines.append(f"| {r['name']} | {r['steps']} | {','.join(map(str, r['nodes']))} | {updates} | "
                     f"{r['u_2']:.1e} | {r['u_3']:.1e} | {r['force_2']:.1e} | {r['force_3']:.1e} | "
                     f"{r['nodes_2']}, {r['nodes_3']} | {r['rerun_2']}, {r['rerun_3']} | "
                     f"{', '.join(f'{k}: {v}' for k, v in r['wall'].items())} |")  # type: ignore[union-attr]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "ranks.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
