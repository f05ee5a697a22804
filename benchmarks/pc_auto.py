"""Robustness of the preconditioners behind ``pc = auto``: ILU against GAMG on hexahedral and tetrahedral bodies.

Every run is the user's command, ``python3 -m fenics_coulomb --scene FILE --no-plots`` under ``mpirun -n R``
(a subprocess), and the numbers are read back from its summary.json and convergence.csv:

* hexahedra: the paper's cuboid (case d3/L2) at the levels ``--levels``;
* tetrahedra: the hemisphere pressed on the plane (meshes/hemisphere.py, clamped apex disc, top face pressed
  with 1 GPa, F = 0.3) and the half-cylinder roller (meshes/roller.py, demos/scenes/roller.toml's loads),
  each meshed by gmsh here at the sizes ``--hemisphere-sizes`` / ``--roller-sizes``;

for every Poisson ratio of ``--poisson``, preconditioner of ``--pcs`` and rank count of ``--ranks`` (rank
counts above the machine's cores run oversubscribed, and the table says so). Recorded per run: unknowns,
Newton and Krylov iterations, the largest Krylov count of one Newton step, how many linear solves hit the
KSP iteration limit (SolverSettings.ksp_max_it), the exit code and reason, the solver's and the process's
wall time and the load average of the machine around the run (it is shared: iteration counts are the
robust quantity, times are indicative). Rows are appended to ``pc-auto.csv`` as they come (``--resume``
skips the rows already there), then ``pc-auto.md`` and ``pc-auto.png`` are written, with the decision of
:func:`fenics_coulomb.scd.newton.choose_preconditioner` checked against every measured group.

    container/run python3 benchmarks/pc_auto.py --out docs/pc-auto
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

from fenics_coulomb.scd.preconditioner import choose_preconditioner  # noqa: E402
from fenics_coulomb.settings import SolverSettings  # noqa: E402

FIELDS = ["body", "cells", "size", "n", "poisson", "pc", "ranks", "oversubscribed", "exit", "reason", "newton",
          "krylov", "max_krylov", "ksp_limit_hits", "solve_s", "process_s", "load_before", "load_after"]

HEMISPHERE_SCENE = """\
# Hemisphere (meshes/hemisphere.py) pressed on the plane: apex disc clamped, flat top pressed down.
[body]
name = "hemisphere"
shape = "mesh"
mesh = "{mesh}"
clamped = ["apex"]
contact = ["bottom"]
[boundaries]
top = 1
bottom = 2
apex = 3
[material]
young = 70.0
poisson = {poisson}
[friction]
coefficient = 0.3
[tractions]
top = [0.0, 0.0, -1.0]
"""

ROLLER_SCENE = """\
# Half-cylinder roller (meshes/roller.py) as demos/scenes/roller.toml, at another mesh size.
[body]
name = "roller"
shape = "mesh"
mesh = "{mesh}"
clamped = ["left"]
contact = ["bottom"]
[boundaries]
left = 1
right = 2
top = 3
bottom = 4
[material]
young = 70.0
poisson = {poisson}
[friction]
coefficient = 0.3
[tractions]
top = [0.0, 0.0, -0.5]
right = [0.0, -0.1, 0.0]
[solver]
start = "undeformed"
"""


def make_mesh(kind: str, size: float, work: Path) -> Path:
    """Mesh ``kind`` (hemisphere or roller) at ``size`` in ``work`` with gmsh (once)."""
    path = work / f"{kind}_{size:g}.msh"
    if not path.exists():
        if kind == "hemisphere":
            from meshes import hemisphere

            hemisphere.build(size, path)
        else:
            from meshes import roller

            roller.build(size, path)
    return path


def cell_count(path: Path) -> int:
    import gmsh

    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.merge(str(path))
    count = sum(len(tags) for dim, tag in gmsh.model.getEntities(3)
                for tags in gmsh.model.mesh.getElements(3, tag)[1])
    gmsh.finalize()
    return count


def run_one(args: argparse.Namespace, body: str, size: float | int, poisson: float, pc: str, ranks: int,
            work: Path) -> dict[str, Any]:
    """Run the CLI once; return the CSV row."""
    tag = f"{body}_{size:g}_nu{poisson:g}_{pc}_np{ranks}"
    out = work / "runs" / tag
    cmd = ["mpirun", "-n", str(ranks)]
    oversubscribed = ranks > (os.cpu_count() or 1)
    if oversubscribed:
        cmd += ["--oversubscribe"]
    cmd += [sys.executable, "-m", "fenics_coulomb", "--no-plots", "--quiet", "--out", str(out), "--pc", pc]
    cells: int | str = ""
    if body == "cuboid":
        cmd += ["--lev", str(size), "--gap", "d3", "--load", "L2", "--poisson", str(poisson),
                "--nested", "0"]  # the preconditioners on the level itself, not nested iteration (default from lev 7)
    else:
        mesh = make_mesh(body, float(size), work)
        cells = cell_count(mesh)
        scene = work / f"{tag}.toml"
        template = HEMISPHERE_SCENE if body == "hemisphere" else ROLLER_SCENE
        scene.write_text(template.format(mesh=mesh.resolve(), poisson=poisson))
        cmd += ["--scene", str(scene)]
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    # a session of its own, so that a run past the timeout is ended with all its ranks (and only those)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT,
                            start_new_session=True)
    try:
        log, _ = proc.communicate(timeout=args.timeout)
        code: int | str = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            log, _ = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            log, _ = proc.communicate()
        code = "timeout"
    process_s = time.perf_counter() - t0
    row: dict[str, Any] = {
        "body": body, "cells": cells, "size": size, "n": "", "poisson": poisson, "pc": pc, "ranks": ranks,
        "oversubscribed": oversubscribed, "exit": code, "reason": "", "newton": "", "krylov": "",
        "max_krylov": "", "ksp_limit_hits": log.count("KSP reached"), "solve_s": "",
        "process_s": round(process_s, 2), "load_before": load_before, "load_after": os.getloadavg()[0],
    }
    summary = out / "summary.json"
    if code != "timeout" and summary.exists():
        data = json.loads(summary.read_text())
        history = data.get("krylov_history") or [0]
        limit = SolverSettings.ksp_max_it
        row.update(n=data["n"], reason=data["reason"], newton=data["newton_iterations"],
                   krylov=data["krylov_iterations"], max_krylov=max(history),
                   ksp_limit_hits=sum(k >= limit for k in history), solve_s=round(data["wall_time_s"], 2))
    elif code != 0:
        row["reason"] = "timeout" if code == "timeout" else (log.strip().splitlines() or [""])[-1][:120]
    return row


def robust(row: dict[str, Any]) -> bool | None:
    """A run is robust when it exits 0 (converged) and every linear solve ends within one GMRES restart cycle
    (SolverSettings.gmres_restart iterations): restarted GMRES is where the solves stagnate and run into the KSP
    limit, so a default must keep this margin. A run ended by the timeout is inconclusive (None) unless a
    linear solve had already hit the KSP limit."""
    if int(row["ksp_limit_hits"] or 0) > 0:
        return False
    if str(row["exit"]) == "timeout":
        return None
    return str(row["exit"]) == "0" and int(row["max_krylov"]) <= SolverSettings.gmres_restart


def report(rows: list[dict[str, Any]], out: Path) -> None:
    """Markdown with the table, the per-group comparison and the auto rule's decisions; the plot."""
    def key(r: dict[str, Any]) -> tuple:
        return (r["body"], float(r["size"]) if r["body"] == "cuboid" else -float(r["size"]), float(r["poisson"]),
                int(r["ranks"]), r["pc"])

    rows = sorted(rows, key=key)
    lines = ["# pc = auto: ILU against GAMG on hexahedral and tetrahedral bodies", "",
             "Written by `benchmarks/pc_auto.py` (every run is `mpirun -n R python3 -m fenics_coulomb --scene FILE "
             "--no-plots`). Bodies: `cuboid` = the paper's hexahedral cuboid, case d3/L2, `size` = lev; "
             "`hemisphere` = tetrahedral hemisphere pressed on the plane (meshes/hemisphere.py, apex disc "
             "clamped, 1 GPa on the top face, F = 0.3), `roller` = tetrahedral half-cylinder "
             "(meshes/roller.py, the loads of demos/scenes/roller.toml); `size` = gmsh element size. "
             f"`ksp_limit_hits` = linear solves that stopped at the KSP limit ({SolverSettings.ksp_max_it}); "
             "`exit` 3 = not converged; `timeout` = ended by the benchmark. The machine (2 cores) is shared "
             "with other users: `load_*` is the 1-minute load average before/after the run; times are "
             "indicative, iteration counts are the robust quantity. Runs with `oversubscribed` = True had "
             "more ranks than cores.", ""]
    # summary per body, ν, rank count and preconditioner
    lines += ["## Summary", "",
              "Per body, ν, rank count and preconditioner over the measured sizes: runs, robust runs (converged, "
              f"every linear solve within one GMRES restart cycle of {SolverSettings.gmres_restart}), the largest "
              "Krylov count of one Newton step, the Newton iterations and the total Krylov iterations; timeouts "
              "(runs ended after `--timeout` s on the loaded machine, inconclusive) are left out of the ranges.", "",
              "| body | ν | ranks | pc | unknowns | runs | robust | timeouts | largest Krylov / step | Newton "
              "| Krylov |",
              "|" + "---|" * 11]
    summary: dict[tuple, list[dict[str, Any]]] = {}
    for r in rows:
        summary.setdefault((r["body"], r["poisson"], r["ranks"], r["pc"]), []).append(r)

    def span(values: list[int]) -> str:
        if not values:
            return ""
        return f"{min(values)}–{max(values)}" if min(values) != max(values) else str(values[0])

    for (body, nu, ranks, pc), group in summary.items():
        done = [r for r in group if str(r["n"]).strip()]
        lines.append(
            f"| {body} | {nu} | {ranks} | {pc} | {span([int(r['n']) for r in done])} | {len(group)} | "
            f"{sum(robust(r) is True for r in group)} | {sum(str(r['exit']) == 'timeout' for r in group)} | "
            f"{span([int(r['max_krylov']) for r in done])} | "
            f"{span([int(r['newton']) for r in done])} | {span([int(r['krylov']) for r in done])} |")
    lines += ["", "## All runs", ""]
    lines += ["| " + " | ".join(FIELDS) + " |", "|" + "---|" * len(FIELDS)]
    def shown(r: dict[str, Any], k: str) -> str:
        return f"{float(r[k]):.1f}" if k.startswith("load_") else str(r[k])

    lines += ["| " + " | ".join(shown(r, k) for k in FIELDS) + " |" for r in rows]
    # per group: which preconditioner is robust, which is faster, and what the auto rule picks
    groups: dict[tuple, dict[str, dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["body"], r["size"], r["poisson"], r["ranks"]), {})[r["pc"]] = r
    lines += ["", "## The auto rule against the measurements", "",
              f"Per body, size, ν and rank count: robust = exit 0 and every linear solve within one GMRES restart "
              f"cycle ({SolverSettings.gmres_restart} iterations; beyond it GMRES may stagnate into the KSP "
              "limit); `auto` = "
              "`choose_preconditioner(n, ranks, cell type)` of fenics_coulomb/scd/preconditioner.py; `auto ok` = the "
              "auto choice was robust in this measurement (None: ended by the timeout without a KSP at its limit, "
              "inconclusive).", "",
              "| body | size | n | ν | ranks | ilu robust | gamg robust | ilu Krylov (max/step) | "
              "gamg Krylov (max/step) | ilu s | gamg s | auto | auto ok |", "|" + "---|" * 13]
    failures = 0
    for (body, size, nu, ranks), by_pc in groups.items():
        ilu, gamg = by_pc.get("ilu"), by_pc.get("gamg")
        n = next((int(r["n"]) for r in by_pc.values() if str(r["n"]).strip()), 0)
        cell = "hexahedron" if body == "cuboid" else "tetrahedron"
        auto = choose_preconditioner(n, int(ranks), cell) if n else "?"
        chosen = by_pc.get(auto)
        ok = robust(chosen) if chosen else "?"
        failures += ok is False
        ilu_ok = "" if ilu is None else robust(ilu)
        gamg_ok = "" if gamg is None else robust(gamg)

        def cell_of(r: dict[str, Any] | None, field: str) -> str:
            return "" if r is None else str(r[field])

        def kry(r: dict[str, Any] | None) -> str:
            return "" if r is None else f"{r['krylov']} ({r['max_krylov']})"

        lines.append(f"| {body} | {size} | {n} | {nu} | {ranks} | {ilu_ok} | {gamg_ok} | {kry(ilu)} | "
                     f"{kry(gamg)} | {cell_of(ilu, 'solve_s')} | {cell_of(gamg, 'solve_s')} | {auto} | {ok} |")
    lines += ["", f"Groups where the auto choice was not robust: {failures}.", ""]
    (out / "pc-auto.md").write_text("\n".join(lines) + "\n")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    markers = {"cuboid": "s", "hemisphere": "o", "roller": "^"}
    colors = {"ilu": "tab:red", "gamg": "tab:blue"}
    for ax, ranks in zip(axes, (1, 2), strict=True):
        for r in rows:
            if int(r["ranks"]) != ranks or not str(r["n"]).strip():
                continue
            y = int(r["max_krylov"]) if str(r["max_krylov"]).strip() else SolverSettings.ksp_max_it
            ax.scatter(int(r["n"]), y, marker=markers.get(r["body"], "x"), color=colors.get(r["pc"], "k"),
                       facecolors="none" if float(r["poisson"]) < 0.4 else colors.get(r["pc"], "k"))
        ax.axhline(SolverSettings.ksp_max_it, color="k", lw=0.8, ls="--")  # the KSP limit
        ax.axhline(SolverSettings.gmres_restart, color="k", lw=0.8, ls=":")  # one GMRES restart cycle
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("unknowns")
        ax.set_title(f"{ranks} rank{'s' if ranks > 1 else ''}")
    axes[0].set_ylabel("largest Krylov count of one Newton step\n(dashed: KSP limit, dotted: GMRES restart)")
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker=m, ls="", color="gray", label=b) for b, m in markers.items()]
    handles += [Line2D([], [], marker="o", ls="", color=c, label=p) for p, c in colors.items()]
    handles += [Line2D([], [], marker="o", ls="", color="gray", mfc="none", label="ν < 0.4"),
                Line2D([], [], marker="o", ls="", color="gray", label="ν ≥ 0.4")]
    axes[1].legend(handles=handles, fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(out / "pc-auto.png", dpi=110)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/pc-auto")
    parser.add_argument("--work", default="out/pc-auto", help="meshes, scenes and run outputs")
    parser.add_argument("--levels", type=int, nargs="*", default=[2, 3, 4, 5, 6, 7])
    parser.add_argument("--hemisphere-sizes", type=float, nargs="*", default=[0.18, 0.11, 0.08, 0.06])
    parser.add_argument("--roller-sizes", type=float, nargs="*", default=[0.12, 0.07, 0.045, 0.032])
    parser.add_argument("--poisson", type=float, nargs="+", default=[0.3, 0.45])
    parser.add_argument("--pcs", nargs="+", default=["ilu", "gamg"])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--timeout", type=float, default=150.0, help="seconds before a run is ended")
    parser.add_argument("--resume", action="store_true", help="keep the CSV's rows and skip their runs")
    parser.add_argument("--report-only", action="store_true", help="rewrite the Markdown/plot from the CSV")
    args = parser.parse_args()
    out, work = Path(args.out), Path(args.work)
    out.mkdir(parents=True, exist_ok=True)
    work.mkdir(parents=True, exist_ok=True)
    table = out / "pc-auto.csv"
    rows: list[dict[str, Any]] = []
    if (args.resume or args.report_only) and table.exists():
        with open(table, newline="") as fh:
            rows = list(csv.DictReader(fh))
    if not args.report_only:
        done = {(r["body"], float(r["size"]), float(r["poisson"]), r["pc"], int(r["ranks"])) for r in rows}
        cases = [("cuboid", lev) for lev in args.levels]
        cases += [("hemisphere", h) for h in args.hemisphere_sizes] + [("roller", h) for h in args.roller_sizes]
        if not rows:
            with open(table, "w", newline="") as fh:
                csv.DictWriter(fh, fieldnames=FIELDS).writeheader()
        for body, size in cases:
            for nu in args.poisson:
                for pc in args.pcs:
                    for ranks in args.ranks:
                        if (body, float(size), nu, pc, ranks) in done:
                            continue
                        row = run_one(args, body, size, nu, pc, ranks, work)
                        rows.append(row)
                        with open(table, "a", newline="") as fh:
                            csv.DictWriter(fh, fieldnames=FIELDS).writerow(row)
                        print(json.dumps(row), flush=True)
    report(rows, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
