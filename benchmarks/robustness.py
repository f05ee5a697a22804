"""Robustness of the defaults on bodies meshed the way engineers mesh them (issue 27).

    container/run python3 benchmarks/robustness.py --out docs/robustness            # every case, 1 and 2 ranks
    container/run python3 benchmarks/robustness.py --cases tet-sphere,roller-gap --ranks 2

Each case is a gmsh body (meshes/engineering.py, meshes/roller.py, meshes/hemisphere_on_block.py) and a scene
file that uses only the defaults of the solver (no ``pc``, ``gamma_scale``, ``rtol`` or start given). It is run
with the real command, ``mpirun -n R python3 -m fenics_coulomb --scene FILE --out DIR``, with the default start
(``start = "auto"``: :meth:`fenics_coulomb.problem.ContactProblem.start_rule`) and, to judge the rule, from the paper's
start (``start = "zero"``) and from the undeformed body (``start = "undeformed"``), and compared with one
linear-elastic solve of the same model
(its stiffness matrix A, the same mesh and boundary conditions) by the best of CG + GAMG and CG + BoomerAMG
(``python3 benchmarks/robustness.py linear FILE``, the same ranks). Recorded per run:

- the exit status, Newton and Krylov iterations, the preconditioner history (pc auto's ladder);
- the time of the contact solve (γ, setup and the Newton iterations of every solve of a path: summary.json's
  ``timings_s``) against the time of the linear solve (setup and solve of its best preconditioner): ``ratio``;
  and the same for the whole command against the whole linear command (Python start, mesh, assembly, output
  included): ``job ratio``;
- the start the rule took (the explicit start whose iteration the default run repeats bit for bit) and the
  Newton and Krylov iterations from each explicit start;
- the force balance from each start: the largest relative residual of equilibrium and of the global
  balance (reactions + contact forces + applied loads) in summary.json's physics checks.

Writes ``robustness.csv``, ``robustness.md`` (table) and ``robustness.png`` (ratio per case) into ``--out``.
Run on an idle machine (timings); the load average is recorded with the results. ``--starts auto`` runs the
default start only.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: Wall-time limit of a baseline run (an earlier version's defaults may crawl).
BASELINE_TIMEOUT = 300.0
#: Facet tags of the generated blocks (meshes/engineering.py's BLOCK_TAGS).
BLOCK_BOUNDARIES = "[boundaries]\nbottom = 1\ntop = 2\nsides = 3\n"
#: Indentation depth of the sphere (radius 0.3) and the cylinder (radius 0.3) into the blocks, and the contact
#: radius a = √(R δ) ≈ 0.0095 of the sphere: a contact zone about 1/50 of the block, graded toward it.
DEPTH = 0.0003
A = (0.3 * DEPTH) ** 0.5
SPHERE = ('[[obstacle]]\nname = "ball"\ntype = "sphere"\ncenter = [0.5, 0.5, 0.8]\nradius = 0.3\n'
          "displacement = {move}\n")


@dataclass
class Case:
    """A robustness case: how its mesh is made and its scene (``{mesh}`` stands for the mesh file)."""

    name: str
    what: str
    mesh: Callable[[Path], Any]
    scene: str
    fast: bool = False  # part of the tests' fast subset


def _block_scene(material: str = "young = 70.0\npoisson = 0.334", friction: float = 0.3,
                 move: str = f"[0.0, 0.0, -{DEPTH}]", obstacle: str = SPHERE, extra: str = "") -> str:
    return ('[body]\nshape = "mesh"\nmesh = "{mesh}"\nclamped = ["bottom"]\ncontact = ["top"]\n'
            f"{BLOCK_BOUNDARIES}[material]\n{material}\n[friction]\ncoefficient = {friction}\n[tractions]\n"
            + obstacle.replace("{move}", move) + extra)


CYLINDER = ('[[obstacle]]\nname = "roller"\ntype = "cylinder"\npoint = [0.0, 0.5, 0.8]\naxis = [1.0, 0.0, 0.0]\n'
            "radius = 0.3\ndisplacement = {move}\n")

DRAG_PATH = """
[[path.step]]
substeps = 2

[[path.step]]
move = { ball = [0.0003, 0.0, -0.0003] }
substeps = 4
"""


def _graded_tet(h0: float, growth: float, toward: str = "point", refined: float = 0.0,
                optimize: bool = True) -> Callable[[Path], Any]:
    def make(path: Path) -> Any:
        from meshes.engineering import graded_tetrahedra
        return graded_tetrahedra(path, h0, growth, toward, h_max=0.25, optimize=optimize, refined=refined)
    return make


def _graded_hex(n: int, power: float) -> Callable[[Path], Any]:
    def make(path: Path) -> Any:
        from meshes.engineering import graded_hexahedra
        return graded_hexahedra(path, n, power)
    return make


def _plate(path: Path) -> Any:
    from meshes.engineering import thin_plate
    return thin_plate(path, 0.05, 0.025)


def _roller(path: Path) -> Any:
    from meshes import roller
    roller.CLEARANCE = 0.025  # 5 % of the radius 0.5
    roller.build(0.045, path)
    return _gmsh_info(path)


def _two_bodies(path: Path) -> Any:
    from meshes import hemisphere_on_block
    hemisphere_on_block.build(0.05, path, size=0.25)
    return _gmsh_info(path)


def _gmsh_info(path: Path) -> dict[str, Any]:
    import gmsh
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        tags, _ = gmsh.model.mesh.getElementsByType(4)
        quality = gmsh.model.mesh.getElementQualities(tags, "minSICN")
        return {"nodes": int(gmsh.model.mesh.getNodes()[0].size), "cells": int(tags.size),
                "min_quality": float(quality.min())}
    finally:
        gmsh.finalize()


PLATE_SCENE = ('[body]\nshape = "mesh"\nmesh = "{mesh}"\nclamped = ["sides"]\ncontact = ["bottom"]\n'
               f"{BLOCK_BOUNDARIES}[material]\nyoung = 70.0\npoisson = 0.3\n[friction]\ncoefficient = 0.3\n"
               "[tractions]\n"
               '[[obstacle]]\nname = "ball"\ntype = "sphere"\ncenter = [0.5, 0.5, -0.42]\nradius = 0.4\n'
               "displacement = [0.0, 0.0, 0.03]\n")

ROLLER_SCENE = ('[body]\nshape = "mesh"\nmesh = "{mesh}"\ncontact = ["bottom"]\n'
                "[boundaries]\nleft = 1\nright = 2\ntop = 3\nbottom = 4\n"
                "[material]\nyoung = 70.0\npoisson = 0.334\n[friction]\ncoefficient = 0.3\n"
                "[tractions]\nright = [0.0, -0.05, 0.0]\n[prescribed]\ntop = [0.0, 0.0, -0.03]\n")

PAIR_SCENE = ('[body]\nshape = "mesh"\nmesh = "{mesh}"\nclamped = ["block_bottom"]\n'
              "[boundaries]\nblock_top = 1\nblock_bottom = 2\nblock_sides = 3\ncurved = 4\nflat = 5\n"
              "[bodies]\nblock = 1\nhemisphere = 2\n"
              "[material]\nyoung = 70.0\npoisson = 0.3\n[material.hemisphere]\nyoung = 210.0\npoisson = 0.25\n"
              "[prescribed]\nflat = [0.004, 0.0, -0.02]\n[tractions]\n"
              '[[contact_pair]]\nslave = "curved"\nmaster = "block_top"\nfriction = 0.3\n')

CASES = [
    Case("tet-sphere", "tetrahedra graded toward a sphere's contact point: edge a/16 within 1.2 a, then growth 1.3",
         _graded_tet(A / 16, 1.3, refined=1.2 * A), _block_scene()),
    Case("tet-cylinder", "tetrahedra graded toward a cylinder's contact line: edge a/2 within a, growth 1.3",
         _graded_tet(A / 2, 1.3, toward="line", refined=A), _block_scene(obstacle=CYLINDER)),
    Case("hex-drag", "hexahedra graded toward the contact (power 2, 2n × 2n × n, n = 16): press, then drag (path)",
         _graded_hex(16, 2.0), _block_scene(extra=DRAG_PATH)),
    Case("slivers", "gmsh's raw (unoptimized) Delaunay tetrahedra, edge a/8 graded by 1.3: slivers",
         _graded_tet(A / 8, 1.3, refined=1.2 * A, optimize=False), _block_scene(), fast=True),
    Case("thin-plate", "a plate 0.05 thick clamped at its sides, a sphere 0.02 below pushed 0.03 up",
         _plate, PLATE_SCENE, fast=True),
    Case("roller-gap", "a half-cylinder roller 5 % of its radius above the plane, its top pressed down",
         _roller, ROLLER_SCENE),
    Case("nu-0.49", "tetrahedra graded as for slivers but optimized, ν = 0.49",
         _graded_tet(A / 8, 1.3, refined=1.2 * A),
         _block_scene("young = 70.0\npoisson = 0.49")),
    Case("nu-0.499", "the same, ν = 0.499", _graded_tet(A / 8, 1.3, refined=1.2 * A),
         _block_scene("young = 70.0\npoisson = 0.499")),
    Case("friction-1", "the same (ν = 0.334), F = 1, the sphere pressed and moved sideways by δ in one step",
         _graded_tet(A / 8, 1.3, refined=1.2 * A), _block_scene(friction=1.0, move=f"[{DEPTH}, 0.0, -{DEPTH}]")),
    Case("friction-2", "the same, F = 2", _graded_tet(A / 8, 1.3, refined=1.2 * A),
         _block_scene(friction=2.0, move=f"[{DEPTH}, 0.0, -{DEPTH}]"), fast=True),
    Case("two-bodies", "a stiff hemisphere on a block, non-matching graded meshes (node-to-surface pair)",
         _two_bodies, PAIR_SCENE),
]


@dataclass
class Run:
    """One command run: its status, iterations, timings and checks (from summary.json)."""

    status: int
    wall: float
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def steps(self) -> list[dict[str, Any]]:
        """The solves of a load path (summary.json "steps"), or the one solve."""
        return self.summary.get("steps") or [self.summary]

    def total(self, key: str) -> int:
        return int(sum(s.get(key, 0) or 0 for s in self.steps))

    @property
    def solve_time(self) -> float:
        """γ, setup and the Newton iterations of every solve (the contact solver's own time)."""
        timings = self.summary.get("timings_s", {})
        if "steps" in self.summary:
            return timings.get("gamma", 0.0) + timings.get("setup", 0.0) + sum(s["wall_time_s"] for s in self.steps)
        return sum(timings.get(k, 0.0) for k in ("gamma", "setup", "total"))

    @property
    def balance(self) -> float:
        """The global force balance of the last solve: |Σ reactions + obstacle contact forces + applied load|
        relative to the largest of them, and each pair's action-reaction balance (a pair's forces are internal
        to the two bodies: the written contact force is the obstacles')."""
        last = self.steps[-1]
        try:
            pairs = self.summary.get("contact_pairs", [])
            obstacles = np.array(last["contact_force"])
            terms = [np.array(v) for v in last["reactions"].values()] + [obstacles, np.array(last["applied_load"])]
        except KeyError:
            return float("nan")
        scale = max(np.linalg.norm(t) for t in terms)
        balance = float(np.linalg.norm(sum(terms)) / scale) if scale > 0 else 0.0
        return max([balance] + [float(p.get("balance", 0.0)) for p in pairs])

    @property
    def equilibrium(self) -> float:
        """The physics check's nodal equilibrium residual of the last solve (the largest residual of a free
        row relative to the largest contact force or load)."""
        return float(self.summary.get("physics_checks", {}).get("equilibrium", float("nan")))


def mpirun(ranks: int, args: list[str], cwd: Path, timeout: float | None = None) -> tuple[int, float, str]:
    command = ["mpirun", "-n", str(ranks), *args] if ranks > 1 else args
    t0 = time.perf_counter()
    proc = subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    return proc.returncode, time.perf_counter() - t0, proc.stdout + proc.stderr


def run_contact(scene: Path, out: Path, ranks: int, checkout: Path = ROOT, timeout: float | None = None) -> Run:
    """The real command on ``scene`` with the package of ``checkout`` (this one, or a baseline's)."""
    shutil.rmtree(out, ignore_errors=True)
    try:
        status, wall, log = mpirun(ranks, [sys.executable, "-m", "fenics_coulomb", "--scene", str(scene), "--out",
                                           str(out), "--no-plots", "--quiet"], checkout, timeout)
    except subprocess.TimeoutExpired:
        return Run(-1, float(timeout or 0), {"log": f"over {timeout} s"})
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    if status != 0:
        summary.setdefault("log", log[-2000:])
    return Run(status, wall, summary)


def run_linear(scene: Path, ranks: int) -> dict[str, Any]:
    status, wall, log = mpirun(ranks, [sys.executable, str(Path(__file__).resolve()), "linear", str(scene)], ROOT)
    lines = [line for line in log.splitlines() if line.startswith("{")]
    if status != 0 or not lines:
        raise RuntimeError(f"the linear solve of {scene} failed ({status}): {log[-2000:]}")
    data = json.loads(lines[-1])
    data["wall"] = wall
    return data


# -- the linear reference (run under mpirun) ----------------------------------------------------------------
def linear(scene_path: Path) -> int:
    """Solve A x = b once on the scene's model with CG + GAMG and CG + BoomerAMG (and, for contact pairs, CG + the
    solver's GAMG on the physical stiffness, scd/physical_preconditioner.py); print the best as JSON.

    b is the scene's load when it has one, else A w for a smooth w (the obstacle scenes load through contact
    alone); the near-nullspace is the model's rigid-body modes. Time: KSP setup + solve (max over ranks)."""
    from mpi4py import MPI
    from petsc4py import PETSc

    from fenics_coulomb.scenes.builder import build_problem
    from fenics_coulomb.scenes.scene import Scene
    from fenics_coulomb.scd.physical_preconditioner import PhysicalGAMG
    from fenics_coulomb.scd.preconditioner import HYPRE_ELASTICITY

    comm = MPI.COMM_WORLD
    built = build_problem(Scene.from_toml(scene_path), comm, petsc_options_prefix="linear_")
    model = built.problem.model
    A = model.A
    b = model.load.copy()
    if b.norm() == 0.0:
        w = A.createVecRight()
        start, _ = w.getOwnershipRange()
        w.setArray(1e-3 * (1.0 + ((start + np.arange(w.getLocalSize())) % 3)))
        A.mult(w, b)
        w.destroy()
    nullspace = model.near_nullspace()
    A.setNearNullSpace(nullspace)
    options = PETSc.Options()
    best: dict[str, Any] | None = None
    B = model.physical_stiffness()
    candidates = [("gamg", {}), ("hypre", {k: v for k, v in HYPRE_ELASTICITY.items()})]
    if B is not None:
        candidates.append(("physical-gamg", {}))
    for pc, extra in candidates:
        prefix = f"linear_{pc.replace('-', '_')}_"
        for key, value in extra.items():
            options[f"{prefix}{key}"] = value
        x = A.createVecRight()
        ksp = PETSc.KSP().create(comm)
        ksp.setOptionsPrefix(prefix)
        ksp.setOperators(A)
        ksp.setType("cg")
        physical = None
        if pc == "physical-gamg":
            assert B is not None
            physical = PhysicalGAMG(B, model.variables, model.V, prefix)
            ksp.getPC().setType("python")
            ksp.getPC().setPythonContext(physical)
            physical.set_from_options()
        else:
            ksp.getPC().setType(pc)
        if pc == "hypre":
            ksp.getPC().setHYPREType("boomeramg")
        ksp.setTolerances(rtol=1e-8, max_it=5000)
        ksp.setFromOptions()
        comm.barrier()
        t0 = time.perf_counter()
        ksp.setUp()
        ksp.solve(b, x)
        elapsed = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        result = {"pc": pc, "iterations": ksp.getIterationNumber(), "converged": ksp.getConvergedReason() > 0,
                  "time": elapsed, "n": A.getSize()[0]}
        if result["converged"] and (best is None or elapsed < best["time"]):
            best = result
        ksp.destroy()
        x.destroy()
        if physical is not None:
            physical.destroy()
        for key in extra:
            options.delValue(f"{prefix}{key}")
    b.destroy()
    nullspace.destroy()
    built.problem.destroy()
    if comm.rank == 0:
        print(json.dumps(best or {"converged": False}), flush=True)
    return 0 if best else 3


# -- the study --------------------------------------------------------------------------------------------------
#: The starts a case runs from: the default (the start rule) and each start it chooses between.
STARTS = ("auto", "zero", "undeformed")


def prepare(case: Case, work: Path) -> tuple[dict[str, Path], Any]:
    """Write the case's mesh and a scene file per start of :data:`STARTS` ("auto": the defaults, no start named)."""
    work.mkdir(parents=True, exist_ok=True)
    mesh = work / f"{case.name}.msh"
    info = case.mesh(mesh)
    text = case.scene.replace("{mesh}", str(mesh))
    scenes = {}
    for start in STARTS:
        scenes[start] = work / (f"{case.name}.toml" if start == "auto" else f"{case.name}-{start}.toml")
        scenes[start].write_text(text if start == "auto" else text + f'\n[solver]\nstart = "{start}"\n')
    return scenes, info


def chosen_start(default: Run, runs: dict[str, Run]) -> str:
    """The explicit start whose iteration the default run repeated (the same residual history), or "?"."""
    history = [s.get("residual_history") for s in default.steps]
    return next((start for start, run in runs.items() if [s.get("residual_history") for s in run.steps] == history),
                "?")


def study(cases: list[Case], ranks: list[int], work: Path, baseline: Path | None = None,
          starts: tuple[str, ...] = STARTS) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for case in cases:
        scenes, info = prepare(case, work)
        for r in ranks:
            lin = run_linear(scenes["auto"], r)
            first = run_contact(scenes["auto"], work / f"{case.name}-{r}", r)
            others = {start: run_contact(scenes[start], work / f"{case.name}-{r}-{start}", r)
                      for start in starts if start != "auto"}
            history = [f"{h['from']}→{h['to']}@{h['newton_step']}"
                       for h in first.summary.get("preconditioner_history", [])]
            row = {
                "case": case.name, "ranks": r, "n": first.summary.get("n", lin["n"]),
                "status": first.status, "start": chosen_start(first, others),
                "newton": first.total("newton_iterations"), "krylov": first.total("krylov_iterations"),
                "pc": first.summary.get("preconditioner", ""),
                "escalations": " ".join(history) or "-",
                "contact_s": first.solve_time, "linear_s": lin["time"], "linear_pc": lin["pc"],
                "linear_its": lin["iterations"],
                "krylov_ratio": first.total("krylov_iterations") / max(lin["iterations"], 1),
                "ratio": first.solve_time / lin["time"] if lin["time"] > 0 else float("nan"),
                "job_s": first.wall, "linear_job_s": lin["wall"], "job_ratio": first.wall / lin["wall"],
                "balance": first.balance, "equilibrium": first.equilibrium,
            }
            for start, run in others.items():
                row.update({f"status_{start}": run.status, f"newton_{start}": run.total("newton_iterations"),
                            f"krylov_{start}": run.total("krylov_iterations"), f"balance_{start}": run.balance})
            if baseline is not None:  # the same command with an earlier checkout's defaults
                before = run_contact(scenes["auto"], work / f"{case.name}-{r}-baseline", r, baseline, BASELINE_TIMEOUT)
                row["before"] = (f"exit {before.status}, {before.total('newton_iterations')} / "
                                 f"{before.total('krylov_iterations')}, {before.wall:.1f} s")
            if first.status or any(run.status for run in others.values()):
                row["log"] = (first.summary.get("log") or next((run.summary.get("log") for run in others.values()
                                                                  if run.summary.get("log")), ""))[-500:]
            rows.append(row)
            print(json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()
                              if k != "log"}), flush=True)
    return rows


def write(rows: list[dict[str, Any]], out: Path, cases: list[Case], load: float | None = None) -> None:
    out.mkdir(parents=True, exist_ok=True)
    keys = list(dict.fromkeys(k for row in rows for k in row if k != "log"))
    with open(out / "robustness.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, keys, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    load = os.getloadavg()[0] if load is None else load

    def counts(r: dict[str, Any], start: str) -> str:
        if f"newton_{start}" not in r:
            return "-"
        return f"{r[f'newton_{start}']} / {r[f'krylov_{start}']}" + (f" (exit {r[f'status_{start}']})"
                                                                     if r[f"status_{start}"] else "")

    lines = [
        "# Robustness of the defaults (benchmarks/robustness.py)", "",
        f"Load average at the start of the study: {load:.2f} (1 min), machine of {os.cpu_count()} cores (timings "
        "on a loaded machine are not comparable between rows; the iteration counts are). Every case runs the real "
        "command with the defaults (start `auto`, the column `start` names the start it took: the explicit start "
        "whose run repeats its iteration bit for bit) and, to judge the rule, from the paper's start (`zero`) and "
        "from the undeformed body. `Krylov ratio` = the default run's Krylov iterations / the iterations of the "
        "best linear solve of the same A (CG + GAMG or BoomerAMG, rtol 1e-8); `ratio` = the contact solver's time "
        "(γ, setup, every Newton step of every solve) / that linear solve's time (KSP setup + solve); `job` = the "
        "same for the whole commands. Balance: |Σ reactions + contact forces on obstacles + applied load| "
        "relative to the largest of them, and each pair's action-reaction balance; nodal equilibrium: the physics "
        "check (the largest free-row residual relative to the largest nodal contact force or load). Before: the "
        "same command with the defaults of an earlier checkout (`--baseline`), the same ranks.", "",
        "| case | ranks | unknowns | exit | start | Newton / Krylov | zero: Newton / Krylov | undeformed: Newton / "
        "Krylov | linear its (pc) | Krylov ratio | pc (escalations) | contact s | linear s | ratio | job ratio "
        "| balance | nodal equilibrium | before (exit, Newton / Krylov, job) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['ranks']} | {r['n']} | {r['status']} | {r['start']} | {r['newton']} / {r['krylov']} | "
            f"{counts(r, 'zero')} | {counts(r, 'undeformed')} | {r['linear_its']} ({r['linear_pc']}) | "
            f"{r['krylov_ratio']:.2f} | {r['pc']} ({r['escalations']}) | {r['contact_s']:.2f} | {r['linear_s']:.2f} | "
            f"{r['ratio']:.2f} | {r['job_ratio']:.2f} | {r['balance']:.1e} | {r['equilibrium']:.1e} | "
            f"{r.get('before', '-')} |")
    lines += ["", "Cases:", ""] + [f"- `{c.name}`: {c.what}" for c in cases] + [""]
    (out / "robustness.md").write_text("\n".join(lines))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(9, 4))
        for i, r in enumerate(sorted({row["ranks"] for row in rows})):
            sel = [row for row in rows if row["ranks"] == r]
            xs = [j + 0.4 * i for j in range(len(sel))]
            ax.bar(xs, [row["ratio"] for row in sel], width=0.4, label=f"{r} rank(s)")
            ax.set_xticks([j + 0.2 for j in range(len(sel))], [row["case"] for row in sel], rotation=30, ha="right")
        ax.axhline(3.0, color="k", ls="--", lw=1, label="3 × a linear solve")
        ax.set_ylabel("contact solve / linear solve")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "robustness.png", dpi=120)
        plt.close(fig)
    except ImportError:  # pragma: no cover - matplotlib is in the package list
        pass


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["linear"]:
        return linear(Path(argv[1]))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "robustness")
    parser.add_argument("--work", type=Path, default=ROOT / "out" / "robustness")
    parser.add_argument("--cases", default="", help="comma-separated case names (default: all)")
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--baseline", type=Path, help="a checkout of an earlier version: its defaults run too")
    parser.add_argument("--starts", default=",".join(STARTS),
                        help="comma-separated starts to run (default: auto, zero, undeformed; auto always runs)")
    args = parser.parse_args(argv)
    args.work = args.work.resolve()
    chosen = [c for c in CASES if not args.cases or c.name in args.cases.split(",")]
    starts = tuple(s for s in STARTS if s == "auto" or s in args.starts.split(","))
    load = os.getloadavg()[0]
    rows = study(chosen, args.ranks, args.work, args.baseline, starts)
    write(rows, args.out, chosen, load)
    bad = [r for r in rows if r["status"] or any(r.get(f"status_{s}") for s in starts)]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
