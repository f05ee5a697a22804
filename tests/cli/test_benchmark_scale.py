"""The scaling benchmark's helpers: level/rank pairing, plans, launcher, peak-RSS records and summary parsing.

No timing is asserted; the solves here are lev 1 (well under a second), only to parse real summaries.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import pytest

from fenics_coulomb.cli import main as cli_main
from fenics_coulomb.scenes.cuboid import expected_sizes

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
from benchmarks import elastic  # noqa: E402
from benchmarks import peak_rss  # noqa: E402
from benchmarks import scale  # noqa: E402


def unknowns(lev: int) -> int:
    return expected_sizes(lev)[1]


def plan(argv: list[str]) -> scale.Plan:
    return scale.make_plan(scale.build_parser().parse_args(argv), unknowns)


# -- pairing ----------------------------------------------------------------------------------------------

@pytest.mark.serial  # rank-local (docs/testing.md)
def test_weak_pairs_exact_when_unknowns_double_per_level():
    pairs = scale.weak_pairs(3, [1, 2, 4, 8], lambda lev: 1000 * 2**lev)
    assert pairs == [(3, 1), (4, 2), (5, 4), (6, 8)]


@pytest.mark.serial  # rank-local (docs/testing.md)
@pytest.mark.parametrize("base, ranks", [(7, [1, 2]), (7, [1, 2, 4, 8, 16]), (10, [2, 4, 8, 16])])
def test_weak_pairs_are_the_closest_levels(base, ranks):
    target = unknowns(base) / ranks[0]
    pairs = scale.weak_pairs(base, ranks, unknowns)
    assert [r for _, r in pairs] == ranks
    assert pairs[0] == (base, ranks[0])
    for lev, r in pairs:
        misfit = abs(math.log(unknowns(lev) / r / target))
        assert all(misfit <= abs(math.log(unknowns(other) / r / target)) for other in range(16))
        # the cuboid's unknowns grow by about 2^(3/2) per level: the best level is within half a level
        assert misfit <= 0.5 * math.log(2**1.5) + 0.1
    levels = [lev for lev, _ in pairs]
    assert levels == sorted(levels)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_weak_pair_on_our_machine():
    """lev 7 on 1 rank and lev 8 on 2 ranks: unknowns per rank within 35 % (the recorded weak pair)."""
    assert scale.weak_pairs(7, [1, 2], unknowns) == [(7, 1), (8, 2)]
    assert 1.0 < unknowns(8) / 2 / unknowns(7) < 1.35


# -- command-line plans -----------------------------------------------------------------------------------

@pytest.mark.serial  # rank-local (docs/testing.md)
def test_plan_default_is_the_level_study():
    p = plan([])
    assert p.case == "d3/L2"
    assert p.jobs == [("levels", lev, 2) for lev in (6, 7, 8, 9, 10)]
    assert plan(["--lev11"]).jobs[-1] == ("levels", 11, 2)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_plan_ranks_is_strong_scaling_at_a_fixed_level():
    assert plan(["--ranks", "1", "2", "4", "8", "16"]).jobs == [("strong", 10, r) for r in (1, 2, 4, 8, 16)]
    assert plan(["--ranks", "1", "2", "--lev", "8"]).jobs == [("strong", 8, 1), ("strong", 8, 2)]


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_plan_weak_and_combinations():
    assert plan(["--weak"]).jobs == [("weak", 7, 1), ("weak", 8, 2)]
    jobs = plan(["--weak", "--strong", "--ranks", "1", "2", "--lev", "8", "--levels", "6", "--np", "1"]).jobs
    assert [s for s, _, _ in jobs] == ["levels", "strong", "strong", "weak", "weak"]
    assert jobs[0] == ("levels", 6, 1)


@pytest.mark.serial  # rank-local (docs/testing.md)
@pytest.mark.parametrize("argv", [["--repeat", "0"], ["--ranks", "0"], ["--np", "0"], ["--case", "d3"],
                                  ["--levels", "-1"]])
def test_plan_rejects_bad_values(argv):
    with pytest.raises(ValueError):
        plan(argv)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_launcher_oversubscribes_only_beyond_the_cores():
    ompi = "mpirun (Open MPI) 5.0.7"
    assert scale.launcher_command("mpirun -n {n}", 2, 2, ompi) == ["mpirun", "-n", "2"]
    assert scale.launcher_command("mpirun -n {n}", 16, 2, ompi) == ["mpirun", "--map-by", ":OVERSUBSCRIBE", "-n", "16"]
    assert scale.launcher_command("mpirun -n {n}", 4, 2, "mpirun (Open MPI) 4.1.4")[1] == "--oversubscribe"
    assert scale.launcher_command("mpiexec -n {n}", 4, 2, "HYDRA build details") == ["mpiexec", "-n", "4"]
    assert scale.launcher_command("srun --mpi=pmix -n {n}", 64, 2, "") == ["srun", "--mpi=pmix", "-n", "64"]


# -- peak RSS -----------------------------------------------------------------------------------------------

@pytest.mark.serial  # rank-local (docs/testing.md)
def test_aggregate_rss():
    records = [{"rank": "0", "peak_rss_kib": 1024 * 300}, {"rank": "1", "peak_rss_kib": 1024 * 100}]
    agg = scale.aggregate_rss(records)
    assert agg["rss_sum_MiB"] == pytest.approx(400.0)
    assert agg["rss_max_MiB"] == pytest.approx(300.0)
    assert agg["rss_mean_MiB"] == pytest.approx(200.0)
    assert agg["rss_max_over_mean"] == pytest.approx(1.5)
    assert agg["rss_ranks"] == 2
    assert math.isnan(scale.aggregate_rss([])["rss_sum_MiB"])


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_read_rss_orders_by_rank(tmp_path):
    for rank in (10, 2, 0):
        (tmp_path / f"rss-{rank}.json").write_text(json.dumps({"rank": str(rank), "peak_rss_kib": rank}))
    assert [r["rank"] for r in scale.read_rss(tmp_path)] == ["0", "2", "10"]


@pytest.mark.serial
def test_peak_rss_wrapper_measures_the_child_from_outside(tmp_path):
    """A child that holds 300 MiB is recorded with at least that peak, under the launcher's rank."""
    child = "b = b'x' * (300 * 2**20); import sys; sys.exit(5)"
    env = {"PATH": "/usr/bin:/bin", "OMPI_COMM_WORLD_RANK": "3"}
    proc = subprocess.run([sys.executable, str(BENCHMARKS / "peak_rss.py"), str(tmp_path), "--",
                           sys.executable, "-c", child], env=env)
    assert proc.returncode == 5
    record = json.loads((tmp_path / "rss-3.json").read_text())
    assert record["rank"] == "3" and record["returncode"] == 5
    assert 300 * 1024 <= record["peak_rss_kib"] < 600 * 1024


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_rank_from_environment():
    assert peak_rss.rank_from_environment({"PMI_RANK": "7"}) == "7"
    assert peak_rss.rank_from_environment({"SLURM_PROCID": "12", "OMPI_COMM_WORLD_RANK": "1"}) == "1"
    assert peak_rss.rank_from_environment({}).startswith("pid")


# -- summaries of the real commands ---------------------------------------------------------------------------

def test_phases_of_the_contact_cli(mpi_tmp_path):
    out = mpi_tmp_path / "contact"
    assert cli_main(["--lev", "1", "--no-plots", "--quiet", "--out", str(out)]) == 0
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    row = scale.phases("contact", data)
    t = data["timings_s"]
    assert set(scale.PHASES) <= {k[:-2] for k in row if k.endswith("_s")}
    assert all(row[f"{k}_s"] >= 0.0 for k in scale.PHASES)
    assert row["mesh_s"] <= t["model"] + 1e-12 and row["assembly_s"] <= t["model"] + 1e-12
    assert row["solve_s"] == t["total"]
    assert row["phases_s"] == pytest.approx(sum(row[f"{k}_s"] for k in scale.PHASES))
    assert row["n"] == unknowns(1)
    assert (row["newton"], row["krylov"], row["converged"]) == (data["newton_iterations"],
                                                                data["krylov_iterations"], True)


def test_phases_of_the_linear_reference(mpi_tmp_path):
    out = mpi_tmp_path / "linear"
    assert elastic.main(["--lev", "1", "--out", str(out)]) == 0
    MPI.COMM_WORLD.barrier()
    data = json.loads((out / "summary.json").read_text())
    row = scale.phases("linear", data)
    assert row["n"] == unknowns(1) and row["converged"] and row["newton"] == 0 and row["krylov"] > 0
    assert row["phases_s"] == pytest.approx(data["timings_s"]["total"])
    assert (out / "solution.xdmf").exists() and (out / "solution.h5").exists()
    with pytest.raises(ValueError):
        scale.phases("other", data)


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_pair_rows_and_markdown():
    def row(solve, wall, rss):
        return {"study": "strong", "lev": 8, "ranks": 2, "repeat": 0, "solve": solve, "n": 209088, "wall_s": wall,
                "solve_s": wall / 2, "rss_sum_MiB": rss, "rss_max_over_mean": 1.0, "krylov": 10, "newton": 5,
                "converged": True, "load1_before": 1.0, "load1_after": 2.0}

    paired = scale.pair_rows([row("contact", 30.0, 1200.0), row("linear", 20.0, 1000.0)])
    assert len(paired) == 1
    assert paired[0]["time_ratio"] == pytest.approx(1.5) and paired[0]["memory_ratio"] == pytest.approx(1.2)
    assert paired[0]["n_per_rank"] == 104544 and paired[0]["load1"] == 2.0
    lines = scale.markdown_table(paired, [("lev", "lev"), ("time_ratio", "ratio"), ("missing", "x")])
    assert lines[0] == "| lev | ratio | x |" and lines[2] == "| 8 | 1.50 | – |"


@pytest.mark.serial  # rank-local (docs/testing.md)
def test_efficiencies():
    def entry(ranks, n, contact, linear):
        return {"ranks": ranks, "n": n, "c_wall_s": contact, "l_wall_s": linear}

    strong = scale.efficiencies([entry(1, 1000, 10.0, 4.0), entry(2, 1000, 6.0, 2.0), entry(2, 1000, 5.0, 3.0)],
                                weak=False)
    assert strong[("c", 1)] == 1.0 and strong[("l", 1)] == 1.0
    assert strong[("c", 2)] == pytest.approx(10.0 / (2 * 5.0))  # the fastest repeat counts
    assert strong[("l", 2)] == pytest.approx(1.0)
    # weak: twice the unknowns per rank in twice the time is perfect; equal time for 1.5x per rank is 1.5
    weak = scale.efficiencies([entry(1, 1000, 10.0, 4.0), entry(2, 4000, 20.0, 4.0)], weak=True)
    assert weak[("c", 2)] == pytest.approx(1.0) and weak[("l", 2)] == pytest.approx(2.0)
    weak = scale.efficiencies([entry(1, 1000, 10.0, 4.0), entry(2, 3000, 10.0, 4.0)], weak=True)
    assert weak[("c", 2)] == pytest.approx(1.5)
