"""Scaling over levels and MPI ranks: the contact solve against one linear-elastic solve, time and memory.

Every measurement launches the commands a user runs, as separate MPI jobs, from this (serial) driver:

* contact: ``mpirun -n R python3 -m fenics_coulomb --lev L --gap d3 --load L2 --no-plots --quiet --out DIR``
  (default settings), phases from its summary.json;
* linear (the reference): ``mpirun -n R python3 benchmarks/elastic.py --lev L --case d3/L2 --out DIR`` (CG + GAMG with
  the rigid-body near-nullspace, rtol 1e-8, assembly and output included), the same phases;

for each (level, ranks) the two run back to back, their order alternating from one configuration (and
repeat) to the next. Each rank runs under ``benchmarks/peak_rss.py``, which records the rank's peak RSS
from outside (getrusage of the waited-for child); rows give the sum, max and mean over ranks. The wall
time of the whole job (launcher, interpreter start, imports, JIT cache, solve, output) is measured here;
the load averages before and after every job are recorded, since other users' work inflates timings.

Studies (each writes ``<study>.csv``, ``<study>.md`` and ``<study>.png`` into ``--out``):

* ``levels``: every ``--levels`` (default 6-10; ``--lev11`` adds 11, about 12.5 GiB on 2 ranks) on ``--np`` ranks;
  run when ``--ranks`` is not given (or ``--levels`` is);
* ``strong``: ``--ranks 1 2 4 8 16`` at the fixed level ``--lev`` (default 10);
* ``weak``: ``--weak --ranks 1 2 4 8 16``: for each rank count the level whose unknowns per rank are
  closest to those of ``--weak-lev`` (default 7) on the first rank count (from the cuboid's unknown
  counts, fenics_coulomb.scenes.cuboid.expected_sizes); ``--strong`` runs both.

Nothing depends on the core count: ranks above the available cores are oversubscribed (Open MPI needs
``--map-by :OVERSUBSCRIBE`` then; it is added only in that case), and ``--launcher`` replaces
``mpirun -n {n}``, e.g. ``--launcher "srun -n {n}"`` inside a Slurm allocation or
``--launcher "mpirun --bind-to core -n {n}"``.

    container/run python3 benchmarks/scale.py --levels 6 7 8 9 --np 2 --out docs/scale
    container/run python3 benchmarks/scale.py --ranks 1 2 --lev 8 --out docs/scale
    container/run python3 benchmarks/scale.py --weak --ranks 1 2 --weak-lev 7 --out docs/scale
    python3 benchmarks/scale.py --ranks 1 2 4 8 16 --lev 10        # a 16-core machine
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
SOLVES = ("contact", "linear")
#: Phases reported for both solves (the contact CLI's summary.json and benchmarks/elastic.py).
PHASES = ("mesh", "assembly", "nested", "setup", "solve", "output")
DEFAULT_LEVELS = [6, 7, 8, 9, 10]
MiB = 1024.0


# -- pure helpers (imported by tests/cli/test_benchmark_scale.py) ---------------------------------------------

@dataclass
class Plan:
    """What one invocation measures: a list of (study, level, ranks) jobs."""

    case: str
    jobs: list[tuple[str, int, int]]


def weak_pairs(base_lev: int, ranks: Sequence[int], unknowns: Callable[[int], int],
               levels: Iterable[int] = range(0, 16)) -> list[tuple[int, int]]:
    """Level/rank pairs of about equal unknowns per rank.

    The target is ``unknowns(base_lev) / ranks[0]``; each rank count gets the level among ``levels`` whose
    unknowns per rank are closest to it on a logarithmic scale (the lower level on a tie).

    Returns:
        ``[(level, ranks), ...]`` in the order of ``ranks``.
    """
    if not ranks:
        raise ValueError("no rank counts")
    target = unknowns(base_lev) / ranks[0]
    candidates = sorted(set(levels))
    pairs = []
    for r in ranks:
        best = min(candidates, key=lambda lev: (abs(math.log(unknowns(lev) / r / target)), lev))
        pairs.append((best, r))
    return pairs


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n".join(__doc__.splitlines()[1:]))
    p.add_argument("--levels", type=int, nargs="+", default=None,
                   help=f"levels of the level study (default {' '.join(map(str, DEFAULT_LEVELS))})")
    p.add_argument("--lev11", action="store_true",
                   help="add lev 11 (4.6 M unknowns, ~12.5 GiB on 2 ranks) to the level study")
    p.add_argument("--np", type=int, default=2, help="ranks of the level study (default 2)")
    p.add_argument("--ranks", type=int, nargs="+", default=None,
                   help="rank counts of the strong (or, with --weak, weak) scaling study")
    p.add_argument("--lev", type=int, default=10, help="level of the strong scaling study (default 10)")
    p.add_argument("--weak", action="store_true", help="weak scaling over --ranks (default 1 2)")
    p.add_argument("--strong", action="store_true", help="with --weak: run the strong scaling study as well")
    p.add_argument("--weak-lev", type=int, default=7,
                   help="level on the first rank count that sets the unknowns per rank of --weak (default 7)")
    p.add_argument("--case", default="d3/L2", help="gap/load (default d3/L2)")
    p.add_argument("--repeat", type=int, default=1, help="runs of every configuration (default 1)")
    p.add_argument("--launcher", default="mpirun -n {n}",
                   help="MPI launcher with {n} for the ranks (default 'mpirun -n {n}'; e.g. 'srun -n {n}')")
    p.add_argument("--python", default="python3", help="interpreter the ranks run (default python3)")
    p.add_argument("--timeout", type=float, default=7200.0, help="seconds per job before it is killed")
    p.add_argument("--work", default=None, help="scratch directory for the jobs' outputs (default: a temporary one)")
    p.add_argument("--keep", action="store_true", help="keep the jobs' outputs (solution.h5 files can be large)")
    p.add_argument("--out", default="docs/scale", help="directory of the CSV, Markdown and plots (default docs/scale)")
    p.add_argument("--replot", nargs="+", metavar="STUDY", choices=("levels", "strong", "weak"),
                   help="only rewrite <study>.md and <study>.png from the CSV and JSON of an earlier run in --out "
                   "(both are rewritten after every job, so this also reports a run that was stopped)")
    return p


def make_plan(args: argparse.Namespace, unknowns: Callable[[int], int]) -> Plan:
    """The jobs of an invocation (raises ValueError on bad values)."""
    if args.repeat < 1:
        raise ValueError(f"--repeat {args.repeat}: must be >= 1")
    if args.np < 1 or (args.ranks and min(args.ranks) < 1):
        raise ValueError("rank counts must be >= 1")
    if "/" not in args.case:
        raise ValueError(f"--case {args.case!r}: expected gap/load, e.g. d3/L2")
    jobs: list[tuple[str, int, int]] = []
    if args.levels is not None or (args.ranks is None and not args.weak):
        levels = list(args.levels if args.levels is not None else DEFAULT_LEVELS)
        if args.lev11 and 11 not in levels:
            levels.append(11)
        jobs += [("levels", lev, args.np) for lev in levels]
    ranks = list(args.ranks) if args.ranks else None
    if ranks is not None and (not args.weak or args.strong):
        jobs += [("strong", args.lev, r) for r in ranks]
    if args.weak:
        jobs += [("weak", lev, r) for lev, r in weak_pairs(args.weak_lev, ranks or [1, 2], unknowns)]
    if any(lev < 0 for _, lev, _ in jobs):
        raise ValueError("levels must be >= 0")
    return Plan(case=args.case, jobs=jobs)


def launcher_command(template: str, n: int, cores: int, mpi_version: str) -> list[str]:
    """The launcher's argv for ``n`` ranks; Open MPI is allowed to oversubscribe only when n > cores."""
    argv = [token.replace("{n}", str(n)) for token in shlex.split(template)]
    if n > cores and argv and Path(argv[0]).name in ("mpirun", "mpiexec") and "Open MPI" in mpi_version:
        argv[1:1] = ["--map-by", ":OVERSUBSCRIBE"] if " 4." not in mpi_version else ["--oversubscribe"]
    return argv


def aggregate_rss(records: Sequence[dict[str, Any]]) -> dict[str, float]:
    """Sum, max and mean over ranks of the peak RSS (MiB) from peak_rss.py records, and max / mean."""
    values = [float(r["peak_rss_kib"]) / MiB for r in records]
    if not values:
        return {"rss_sum_MiB": float("nan"), "rss_max_MiB": float("nan"), "rss_mean_MiB": float("nan"),
                "rss_max_over_mean": float("nan"), "rss_ranks": 0}
    mean = sum(values) / len(values)
    return {"rss_sum_MiB": sum(values), "rss_max_MiB": max(values), "rss_mean_MiB": mean,
            "rss_max_over_mean": max(values) / mean if mean > 0 else float("nan"), "rss_ranks": len(values)}


def read_rss(directory: Path) -> list[dict[str, Any]]:
    """The per-rank records written by peak_rss.py, ordered by rank."""
    records = [json.loads(f.read_text()) for f in sorted(directory.glob("rss-*.json"))]
    return sorted(records, key=lambda r: (not str(r["rank"]).isdigit(), int(r["rank"]) if str(r["rank"]).isdigit()
                                          else 0, str(r["rank"])))


def phases(solve: str, summary: dict[str, Any]) -> dict[str, Any]:
    """Phase times and counts of a job from its summary.json.

    Contact (the CLI): mesh, assembly, nested = the coarse levels of nested iteration and the interpolation of
    their solution, setup = γ estimate + solver construction, solve = the Newton iterations (the GAMG hierarchy
    is built in the first one), output. Linear (elastic.py): mesh, assembly, setup = near-nullspace + GAMG
    hierarchy, solve = CG, output.
    """
    t = summary["timings_s"]
    if solve == "contact":
        values = {"mesh": t["mesh"], "assembly": t["assembly"], "nested": t.get("nested", 0.0),
                  "setup": t.get("gamma", 0.0) + t.get("setup", 0.0), "solve": t["total"], "output": t["output"]}
    elif solve == "linear":
        values = {key: t.get(key, 0.0) for key in PHASES}
    else:
        raise ValueError(f"unknown solve {solve!r}")
    row: dict[str, Any] = {f"{key}_s": float(values[key]) for key in PHASES}
    row["phases_s"] = sum(float(values[key]) for key in PHASES)
    row.update({"n": int(summary["n"]), "newton": int(summary.get("newton_iterations", 0)),
                "krylov": int(summary["krylov_iterations"]), "converged": bool(summary["converged"])})
    return row


def pair_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per configuration (study, lev, ranks, repeat) with both solves side by side and their ratios."""
    table: dict[tuple, dict[str, Any]] = {}
    for r in rows:
        key = (r["study"], r["lev"], r["ranks"], r["repeat"])
        entry = table.setdefault(key, {"study": r["study"], "lev": r["lev"], "ranks": r["ranks"], "repeat": r["repeat"],
                                       "n": r["n"], "n_per_rank": r["n"] // r["ranks"]})
        tag = "c" if r["solve"] == "contact" else "l"
        entry[f"{tag}_wall_s"] = r["wall_s"]
        entry[f"{tag}_solve_s"] = r["solve_s"]
        entry[f"{tag}_rss_sum_MiB"] = r["rss_sum_MiB"]
        entry[f"{tag}_rss_max_over_mean"] = r["rss_max_over_mean"]
        entry[f"{tag}_krylov"] = r["krylov"]
        if tag == "c":
            entry["c_newton"] = r["newton"]
            entry["c_converged"] = r["converged"]
        entry["load1"] = max(entry.get("load1", 0.0), r["load1_before"], r["load1_after"])
    out = []
    for entry in table.values():
        if "c_wall_s" in entry and "l_wall_s" in entry:
            entry["time_ratio"] = entry["c_wall_s"] / entry["l_wall_s"]
            entry["memory_ratio"] = entry["c_rss_sum_MiB"] / entry["l_rss_sum_MiB"]
        if "c_rss_sum_MiB" in entry and entry["n"] > 0:
            entry["c_KiB_per_unknown"] = entry["c_rss_sum_MiB"] * MiB / entry["n"]
        out.append(entry)
    return out


def efficiencies(paired: Sequence[dict[str, Any]], weak: bool) -> dict[tuple[str, int], float]:
    """Parallel efficiency per (solve tag, ranks) from the fastest repeat of every rank count.

    Strong: T(r0)·r0 / (T(r)·r). Weak: the time per unknown per rank relative to r0's,
    (T(r0)/m(r0)) / (T(r)/m(r)) with m the unknowns per rank (the pairs' m differ by up to ~40 %), i.e.
    T(r0)/T(r) for exactly equal m. r0 is the smallest rank count.
    """
    best: dict[tuple[str, int], float] = {}
    per_rank: dict[int, float] = {}
    for e in paired:
        per_rank[e["ranks"]] = e["n"] / e["ranks"]
        for tag in ("c", "l"):
            if f"{tag}_wall_s" in e:
                key = (tag, e["ranks"])
                best[key] = min(best.get(key, math.inf), e[f"{tag}_wall_s"])
    result = {}
    for tag in ("c", "l"):
        ranks = sorted(r for t, r in best if t == tag)
        if not ranks:
            continue
        r0 = ranks[0]
        for r in ranks:
            t0, t = best[(tag, r0)], best[(tag, r)]
            result[(tag, r)] = (t0 / per_rank[r0]) / (t / per_rank[r]) if weak else (t0 * r0) / (t * r)
    return result


def fmt(value: Any) -> str:
    """A table cell: floats with 3 significant digits (at least 2 decimals below 100), booleans as yes/no."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        if value != 0 and (abs(value) >= 1e5 or abs(value) < 1e-2):
            return f"{value:.3g}"
        return f"{value:.2f}" if abs(value) < 100 else f"{value:.0f}"
    return str(value)


def markdown_table(rows: Sequence[dict[str, Any]], columns: Sequence[tuple[str, str]]) -> list[str]:
    """Markdown lines of a table with (key, heading) columns; missing keys print as '–'."""
    lines = ["| " + " | ".join(h for _, h in columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        lines.append("| " + " | ".join(fmt(r[k]) if k in r else "–" for k, _ in columns) + " |")
    return lines


# -- the driver -------------------------------------------------------------------------------------------

def environment() -> dict[str, str]:
    """The jobs' environment: the repository on PYTHONPATH (a checkout need not be installed)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH", "")) if p)
    env.setdefault("MPLBACKEND", "Agg")
    return env


def unknowns_function(python: str) -> Callable[[int], int]:
    """n(lev) of the cuboid from fenics_coulomb.scenes.cuboid.expected_sizes, asked of a child interpreter.

    The driver does not import DOLFINx itself: that would initialize MPI in the process that launches the
    MPI jobs.
    """
    code = ("import json; from fenics_coulomb.scenes.cuboid import expected_sizes; "
            "print(json.dumps([expected_sizes(l)[1] for l in range(16)]))")
    table = json.loads(subprocess.run([python, "-c", code], check=True, capture_output=True, text=True,
                                      env=environment(), cwd=REPO).stdout)
    return lambda lev: int(table[lev])


def uptime() -> str:
    """``uptime``'s line (load averages over 1, 5, 15 min), or os.getloadavg() without it."""
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "load average: " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def run_job(solve: str, lev: int, ranks: int, case: str, work: Path, args: argparse.Namespace,
            mpi_version: str, cores: int, log: Any) -> dict[str, Any]:
    """Launch one job under peak_rss.py; return its row (phases, counts, wall time, RSS, load)."""
    gap, load = case.split("/")
    out = work / f"{solve}-lev{lev}-np{ranks}"
    rss = work / f"{solve}-lev{lev}-np{ranks}.rss"  # beside the result directory: the CLI writes only result sets
    for path in (out, rss):
        shutil.rmtree(path, ignore_errors=True)
    rss.mkdir(parents=True)
    if solve == "contact":
        command = [args.python, "-m", "fenics_coulomb", "--lev", str(lev), "--gap", gap, "--load", load,
                   "--no-plots", "--quiet", "--out", str(out)]
    else:
        command = [args.python, str(HERE / "elastic.py"), "--lev", str(lev), "--case", case, "--out", str(out)]
    argv = [*launcher_command(args.launcher, ranks, cores, mpi_version),
            args.python, str(HERE / "peak_rss.py"), str(rss), "--", *command]
    load_before = os.getloadavg()[0]
    print(f"$ {shlex.join(argv)}", file=log, flush=True)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=REPO, env=environment(), stdout=log, stderr=subprocess.STDOUT,
                          timeout=args.timeout)
    wall = time.perf_counter() - t0
    load_after = os.getloadavg()[0]
    row: dict[str, Any] = {"solve": solve, "lev": lev, "ranks": ranks, "returncode": proc.returncode,
                           "wall_s": wall}
    summary_file = out / "summary.json"
    if summary_file.exists():
        row.update(phases(solve, json.loads(summary_file.read_text())))
    else:
        row.update({f"{k}_s": float("nan") for k in PHASES})
        row.update({"phases_s": float("nan"), "n": 0, "newton": 0, "krylov": 0, "converged": False})
    row.update(aggregate_rss(read_rss(rss)))
    row.update({"load1_before": load_before, "load1_after": load_after})
    if not args.keep:
        shutil.rmtree(out, ignore_errors=True)
    return row


COLUMNS = ["study", "lev", "ranks", "repeat", "solve", "n", "n_per_rank", "wall_s", "phases_s",
           *[f"{k}_s" for k in PHASES], "newton", "krylov", "converged", "returncode", "rss_sum_MiB",
           "rss_max_MiB", "rss_mean_MiB", "rss_max_over_mean", "rss_ranks", "load1_before", "load1_after"]


def write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS, extrasaction="ignore")
        writer.writeheader()
        for r in rows:
            writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def read_csv(path: Path) -> list[dict[str, Any]]:
    """Rows of a CSV written by :func:`write_csv`, with numbers and booleans restored."""
    ints = {"lev", "ranks", "repeat", "n", "n_per_rank", "newton", "krylov", "returncode", "rss_ranks"}

    def convert(key: str, value: str) -> Any:
        if key in ints:
            return int(value)
        if key == "converged":
            return value == "True"
        if key in ("study", "solve"):
            return value
        return float(value)

    with open(path, newline="") as fh:
        return [{k: convert(k, v) for k, v in row.items()} for row in csv.DictReader(fh)]


def write_markdown(path: Path, study: str, rows: Sequence[dict[str, Any]], meta: dict[str, Any]) -> None:
    paired = pair_rows(rows)
    title = {"levels": f"Contact solve against one linear-elastic solve over levels, {meta['case']}",
             "strong": f"Strong scaling at lev {rows[0]['lev']}, {meta['case']}",
             "weak": f"Weak scaling (about equal unknowns per rank), {meta['case']}"}[study]
    lines = [f"# {title}", "",
             "Generated by `benchmarks/scale.py` (command below). *contact*: `python3 -m fenics_coulomb "
             "--no-plots --quiet` with the default settings; *linear*: one linear-elastic solve of the same "
             "mesh (CG + GAMG with the rigid-body near-nullspace, rtol 1e-8, assembly and output included, "
             "`benchmarks/elastic.py`). Both are whole MPI jobs launched one after the other (order "
             "alternating); *wall* is the job's wall time measured outside (launcher, interpreter start, "
             "imports, solve, output). Peak RSS is measured per rank from outside (`benchmarks/peak_rss.py`: "
             "getrusage of the rank's process) and summed over ranks; *max/mean* is the largest rank's peak "
             "over the mean (memory balance).", "",
             f"**Load:** the machine is shared; timings taken while others run are inflated. `uptime` before: "
             f"`{meta['uptime_before']}`; after: `{meta['uptime_after']}`. *load1* is the largest 1-minute "
             f"load average seen around the configuration's two jobs (the machine has {meta['cores']} cores "
             "available to this process).", "",
             f"Command: `{meta['command']}`  ", f"Machine: `{json.dumps(meta['machine'])}`", ""]
    if meta.get("note"):
        lines += [f"**Note:** {meta['note']}", ""]
    columns = [("lev", "lev"), ("ranks", "ranks"), ("n", "unknowns"), ("n_per_rank", "per rank"),
               ("c_wall_s", "contact wall s"), ("c_newton", "Newton"), ("c_krylov", "Krylov"),
               ("c_rss_sum_MiB", "contact RSS MiB"), ("c_rss_max_over_mean", "max/mean"),
               ("c_KiB_per_unknown", "KiB/unknown"),
               ("l_wall_s", "linear wall s"), ("l_krylov", "CG"), ("l_rss_sum_MiB", "linear RSS MiB"),
               ("l_rss_max_over_mean", "max/mean"), ("time_ratio", "time ratio"),
               ("memory_ratio", "memory ratio"), ("load1", "load1")]
    if meta["repeat"] > 1:
        columns.insert(2, ("repeat", "repeat"))
    if study in ("strong", "weak"):
        eff = efficiencies(paired, weak=study == "weak")
        for e in paired:
            e["c_eff"] = eff.get(("c", e["ranks"]), float("nan"))
            e["l_eff"] = eff.get(("l", e["ranks"]), float("nan"))
        columns += [("c_eff", "contact efficiency"), ("l_eff", "linear efficiency")]
        lines += ["Efficiency from the job wall times (fastest repeat), r0 the smallest rank count: " + (
            "(T(r0)/m(r0)) / (T(r)/m(r)) with m the unknowns per rank (time per unknown per rank; the "
            "pairs' m differ)." if study == "weak" else "T(r0)·r0 / (T(r)·r)."), ""]
    lines += markdown_table(paired, columns)
    lines += ["", "Phases (s, max over ranks; contact: nested = the coarse levels of nested iteration and the "
              "interpolation of their solution, setup = γ estimate + solver construction, solve = the "
              "Newton iterations including the GAMG setup in the first one; linear: setup = near-nullspace + "
              "GAMG setup, solve = CG):", ""]
    lines += markdown_table(rows, [("lev", "lev"), ("ranks", "ranks"), ("solve", "job"),
                                   *[(f"{k}_s", k) for k in PHASES], ("phases_s", "sum"), ("wall_s", "wall"),
                                   ("rss_max_MiB", "max rank RSS MiB"), ("rss_mean_MiB", "mean rank RSS MiB"),
                                   ("converged", "converged")])
    path.write_text("\n".join(lines) + "\n")


def plot(path: Path, study: str, rows: Sequence[dict[str, Any]], case: str) -> None:
    """Levels: time and memory against unknowns (log-log). Strong/weak: time, efficiency and memory against ranks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    paired = pair_rows(rows)
    best: dict[tuple[str, int, int], dict[str, Any]] = {}
    for e in paired:  # the fastest repeat of each configuration
        key = (e["study"], e["lev"], e["ranks"])
        if key not in best or e.get("c_wall_s", math.inf) < best[key].get("c_wall_s", math.inf):
            best[key] = e
    data = sorted(best.values(), key=lambda e: (e["ranks"], e["n"]))
    styles = {"c": ("contact solve", "o-", "C0"), "l": ("linear-elastic solve", "s--", "C1")}
    if study == "levels":
        fig, axes = plt.subplots(1, 2, figsize=(10, 4))
        x = [e["n"] for e in data]
        for tag, (label, style, color) in styles.items():
            axes[0].loglog(x, [e.get(f"{tag}_wall_s", math.nan) for e in data], style, color=color, label=label)
            axes[1].loglog(x, [e.get(f"{tag}_rss_sum_MiB", math.nan) / 1024 for e in data], style, color=color,
                           label=label)
        axes[0].set_ylabel("wall time of the job [s]")
        axes[1].set_ylabel("peak RSS summed over ranks [GiB]")
        for ax in axes:
            ax.set_xlabel("unknowns n")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend()
        fig.suptitle(f"{case} on {data[0]['ranks']} rank(s)")
    else:
        eff = efficiencies(paired, weak=study == "weak")
        fig, axes = plt.subplots(1, 3, figsize=(14, 4))
        ranks = [e["ranks"] for e in data]
        for tag, (label, style, color) in styles.items():
            times = [e.get(f"{tag}_wall_s", math.nan) for e in data]
            axes[0].loglog(ranks, times, style, color=color, label=label)
            if study == "strong" and times:
                axes[0].loglog(ranks, [times[0] * ranks[0] / r for r in ranks], ":", color=color,
                               label=f"ideal ({label.split()[0]})")
            axes[1].semilogx(ranks, [eff.get((tag, r), math.nan) for r in ranks], style, color=color, label=label)
            axes[2].loglog(ranks, [e.get(f"{tag}_rss_sum_MiB", math.nan) / 1024 for e in data], style, color=color,
                           label=label)
        axes[0].set_ylabel("wall time of the job [s]")
        axes[1].set_ylabel("parallel efficiency")
        axes[1].set_ylim(0, 1.2)
        axes[2].set_ylabel("peak RSS summed over ranks [GiB]")
        for ax in axes:
            ax.set_xlabel("MPI ranks")
            ax.set_xticks(ranks, [str(r) for r in ranks])
            ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
        if study == "strong":
            fig.suptitle(f"Strong scaling, {case}, lev {data[0]['lev']} ({data[0]['n']} unknowns)")
        else:
            fig.suptitle(f"Weak scaling, {case}: " + ", ".join(f"lev {e['lev']} on {e['ranks']}" for e in data))
    for ax in axes:  # readable log axes: ticks at 1, 2, 5 × 10^k labelled as plain numbers
        for axis, scale_name in ((ax.yaxis, ax.get_yscale()), (ax.xaxis, ax.get_xscale() if study == "levels" else "")):
            if scale_name == "log":
                axis.set_major_locator(matplotlib.ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
                axis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
                axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def machine() -> dict[str, Any]:
    info: dict[str, Any] = {"machine": platform.machine(), "cores_available": len(os.sched_getaffinity(0)),
                            "cores_online": os.cpu_count()}
    try:
        with open("/proc/cpuinfo") as fh:
            info["cpu"] = next(line.split(":", 1)[1].strip() for line in fh if line.startswith("model name"))
        with open("/proc/meminfo") as fh:
            kib = int(next(line.split()[1] for line in fh if line.startswith("MemTotal")))
            info["memory_GiB"] = round(kib / MiB**2, 1)
    except (OSError, StopIteration):
        pass
    return info


def report(out: Path, study: str, rows: Sequence[dict[str, Any]], meta: dict[str, Any]) -> None:
    """Write <study>.csv, .json (the run's metadata), .md and .png."""
    write_csv(out / f"{study}.csv", rows)
    (out / f"{study}.json").write_text(json.dumps(meta, indent=2) + "\n")
    write_markdown(out / f"{study}.md", study, rows, meta)
    plot(out / f"{study}.png", study, rows, meta["case"])


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    out = Path(args.out)
    if args.replot:
        for study in args.replot:
            meta = json.loads((out / f"{study}.json").read_text())
            report(out, study, read_csv(out / f"{study}.csv"), meta)
        return 0
    unknowns = unknowns_function(args.python)
    try:
        plan = make_plan(args, unknowns)
    except ValueError as err:
        parser.error(str(err))
    cores = len(os.sched_getaffinity(0))
    launcher0 = shlex.split(args.launcher)[0]
    try:
        mpi_version = subprocess.run([launcher0, "--version"], capture_output=True, text=True).stdout
    except OSError:
        parser.error(f"--launcher: {launcher0!r} not found")
    out.mkdir(parents=True, exist_ok=True)
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="fenics-coulomb-scale-"))
    work.mkdir(parents=True, exist_ok=True)
    meta = {"case": plan.case, "cores": cores, "repeat": args.repeat, "machine": machine(),
            "command": "python3 benchmarks/scale.py " + shlex.join(sys.argv[1:] if argv is None else argv),
            "uptime_before": uptime()}
    print(f"{len(plan.jobs)} configuration(s) x {args.repeat} x 2 jobs; {cores} cores; {meta['uptime_before']}",
          flush=True)
    rows: list[dict[str, Any]] = []
    with open(out / "scale.log", "a") as log:
        index = 0
        for repeat in range(args.repeat):
            for study, lev, ranks in plan.jobs:
                order = SOLVES if index % 2 == 0 else SOLVES[::-1]
                index += 1
                for solve in order:
                    row = {"study": study, "repeat": repeat,
                           **run_job(solve, lev, ranks, plan.case, work, args, mpi_version, cores, log)}
                    row["n_per_rank"] = row["n"] // ranks
                    rows.append(row)
                    # keep what is measured if a long run is stopped: --replot writes the tables from it
                    meta["uptime_after"] = uptime() + " (run incomplete)"
                    write_csv(out / f"{study}.csv", [r for r in rows if r["study"] == study])
                    (out / f"{study}.json").write_text(json.dumps(meta, indent=2) + "\n")
                    print(f"{study} lev {lev} on {ranks}: {solve} {row['wall_s']:.1f} s, "
                          f"{row['newton']}/{row['krylov']} its, {row['rss_sum_MiB']:.0f} MiB, "
                          f"rc {row['returncode']}, load {row['load1_after']:.2f}", flush=True)
    meta["uptime_after"] = uptime()
    if not args.work and not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    for study in dict.fromkeys(s for s, _, _ in plan.jobs):
        report(out, study, [r for r in rows if r["study"] == study], meta)
    print(f"results in {out}/", flush=True)
    return 0 if all(r["returncode"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
