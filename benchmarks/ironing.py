"""Ironing, small strain: an elastic hemisphere pressed into an elastic block and dragged over five contact radii
and back, with the contact geometry following the hemisphere (finite sliding).

    container/run mpirun -n 2 python3 benchmarks/ironing.py [--out docs/sliding] [--sliding finite] [--contact H]

The scene is docs/sliding/ironing.toml (the hemisphere of demos/scenes/two_bodies.toml: E 210 on a block of E 70,
both ν 0.3, F = 0.3, dual mortar; the flat face pressed 0.02, then dragged 0.7 along x₁ in 14 substeps and back
in 14). Per solve: the force on the hemisphere from the block (P its normal part, Q its tangential part), the
contact area (Σ D_j over the closed slave nodes: the mortar nodal areas), the contact radius a = √(area/π), the
stick and slip counts and the geometry updates. While every contact node slips, Coulomb's law gives |t_j| = F p_j
node by node, so Q = F·P exactly when the tractions are parallel; the steady drag must keep P and a (the slave
mesh moves with the hemisphere, so its contact nodes do too).

With ``--contact H`` the same scene runs on a mesh made with element size H at the contact (the scene's own:
0.12, about 7 contact nodes; docs/sliding/fine-0.06 and fine-0.04 hold the refined runs). Writes ``ironing.csv``,
``ironing.md`` and ``ironing.png`` into ``--out``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from collections.abc import Callable
from typing import Any

from mpi4py import MPI

import numpy as np

from fenics_coulomb.scd.resolvent import OPEN
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.path import obstacle_labels, plan, run_path
from fenics_coulomb.scenes.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "docs" / "sliding" / "ironing.toml"


def run(comm: MPI.Comm, sliding: str = "finite", scene_path: Path = SCENE, substeps: tuple[int, int] | None = None,
        rtol: float | None = None) -> list[dict[str, Any]]:
    """Solve the ironing path; one row per solve (the same on every rank); ``rtol`` replaces the scene's."""
    scene = Scene.from_toml(str(scene_path)).override(sliding=sliding, rtol=rtol)
    if substeps is not None:  # a shorter path (tests): the drag and the way back in fewer substeps
        import dataclasses

        steps = list(scene.path)
        steps[1] = dataclasses.replace(steps[1], substeps=substeps[0])
        steps[2] = dataclasses.replace(steps[2], substeps=substeps[1])
        scene = dataclasses.replace(scene, path=steps)
    solves = plan(scene)
    rows: list[dict[str, Any]] = []
    built = build_problem(scene, comm, petsc_options_prefix=f"ironing_{sliding}_")
    friction = float(scene.contact_pairs[0].friction)

    def record(solve: Any, step: Any, result: Any) -> None:
        model = problem.model
        closed = result.states != OPEN
        f = np.asarray(result.contact_force, dtype=np.float64).reshape(-1, 3)
        force = comm.allreduce(f.sum(axis=0), op=MPI.SUM)
        # the resultant's parts carried by the nodal normal forces (f·n) n and by the tangential tractions: Coulomb's
        # law holds node by node in each node's frame, the ratio of the resultants mixes both through the tilts
        assert f.shape[0] == model.contact.size
        n = model.contact.frames[:, :, 2]
        normal_part = comm.allreduce((np.einsum("ij,ij->i", f, n)[:, None] * n).sum(axis=0), op=MPI.SUM)
        tangential_part = force - normal_part
        area = comm.allreduce(float(np.sum(model.pairing.area[closed[:model.pairing.area.size]])), op=MPI.SUM)
        p = np.maximum(np.asarray(result.normal_force, dtype=np.float64), 0.0)
        t = np.linalg.norm(np.asarray(result.tangential_force, dtype=np.float64).reshape(-1, 2), axis=1)
        sum_t = comm.allreduce(float(t.sum()), op=MPI.SUM)
        sum_p = comm.allreduce(float(p.sum()), op=MPI.SUM)
        drag = float(loads_x(solve))
        rows.append({"solve": solve.index, "step": solve.step, "drag": drag, "P": float(force[2]),
                     "Q": float(np.hypot(force[0], force[1])), "Qx": float(force[0]),
                     "ratio": float(np.hypot(force[0], force[1]) / force[2]) if force[2] > 0 else 0.0,
                     "Pn": float(normal_part[2]), "Pt": float(tangential_part[2]), "Qn": float(normal_part[0]),
                     "Qt": float(tangential_part[0]),
                     "cone": sum_t / (friction * sum_p) if sum_p > 0 else 0.0, "area": area,
                     "a": float(np.sqrt(area / np.pi)), "stick": step.counts["stick"], "slip": step.counts["slip"],
                     "updates": step.geometry_updates, "newton": step.newton_iterations})
        if comm.rank == 0:
            r = rows[-1]
            print(f"solve {r['solve']:2d} drag {r['drag']:+.3f}: P {r['P']:.6f} Q/P {r['ratio']:.6f} a {r['a']:.4f} "
                  f"stick/slip {r['stick']}/{r['slip']} updates {r['updates']}", flush=True)

    def loads_x(solve: Any) -> float:
        start, end = solve.start.prescribed["flat"][0], solve.end.prescribed["flat"][0]
        return (1.0 - solve.weight) * start + solve.weight * end

    with built.problem as problem:
        _, _, failure = run_path(problem, built.loads, solves, obstacle_labels(scene), built.dirichlet_groups or {},
                                 on_solve=record)
    if failure:
        raise RuntimeError(f"ironing: the path stopped: {failure}")
    return rows


def write(out: Path, rows: list[dict[str, Any]], friction: float, seconds: float, comm: MPI.Comm,
          sliding: str, option: str = "") -> None:
    """ironing.csv, ironing.md and ironing.png (rank 0)."""
    if comm.rank != 0:
        return
    import os

    out.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    csv_rows = [",".join(f"{r[k]:.10g}" if isinstance(r[k], float) else str(r[k]) for k in keys) for r in rows]
    (out / "ironing.csv").write_text("\n".join([",".join(keys), *csv_rows]) + "\n")
    pressed = [r for r in rows if r["step"] == 1][-1]
    steady = [r for r in rows if r["step"] >= 2 and r["stick"] == 0 and r["slip"] > 0]
    ratio_dev = max(abs(r["ratio"] / friction - 1.0) for r in steady) if steady else float("nan")
    P_dev = max(abs(r["P"] / pressed["P"] - 1.0) for r in steady) if steady else float("nan")
    a_dev = max(abs(r["a"] - pressed["a"]) for r in steady) if steady else float("nan")
    split_dev = max(abs(abs(r["Qt"] / r["Pn"]) / friction - 1.0) for r in steady) if steady else float("nan")
    table = ["| solve | drag x₁ | P | Q/P | Σ abs t / (F Σ p) | abs Qₜ / Pₙ | Qₙ, Pₜ | a | stick / slip | updates | "
             "Newton |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        table.append(f"| {r['solve']} | {r['drag']:+.3f} | {r['P']:.6f} | {r['ratio']:.6f} | "
                     f"{r['cone']:.8f} | {abs(r['Qt'] / r['Pn']):.6f} | {r['Qn']:+.2e}, {r['Pt']:+.2e} | "
                     f"{r['a']:.4f} | {r['stick']} / {r['slip']} | {r['updates']} | {r['newton']} |")
    title = f"Ironing: a hemisphere dragged over five contact radii and back ({sliding} sliding)"
    scene_link = os.path.relpath(SCENE, out.resolve())
    where = f" on a mesh with element size {option.split()[-1]} at the contact" if option else ""
    (out / "ironing.md").write_text(f"""# {title}

`container/run mpirun -n {comm.size} python3 benchmarks/ironing.py{option}` ({comm.size} ranks, load average
{os.getloadavg()[0]:.1f}, {seconds:.0f} s): the scene [ironing.toml]({scene_link}) (its header has the set-up){where}.
P, Q: the normal and tangential parts of the force on the hemisphere from the block; a = √(area/π) with the
area Σ D_j over the closed slave nodes; "Σ abs t / (F Σ p)" = 1 when every node's traction is on the cone.
The resultant split by what carries it: Pₙ, Qₙ the vertical and x₁ parts of the nodal normal forces (f·n)n, Pₜ, Qₜ
those of the tangential tractions (P = Pₙ + Pₜ, Q₁ = Qₙ + Qₜ): each node's normal n is tilted on the curved slave,
so a normal force has an x₁ part and a tangential traction a vertical one.

Pressed: P = {pressed['P']:.6f}, a = {pressed['a']:.4f}. Over the {len(steady)} solves of the drag where every
contact node slips: Q/P within {ratio_dev:.2e} of F = {friction:g} (relative; abs Qₜ/Pₙ within {split_dev:.2e}),
P within {100 * P_dev:.3f} % of the pressed
value, a within {a_dev:.4f} of it (the element size at the contact: {option.split()[-1] if option else "0.12"}).

{chr(10).join(table)}

![Q and P along the drag](ironing.png)
""")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    s = np.arange(1, len(rows) + 1)
    ax[0].plot(s, [r["P"] for r in rows], "o-", ms=3, label="P (normal)")
    ax[0].plot(s, [r["Qx"] for r in rows], "s-", ms=3, label="Q₁ (tangential, x₁)")
    ax[0].plot(s, [friction * r["P"] for r in rows], "k--", lw=0.8, label="F·P")
    ax[0].plot(s, [-friction * r["P"] for r in rows], "k--", lw=0.8)
    ax[0].set_xlabel("solve (press 1–2, drag 3–16, back 17–30)")
    ax[0].set_ylabel("force on the hemisphere")
    ax[0].legend()
    ax[1].plot([r["drag"] for r in rows], [r["ratio"] for r in rows], "o-", ms=3)
    ax[1].axhline(friction, color="k", ls="--", lw=0.8)
    ax[1].set_xlabel("drag x₁")
    ax[1].set_ylabel("Q / P")
    fig.suptitle("Ironing: hemisphere on block, F = 0.3, dual mortar, finite sliding")
    fig.tight_layout()
    fig.savefig(out / "ironing.png", dpi=110)


def refined_scene(comm: MPI.Comm, contact: float, directory: Path) -> Path:
    """docs/sliding/ironing.toml on a mesh with element size ``contact`` at the contact, made on rank 0 in
    ``directory`` (the same on every rank); the scene file's path (collective)."""
    scene = directory / "ironing.toml"
    if comm.rank == 0:
        from meshes.hemisphere_on_block import build

        mesh = directory / "hemisphere_ironing.msh"
        build(contact, mesh, size=0.6, refined=1.0)
        text = SCENE.read_text()
        assert 'mesh = "../../meshes/hemisphere_ironing.msh"' in text
        scene.write_text(text.replace('mesh = "../../meshes/hemisphere_ironing.msh"', f"mesh = {str(mesh)!r}"))
    comm.barrier()
    return scene


def _positive_int(text: str) -> int:
    """A substep count: an integer ≥ 1 (argparse refuses anything else, on every rank, before any MPI call)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} substeps: need at least 1")
    return value


def _in_unit_interval(name: str) -> Callable[[str], float]:
    """An argparse type: a number in (0, 1) called ``name`` in the refusal (argparse refuses anything else, on every
    rank, before any MPI call)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not 0.0 < value < 1.0:
            raise argparse.ArgumentTypeError(f"{name} {value!r}: must lie in (0, 1)")
        return value

    return parse


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "sliding"))
    parser.add_argument("--sliding", default="finite", choices=["finite", "small"])
    parser.add_argument("--substeps", type=_positive_int, nargs=2, metavar=("DRAG", "BACK"), default=None,
                        help="a shorter path: the drag and the way back in these many substeps (the scene: 14 14)")
    parser.add_argument("--rtol", type=_in_unit_interval("rtol"), default=None,
                        help="the solves' rtol in (0, 1) (the scene: 1e-9)")
    parser.add_argument("--contact", type=_in_unit_interval("element size"), default=None, metavar="H",
                        help="the scene on a mesh made with element size H at the contact (meshes/"
                             "hemisphere_on_block.py --contact H --size 0.6 --refined 1.0, in a temporary directory; "
                             "the scene's own mesh has H = 0.12)")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="ironing-") as tmp:
        scene = SCENE if args.contact is None else refined_scene(comm, args.contact, Path(comm.bcast(tmp)))
        rows = run(comm, args.sliding, scene_path=scene,
                   substeps=None if args.substeps is None else tuple(args.substeps), rtol=args.rtol)
    seconds = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    friction = float(Scene.from_toml(str(SCENE)).contact_pairs[0].friction)
    option = "" if args.contact is None else f" --contact {args.contact:g}"
    write(Path(args.out), rows, friction, seconds, comm, args.sliding, option)
    return 0


if __name__ == "__main__":
    sys.exit(main())
