"""Repeatability: the same command run several times on the same ranks; iteration counts and output digests.

    container/run python3 benchmarks/repeatability.py --runs 3 --label after --out docs/partition
    container/run python3 benchmarks/repeatability.py --runs 3 --label before --source /path/to/old/checkout

Runs ``mpirun -n R python3 -m fenics_coulomb ... --no-plots --quiet`` (oversubscribed) for each case,
``--runs`` times, with ``--source`` (a checkout of fenics-coulomb) first on PYTHONPATH, and records per run
the Newton/Krylov counts and SHA-256 digests of the residual history (summary.json) and of the displacement
array in solution.h5. Appends to repeatability.csv and rewrites repeatability.md in ``--out``.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent

#: (name, ranks, CLI arguments)
CASES = [
    ("lev 5 d2/L1 rtol 1e-12", 3, ["--lev", "5", "--gap", "d2", "--load", "L1", "--rtol", "1e-12"]),
    ("lev 6 d3/L2", 2, ["--lev", "6", "--gap", "d3", "--load", "L2"]),
    ("lev 5 d3/L2 pc gamg", 3, ["--lev", "5", "--gap", "d3", "--load", "L2", "--pc", "gamg"]),
    ("roller.toml", 2, ["--scene", str(ROOT / "demos" / "scenes" / "roller.toml")]),
]


def displacement(path: Path) -> np.ndarray:
    """The displacement point data of solution.h5 (the first dataset whose path names it)."""
    found: list[str] = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: found.append(name)
                     if isinstance(obj, h5py.Dataset) and "displacement" in name.lower() else None)
        return np.asarray(f[sorted(found)[0]][...])


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:12]


def run(case: list[str], ranks: int, source: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=f"{source}:{os.environ.get('PYTHONPATH', '')}")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = ["mpirun", "--oversubscribe", "-n", str(ranks), sys.executable, "-m", "fenics_coulomb", *case,
               "--out", tmp, "--no-plots", "--quiet"]
        subprocess.run(cmd, env=env, check=True, capture_output=True, cwd=tmp)
        summary = json.loads((Path(tmp) / "summary.json").read_text())
        u = displacement(Path(tmp) / "solution.h5")
    return {"newton": summary["newton_iterations"], "krylov": summary["krylov_iterations"],
            "history": digest(np.asarray(summary["residual_history"]).tobytes()),
            "displacement": digest(u.tobytes())}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--label", default="after")
    parser.add_argument("--source", type=Path, default=ROOT, help="fenics-coulomb checkout to run")
    parser.add_argument("--cases", type=int, nargs="*", help="indices into CASES (default all)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "partition")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    table = args.out / "repeatability.csv"
    keys = ["label", "case", "ranks", "run", "newton", "krylov", "history", "displacement"]
    rows = list(csv.DictReader(table.open())) if table.exists() else []
    chosen = [name for i, (name, _, _) in enumerate(CASES) if not args.cases or i in args.cases]
    rows = [r for r in rows if r["label"] != args.label or r["case"] not in chosen]
    for i, (name, ranks, case) in enumerate(CASES):
        if args.cases and i not in args.cases:
            continue
        for k in range(args.runs):
            row = {"label": args.label, "case": name, "ranks": ranks, "run": k + 1,
                   **run(case, ranks, args.source.resolve())}
            print(row, flush=True)
            rows.append(row)
    with table.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    lines = ["# Repeatability: the same command on the same ranks, run after run", "",
             "Newton / Krylov counts and SHA-256 prefixes of the residual history (summary.json) and of the",
             "displacement array (solution.h5). `before`: DOLFINx's default partitioner (PT-Scotch);",
             "`after`: fenics_coulomb.scenes.partition (recursive coordinate bisection).", "",
             "| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    (args.out / "repeatability.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
