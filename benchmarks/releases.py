"""Two releases, back to back on one machine: the paper's cuboid solved by each, whole command, time and memory.

Machines here differ by 2x in speed and other users' work inflates timings, so a release is only ever compared
with another one measured on the same machine in the same minutes. For each level (default 8 and 10, case
d3/L2, default settings) and repeat, this driver runs the user's command

    mpirun -n R python3 -m fenics_coulomb --lev L --gap d3 --load L2 --no-plots --quiet --out DIR

from a checkout of each commit (``git worktree add --detach``, removed afterwards), the two commits
alternating and their order swapping from one repeat to the next (ABBA...), every rank under
``benchmarks/peak_rss.py``. A row holds the whole job's wall time, the phases from summary.json, the Newton
and Krylov iterations, the peak RSS summed over the ranks and the load averages around the job; the
table gives, per level, the median over the repeats of each commit and the ratio head / base.

    python3 benchmarks/releases.py --base 5761472 --head HEAD --levels 8 10 --repeats 2   # git and MPI here

Inside container/run (no git there), make the checkouts on the host first:

    git worktree add --detach /tmp/base 5761472 && git worktree add --detach /tmp/head HEAD
    container/run python3 benchmarks/releases.py --base-tree /tmp/base --head-tree /tmp/head --levels 8 10 \\
        --repeats 2 --out docs/scale/releases
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.scale import aggregate_rss, launcher_command, machine, phases, read_rss, uptime

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
COLUMNS = ["lev", "repeat", "release", "commit", "n", "wall_s", "mesh_s", "assembly_s", "setup_s", "solve_s",
           "output_s", "newton", "krylov", "final_residual", "converged", "returncode", "rss_sum_MiB",
           "load1_before", "load1_after"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", default="5761472", help="the earlier release (a commit)")
    parser.add_argument("--head", default="HEAD", help="the release measured against it (a commit)")
    parser.add_argument("--levels", type=int, nargs="+", default=[8, 10])
    parser.add_argument("--np", type=int, default=2, help="MPI ranks")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--launcher", default="mpirun -n {n}")
    parser.add_argument("--python", default=sys.executable)
    parser.add_argument("--timeout", type=float, default=1800.0)
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "scale" / "releases")
    parser.add_argument("--base-tree", type=Path, help="a checkout of the base made beforehand (where git is not "
                        "available, e.g. inside container/run: `git worktree add --detach DIR COMMIT` on the host)")
    parser.add_argument("--head-tree", type=Path, help="a checkout of the head made beforehand")
    parser.add_argument("--head-args", default="", help="extra options of the head's command, e.g. '--rtol 2e-7' "
                        "to compare the two at the same accuracy (the table's column 'final |y|' shows it)")
    return parser


def tree_commit(tree: Path) -> str:
    """The commit checked out in the worktree ``tree`` (read from its git files: no git needed)."""
    dot_git = tree / ".git"
    gitdir = Path(dot_git.read_text().split(":", 1)[1].strip()) if dot_git.is_file() else dot_git
    head = (gitdir / "HEAD").read_text().strip()
    if head.startswith("ref:"):
        ref = head.split(None, 1)[1]
        common = gitdir / "commondir"
        root = (gitdir / common.read_text().strip()).resolve() if common.exists() else gitdir
        for where in (gitdir / ref, root / ref):
            if where.exists():
                return where.read_text().strip()
        return ref
    return head


def resolve(commit: str) -> str:
    """The full hash of ``commit`` in this repository."""
    return subprocess.run(["git", "rev-parse", "--verify", f"{commit}^{{commit}}"], cwd=REPO, check=True,
                          capture_output=True, text=True).stdout.strip()


def checkout(commit: str, parent: Path) -> Path:
    """A detached worktree of ``commit`` under ``parent``."""
    path = parent / commit[:12]
    subprocess.run(["git", "worktree", "add", "--detach", str(path), commit], cwd=REPO, check=True,
                   capture_output=True)
    return path


def run_job(tree: Path, lev: int, args: argparse.Namespace, mpi_version: str, work: Path, log: Any,
            extra: list[str] | None = None) -> dict[str, Any]:
    """The cuboid at ``lev`` solved by the checkout ``tree`` (``extra``: more options of the command); its row."""
    out, rss = work / "out", work / "rss"
    for path in (out, rss):
        shutil.rmtree(path, ignore_errors=True)
    rss.mkdir(parents=True)
    command = [args.python, "-m", "fenics_coulomb", "--lev", str(lev), "--gap", "d3", "--load", "L2",
               "--no-plots", "--quiet", "--out", str(out), *(extra or [])]
    argv = [*launcher_command(args.launcher, args.np, len(os.sched_getaffinity(0)), mpi_version),
            args.python, str(HERE / "peak_rss.py"), str(rss), "--", *command]
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=tree, env=env, stdout=log, stderr=subprocess.STDOUT, timeout=args.timeout)
    row: dict[str, Any] = {"lev": lev, "wall_s": time.perf_counter() - t0, "returncode": proc.returncode,
                           "load1_before": load_before, "load1_after": os.getloadavg()[0]}
    summary = out / "summary.json"
    if summary.exists():
        data = json.loads(summary.read_text())
        row.update(phases("contact", data))
        # The residual norm the solve ended at (the same scale in both releases): the accuracy delivered.
        row["final_residual"] = float(data["residual_history"][-1])
    row.update(aggregate_rss(read_rss(rss)))
    return row


def table(rows: list[dict[str, Any]], base: str, head: str) -> list[str]:
    """Per level: the median of each release's repeats and head / base."""
    lines = ["| lev | n | release | wall s | assembly s | solve s | Newton | Krylov | final \\|y\\| | RSS sum MiB |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for lev in sorted({r["lev"] for r in rows}):
        medians = {}
        for release in ("base", "head"):
            mine = [r for r in rows if r["lev"] == lev and r["release"] == release]
            medians[release] = {k: statistics.median(float(r.get(k, float("nan"))) for r in mine)
                                for k in ("wall_s", "assembly_s", "solve_s", "newton", "krylov", "final_residual",
                                          "rss_sum_MiB")}
            m, n = medians[release], mine[0].get("n", 0) if mine else 0
            commit = base if release == "base" else head
            lines.append(f"| {lev} | {n} | {release} {commit[:7]} | {m['wall_s']:.1f} | {m['assembly_s']:.1f} | "
                         f"{m['solve_s']:.1f} | {m['newton']:.0f} | {m['krylov']:.0f} | {m['final_residual']:.2e} | "
                         f"{m['rss_sum_MiB']:.0f} |")
        b, h = medians["base"], medians["head"]
        lines.append(f"| {lev} | | head / base | {h['wall_s'] / b['wall_s']:.3f} | "
                     f"{h['assembly_s'] / b['assembly_s']:.3f} | {h['solve_s'] / b['solve_s']:.3f} | "
                     f"{h['newton'] / b['newton']:.2f} | {h['krylov'] / b['krylov']:.2f} | "
                     f"{h['final_residual'] / b['final_residual']:.2f} | {h['rss_sum_MiB'] / b['rss_sum_MiB']:.3f} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    given = args.base_tree is not None and args.head_tree is not None
    base = tree_commit(args.base_tree) if given else resolve(args.base)
    head = tree_commit(args.head_tree) if given else resolve(args.head)
    mpi_version = subprocess.run([args.python, "-c", "from mpi4py import MPI; print(MPI.Get_library_version())"],
                                 capture_output=True, text=True).stdout
    args.out.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    started = uptime()
    with tempfile.TemporaryDirectory(prefix="releases-") as tmp, open(args.out / "releases.log", "w") as log:
        parent = Path(tmp)
        trees = ({"base": args.base_tree.resolve(), "head": args.head_tree.resolve()} if given
                 else {"base": checkout(base, parent), "head": checkout(head, parent)})
        try:
            for lev in args.levels:
                for repeat in range(args.repeats):
                    order = ("base", "head") if repeat % 2 == 0 else ("head", "base")
                    for release in order:
                        extra = args.head_args.split() if release == "head" else []
                        row = run_job(trees[release], lev, args, mpi_version, parent / "work", log, extra)
                        row.update({"repeat": repeat, "release": release,
                                    "commit": base if release == "base" else head})
                        rows.append(row)
                        print(f"lev {lev} repeat {repeat} {release}: {row['wall_s']:.1f} s, "
                              f"{row.get('newton', '?')} Newton / {row.get('krylov', '?')} Krylov, load "
                              f"{row['load1_before']:.2f} -> {row['load1_after']:.2f}", flush=True)
        finally:
            for tree in trees.values() if not given else ():
                subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=REPO, capture_output=True)
    with open(args.out / "releases.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    meta = {"base": base, "head": head, "head_args": args.head_args, "ranks": args.np, "levels": args.levels,
            "repeats": args.repeats,
            "machine": machine(), "uptime_before": started, "uptime_after": uptime()}
    (args.out / "releases.json").write_text(json.dumps(meta, indent=2) + "\n")
    text = [f"# Release against release: base {base[:7]}, head {head[:7]}", "",
            f"The paper's cuboid (d3/L2, default settings) on {args.np} ranks, whole command "
            f"(`python3 -m fenics_coulomb --lev L --gap d3 --load L2 --no-plots`"
            f"{'; the head with ' + repr(args.head_args) if args.head_args else ''}), the two commits alternating "
            f"(ABBA), {args.repeats} repeat(s) each, medians; written by `benchmarks/releases.py`. Load before: "
            f"{started}; after: {meta['uptime_after']}. Machine: {meta['machine']}.", "", *table(rows, base, head), ""]
    (args.out / "README.md").write_text("\n".join(text))
    return 0 if all(r["returncode"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
