"""pc = auto: the default preconditioner converges on tetrahedral bodies and agrees with the measurements.

The rule (fenics_coulomb.scd.preconditioner.choose_preconditioner) is chosen from docs/pc-auto (benchmarks/pc_auto.py).
"""

from __future__ import annotations

import csv
import importlib
import json
from pathlib import Path

from mpi4py import MPI

import pytest

from fenics_coulomb.cli import main
from fenics_coulomb.scd.preconditioner import choose_preconditioner
from fenics_coulomb.settings import SolverSettings

ROOT = Path(__file__).resolve().parents[2]
TABLE = ROOT / "docs" / "pc-auto" / "pc-auto.csv"

# The scenes the measurement in docs/pc-auto ran (benchmarks/pc_auto.py), so the test checks the same bodies.
from benchmarks import pc_auto  # noqa: E402

SCENES = {"hemisphere": pc_auto.HEMISPHERE_SCENE, "roller": pc_auto.ROLLER_SCENE}


def scene_file(tmp: Path, body: str, size: float, poisson: float) -> Path:
    """The scene of ``body`` meshed by its generator in meshes/ at ``size`` (on rank 0)."""
    comm = MPI.COMM_WORLD
    mesh, scene = tmp / f"{body}.msh", tmp / f"{body}.toml"
    if comm.rank == 0:
        generator = importlib.import_module(f"meshes.{body}")
        generator.build(size, mesh)
        scene.write_text(SCENES[body].format(mesh=mesh, poisson=poisson))
    comm.barrier()
    return scene


@pytest.mark.parametrize(
    ("body", "size", "poisson"),
    [
        ("hemisphere", 0.18, 0.45),  # 3 531 unknowns
        # 24 612 unknowns: the old rule's ILU needed 118 (1 rank) and 110 (2 ranks) iterations in one linear
        # solve, more than a GMRES restart cycle (docs/pc-auto)
        ("roller", 0.045, 0.3),
    ],
)
def test_default_is_robust_on_tetrahedra(mpi_tmp_path, body, size, poisson):
    """The user's command with the default pc on a tetrahedral body: exit 0, converged, the preconditioner
    the rule picks, no linear solve at the KSP limit and each within one GMRES restart cycle (the margin a
    default keeps from stagnation)."""
    scene = scene_file(mpi_tmp_path, body, size, poisson)
    out = mpi_tmp_path / "out"
    assert main(["--scene", str(scene), "--out", str(out), "--no-plots", "--quiet"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is True
    assert summary["preconditioner"] == choose_preconditioner(summary["n"], MPI.COMM_WORLD.size, "tetrahedron")
    assert max(summary["krylov_history"]) < SolverSettings.ksp_max_it
    assert max(summary["krylov_history"]) <= SolverSettings.gmres_restart
    counts = summary["state_counts"]
    assert counts["stick"] + counts["slip"] > 0 and counts["open"] > 0  # pressed on the plane


def measured_groups() -> dict[tuple, dict[str, dict[str, str]]]:
    with open(TABLE, newline="") as fh:
        rows = list(csv.DictReader(fh))
    groups: dict[tuple, dict[str, dict[str, str]]] = {}
    for r in rows:
        if r["n"].strip():
            groups.setdefault((r["body"], r["size"], r["poisson"], r["ranks"]), {})[r["pc"]] = r
    return groups


def robust(row: dict[str, str]) -> bool:
    """Converged, no linear solve at the KSP limit, each within one GMRES restart cycle."""
    return (row["exit"] == "0" and int(row["ksp_limit_hits"] or 0) == 0
            and int(row["max_krylov"]) <= SolverSettings.gmres_restart)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_rule_is_robust_on_every_measured_case():
    """Wherever docs/pc-auto (benchmarks/pc_auto.py) measured a robust preconditioner, the rule picks one that
    was robust there too. Fails when the rule changes against the measurements (or these change)."""
    groups = measured_groups()
    assert len(groups) >= 20
    assert {"cuboid", "hemisphere", "roller"} <= {key[0] for key in groups}
    for (body, size, nu, ranks), by_pc in groups.items():
        n = int(next(iter(by_pc.values()))["n"])
        cell = "hexahedron" if body == "cuboid" else "tetrahedron"
        choice = choose_preconditioner(n, int(ranks), cell)
        if any(robust(r) for r in by_pc.values()):
            assert choice in by_pc and robust(by_pc[choice]), (body, size, nu, ranks, choice)


def test_rule_refuses_nonsense():
    assert choose_preconditioner(1, 1, "hexahedron") in ("ilu", "gamg")
    for n, ranks in ((0, 1), (10, 0), (-5, 2)):
        with pytest.raises(ValueError, match="must be >= 1"):
            choose_preconditioner(n, ranks, "tetrahedron")
