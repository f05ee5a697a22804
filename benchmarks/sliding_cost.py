# ---
# jupytext:
#   text_representation:
#     extension: .py
#     format_name: light
# ---

# # The cost of finite sliding against small sliding on the demo scenes
#
# Every demo scene solved with `--sliding finite` and `--sliding small`, back to back in one process (the form
# kernels compiled once, so the second mode is not charged for it), alternating which mode runs first: Newton
# and Krylov iterations over every geometry, geometry updates, and the time spent in `ContactProblem.solve` (the sum
# over the steps of a path: the geometry updates, pairings and solver set-ups included; model set-up and output
# excluded), as wall time and as this process's CPU time (the machine is shared: the CPU time is the steadier
# measure under load). Writes `docs/sliding/cost.md`.
#
#     python3 benchmarks/sliding_cost.py [--out docs/sliding] [--scenes NAME ...] [--hertz LEVEL ...] [--table cost.md]
#     python3 benchmarks/sliding_cost.py --robustness [--cases NAME ...] [--table robustness.md]
#
# `--robustness` measures the cases of benchmarks/robustness.py instead (the engineers' meshes: graded, slivers,
# thin, nearly incompressible, a roller, two bodies; their meshes made in a temporary directory, each run with the
# defaults as docs/robustness does). `--hertz 1` adds the hemisphere pressed onto the block of
# benchmarks/verification_two_body.py (dual mortar, 23 781 unknowns at level 1) at the default rtol. Each table row
# also gives the pairings inside the finite solves and the floor of the ratio they imply: (small solve + one
# pairing per solve) / small solve.

from __future__ import annotations

import argparse
import csv
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from fenics_coulomb.cli import main
import fenics_coulomb.model.pairs.coupling as coupling_module
from fenics_coulomb.problem import ContactProblem
from fenics_coulomb.settings import SolverSettings

ROOT = Path(__file__).resolve().parents[1]

#: The scenes measured: every demo scene with something curved (pairs, spheres, cylinders, STL) and, as the
#: control, planes (no update, bit for bit).
SCENES = ["sphere_indentation", "surface_ball", "cylinder_roller", "two_bodies", "slide_off", "tilted_plane", "roller",
          "d3_L2_path", "cylinder_drag_path", "roller_rolling_path", "stl_roller_rolling"]


class SolveClock:
    """Wall and CPU time spent inside ``ContactProblem.solve`` (every call, on this rank) while installed, and the
    count and wall time of the pairings of contact pairs inside it (``pair_surfaces`` as the pair coupling calls
    it: the geometry checks and updates of finite sliding; the construction's pairing is not counted)."""

    def __init__(self) -> None:
        self.wall = 0.0
        self.cpu = 0.0
        self.pairings = 0
        self.pairing_wall = 0.0
        self._solve = ContactProblem.solve
        self._pair = coupling_module.pair_surfaces
        self._inside = False

    def __enter__(self) -> SolveClock:
        clock, solve, pair = self, self._solve, self._pair

        def timed(problem: ContactProblem, *args: Any, **kwargs: Any) -> Any:
            w0, c0 = time.perf_counter(), time.process_time()
            clock._inside = True
            try:
                return solve(problem, *args, **kwargs)
            finally:
                clock._inside = False
                clock.wall += time.perf_counter() - w0
                clock.cpu += time.process_time() - c0

        def timed_pairing(*args: Any, **kwargs: Any) -> Any:
            w0 = time.perf_counter()
            try:
                return pair(*args, **kwargs)
            finally:
                if clock._inside:
                    clock.pairing_wall += time.perf_counter() - w0
                    clock.pairings += 1

        ContactProblem.solve = timed  # type: ignore[method-assign]
        coupling_module.pair_surfaces = timed_pairing  # type: ignore[assignment]
        return self

    def __exit__(self, *args: object) -> None:
        ContactProblem.solve = self._solve  # type: ignore[method-assign]
        coupling_module.pair_surfaces = self._pair  # type: ignore[assignment]


def measure(comm: MPI.Comm, scene: Path, sliding: str, out: Path) -> dict[str, Any]:
    """Solve the scene file ``scene`` in one sliding mode: Newton and Krylov iterations, geometry updates, the
    time in ``ContactProblem.solve`` (wall and CPU, the largest over the ranks), the pairings of contact pairs
    inside it (count and wall time) and the command's wall time."""
    t0 = time.perf_counter()
    with SolveClock() as clock:
        status = main(["--scene", str(scene), "--sliding", sliding, "--out", str(out), "--quiet", "--no-plots"])
    command = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    summary = json.loads((out / "summary.json").read_text())
    row: dict[str, Any] = {"status": status, "command_s": command,
                           "solve_s": comm.allreduce(clock.wall, op=MPI.MAX),
                           "cpu_s": comm.allreduce(clock.cpu, op=MPI.MAX),
                           "pairings": clock.pairings, "pairing_s": comm.allreduce(clock.pairing_wall, op=MPI.MAX)}
    if (out / "path.csv").exists():
        with open(out / "path.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        row["solves"] = len(rows)
        row["newton"] = sum(int(r["newton_iterations"]) for r in rows)
        row["krylov"] = sum(int(r["krylov_iterations"]) for r in rows)
        row["updates"] = sum(int(r.get("geometry_updates") or 0) for r in rows)
    else:
        row["solves"] = 1
        row["newton"] = int(summary["newton_iterations"])
        row["krylov"] = int(summary["krylov_iterations"])
        row["updates"] = int(summary.get("geometry_updates") or 0)
    return row


def measure_hertz(comm: MPI.Comm, level: int, sliding: str) -> dict[str, Any]:
    """The hemisphere pressed onto the block of benchmarks/verification_two_body.py (dual mortar, frictionless,
    its mesh level ``level``) at the default rtol through the API, measured as :func:`measure` does (the command:
    mesh, problem and solve)."""
    import benchmarks.verification_two_body as hertz

    saved = hertz.SLIDING
    hertz.SLIDING = sliding
    t0 = time.perf_counter()
    try:
        with SolveClock() as clock:
            body = hertz._Hemisphere(comm, hertz.HERTZ2_LEVELS[level], hertz.HERTZ_MATERIALS, 0.0,
                                     f"cost_{sliding}_", SolverSettings().rtol)
            try:
                body.flat.value[:] = (0.0, 0.0, -hertz.HERTZ_DELTA)
                _, result = body.problem.solve()
            finally:
                body.destroy()
    finally:
        hertz.SLIDING = saved
    return {"status": 0 if result.converged else 3, "command_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX),
            "solve_s": comm.allreduce(clock.wall, op=MPI.MAX), "cpu_s": comm.allreduce(clock.cpu, op=MPI.MAX),
            "pairings": clock.pairings, "pairing_s": comm.allreduce(clock.pairing_wall, op=MPI.MAX), "solves": 1,
            "newton": int(result.iterations), "krylov": int(result.krylov_iterations),
            "updates": int(result.geometry_updates or 0)}


def table(comm: MPI.Comm, scenes: dict[str, Path | int], work: Path) -> list[dict[str, Any]]:
    """Both modes of every scene (name: scene file, or the level of the Hertz hemisphere), back to back, the first
    mode alternating from scene to scene."""
    rows = []
    for k, (scene, path) in enumerate(scenes.items()):
        modes = ("finite", "small") if k % 2 == 0 else ("small", "finite")
        result = {m: measure_hertz(comm, path, m) if isinstance(path, int)
                  else measure(comm, path, m, work / f"{scene}_{m}") for m in modes}
        rows.append({"scene": scene, **{f"{m}_{key}": v for m in modes for key, v in result[m].items()}})
        if comm.rank == 0:
            f, s = result["finite"], result["small"]
            print(f"{scene}: Newton {s['newton']} -> {f['newton']} ({f['updates']} updates), Krylov {s['krylov']} -> "
                  f"{f['krylov']}, solve {s['solve_s']:.2f} -> {f['solve_s']:.2f} s, CPU {s['cpu_s']:.2f} -> "
                  f"{f['cpu_s']:.2f} s", flush=True)
    return rows


def robustness_scenes(names: list[str] | None, work: Path, comm: MPI.Comm) -> dict[str, Path]:
    """The scene files of benchmarks/robustness.py's cases (all, or ``names``), their meshes made in ``work`` on
    rank 0."""
    from benchmarks.robustness import CASES, prepare

    cases = [c for c in CASES if names is None or c.name in names]
    unknown = sorted(set(names or ()) - {c.name for c in cases})
    if unknown:
        raise SystemExit(f"sliding_cost: no robustness case {', '.join(unknown)} (cases: "
                         f"{', '.join(c.name for c in CASES)})")
    scenes = {c.name: prepare(c, work / c.name)[0]["auto"] for c in cases} if comm.rank == 0 else None
    return comm.bcast(scenes, root=0)


def write(rows: list[dict[str, Any]], path: Path, comm: MPI.Comm, command: str = "") -> None:
    """The Markdown table (rank 0)."""
    if comm.rank != 0:
        return
    load = os.getloadavg()[0]
    lines = [f"Measured with `python3 benchmarks/sliding_cost.py{command}` on {comm.size} rank(s), load average "
             f"{load:.1f} at the end (2-core machine), {time.strftime('%Y-%m-%d %H:%M')}. Newton and Krylov iterations "
             "over every geometry of every solve; solve time = the wall and CPU time inside `ContactProblem.solve` "
             "summed over the solves (geometry updates included; model set-up and output excluded). Pairings: those of "
             "contact pairs inside the finite solves (geometry checks and updates), count and wall time. Floor: the "
             "ratio finite sliding cannot go below with this pairing, (small solve + one pairing per solve) / small "
             "solve — a solve must evaluate the geometry of its solution at least once to know it has settled.", "",
             "| scene | solves | small Newton | finite Newton (updates) | small Krylov | finite Krylov | small solve s "
             "| finite solve s | time ratio | finite pairings (s) | floor | small CPU s | finite CPU s | CPU ratio "
             "| small command s | finite command s | command ratio |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        time_ratio = r["finite_solve_s"] / max(r["small_solve_s"], 1e-9)
        cpu_ratio = r["finite_cpu_s"] / max(r["small_cpu_s"], 1e-9)
        count = r["finite_pairings"]
        floor = 1.0 + min(count, r["finite_solves"]) * (r["finite_pairing_s"] / max(count, 1)) / \
            max(r["small_solve_s"], 1e-9)
        pairings = f"{count} ({r['finite_pairing_s']:.2f})" if count else "0"
        lines.append(
            f"| {r['scene']} | {r['finite_solves']} | {r['small_newton']} | {r['finite_newton']} "
            f"({r['finite_updates']}) | {r['small_krylov']} | {r['finite_krylov']} | {r['small_solve_s']:.2f} "
            f"| {r['finite_solve_s']:.2f} | {time_ratio:.2f} | {pairings} | {floor:.2f} | {r['small_cpu_s']:.2f} "
            f"| {r['finite_cpu_s']:.2f} | {cpu_ratio:.2f} | {r['small_command_s']:.1f} | {r['finite_command_s']:.1f} "
            f"| {r['finite_command_s'] / max(r['small_command_s'], 1e-9):.2f} |")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(ROOT / "docs" / "sliding"))
    parser.add_argument("--scenes", nargs="*", default=SCENES)
    parser.add_argument("--robustness", action="store_true",
                        help="measure benchmarks/robustness.py's cases instead of the demo scenes")
    parser.add_argument("--cases", nargs="*", default=None, help="with --robustness: these cases only")
    parser.add_argument("--hertz", type=int, nargs="*", default=[],
                        help="also the Hertz hemisphere of benchmarks/verification_two_body.py at these mesh levels")
    parser.add_argument("--table", default=None, help="the table's file name in --out (default cost.md, with "
                                                      "--robustness robustness.md)")
    args = parser.parse_args()
    if args.cases is not None and not args.robustness:
        parser.error("--cases selects robustness cases: give it with --robustness (the demo scenes: --scenes)")
    if args.robustness and args.scenes != SCENES:
        parser.error("--scenes selects demo scenes: not with --robustness (its cases: --cases)")
    comm = MPI.COMM_WORLD
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(comm.bcast(tmp if comm.rank == 0 else None))
        scenes: dict[str, Path | int]
        if args.robustness:
            scenes = dict(robustness_scenes(args.cases, work / "meshes", comm))
        else:
            scenes = {name: ROOT / "demos" / "scenes" / f"{name}.toml" for name in args.scenes}
        scenes.update({f"hertz level {level}": level for level in args.hertz})
        table_name = args.table or ("robustness.md" if args.robustness else "cost.md")
        write(table(comm, scenes, work), Path(args.out) / table_name, comm, " --robustness" * args.robustness)
