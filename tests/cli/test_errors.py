"""Every bad input is exit 2 with one line naming it, on every rank, before any work; every solve that does
not converge is exit 3; a zero load converges at once; gap expressions never write into their inputs.

The in-process tests (``main([...])``) run on 1 rank (pytest) and 2 ranks (mpirun -n 2 ... pytest); the
``real command`` tests start ``mpirun -n 2 python3 -m fenics_coulomb`` as a user does.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fenics_coulomb.cli import EXIT_DIVERGED, EXIT_INPUT, main
from fenics_coulomb.scenes.scene import KINDS, Scene
from fenics_coulomb.errors import InputError
from fenics_coulomb.scenes.expression import FUNCTIONS, parse_gap_expression

ROOT = Path(__file__).resolve().parents[2]
PROG = "python3 -m fenics_coulomb: error:"


def shared_file(path: Path, content: str | bytes) -> Path:
    """Write a file on rank 0 that every rank then sees."""
    if MPI.COMM_WORLD.rank == 0:
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content)
    MPI.COMM_WORLD.barrier()
    return path


def assert_one_line(capsys, *fragments: str) -> None:
    """Rank 0 printed exactly one line, the error naming every fragment (other ranks print nothing)."""
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    if MPI.COMM_WORLD.rank == 0:
        assert len(lines) == 1 and lines[0].startswith(PROG), lines
        for fragment in fragments:
            assert fragment in lines[0], (fragment, lines)
    else:
        assert lines == [], lines


# -- wrong types: every key of every section ------------------------------------------------------------
WRONG = {
    "str": ["5", '["d1"]', "true"],
    "int": ["inf", "1.5", '"4"', "true"],
    "number": ['"0.1"', "nan", "inf", "[1.0]", "true"],
    "bool": ["1", '"yes"'],
    "names": ['"left"', "[1]"],
    "vector": ["[1, 2]", "5", '["a", 1, 2]', "[1, 2, inf]"],
    "traction": ["[1, 2]", "5", "[1, 2, inf]", "[true, 1, 2]"],
    "prescription": ["[1, 2]", "5", "[1, 2, inf]", '["free", "free", "free"]', "[true, 1, 2]", '["x", 0, 0]'],
    "components": ["[3]", "1", "[0, 0]", "[true]", "[]"],
    "table": ["5", "[1, 2, 3]", '"top"'],
    "surface": ["5", "[1]", "[]"],
}
#: Every key once, with the wrong values of its kind taken in turn (so every wrong value of every kind is used).
CASES = [(section, key, WRONG[kind][i % len(WRONG[kind])])
         for i, (section, key, kind) in enumerate((s, k, t) for s, keys in KINDS.items() for k, t in keys.items())]


@pytest.mark.parametrize("section, key, value", CASES, ids=[f"{s}.{k}={v}" for s, k, v in CASES])
def test_every_scene_key_rejects_a_wrong_type(section, key, value, mpi_tmp_path):
    name = {"boundaries": "left", "tractions": "top", "prescribed": "right", "roller": "left",
            "bodies": "block"}.get(section, key)
    if section in ("obstacle", "path.step", "contact_pair"):  # arrays of tables: the message names the table's number
        path = shared_file(mpi_tmp_path / "wrong.toml", f"[[{section}]]\n{name} = {value}\n")
        match = rf"^\[\[{re.escape(section)}\]\] 1 {name} = "
    else:
        path = shared_file(mpi_tmp_path / "wrong.toml", f"[{section}]\n{name} = {value}\n")
        match = rf"^\[{section}\] {name} = "
    with pytest.raises(InputError, match=match):
        Scene.from_toml(path)


@pytest.mark.parametrize(
    "toml, fragment",
    [("[solver]\nmax_it = inf\n", "max_it = inf"), ('[solver]\ntol = "0.1"\n', "tol = '0.1'"),
     ("[solver]\nstart = 5\n", "start = 5"), ('[body]\ngap = ["d1"]\n', "gap = ['d1']"),
     ('[body]\nshape = "mesh"\nmesh = 5\n', "mesh = 5")],
)
def test_wrong_types_exit_2(toml, fragment, mpi_tmp_path, capsys):
    scene = shared_file(mpi_tmp_path / "scene.toml", toml)
    assert main(["--scene", str(scene), "--out", str(mpi_tmp_path / "out")]) == EXIT_INPUT
    assert_one_line(capsys, fragment)


# -- scene files that are no scene files ----------------------------------------------------------------
def test_scene_files_that_are_not_scenes(mpi_tmp_path, capsys):
    binary = shared_file(mpi_tmp_path / "binary.toml", bytes(range(256)) * 4)
    huge = shared_file(mpi_tmp_path / "huge.toml", "# " + "x" * (2 << 20) + "\n")
    for path, fragment in (("/dev/zero", "not a regular file"), (str(mpi_tmp_path), "is a directory"),
                           (str(binary), "binary file"), (str(huge), "larger than")):
        assert main(["--scene", path, "--out", str(mpi_tmp_path / "out")]) == EXIT_INPUT
        assert_one_line(capsys, repr(path), fragment)


# -- values no machine can solve ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "args, fragment",
    [(["--young", "1e-300"], "Young's modulus E = 1e-300"), (["--young", "1e300"], "Young's modulus E = 1e+300"),
     (["--gamma-scale", "1e300"], "gamma_scale = 1e+300"), (["--gamma-scale", "1e-300"], "gamma_scale = 1e-300"),
     (["--load-scale", "1e300"], "load scale = 1e+300"), (["--lev", "30"], "lev = 30: "),
     (["--lev", "1000"], "lev = 1000"), (["--out", ""], "--out ''"), (["--out", " "], "--out ' '"),
     (["--sliding", "large"], "sliding = 'large'"), (["--sliding", ""], "sliding = ''")],
)
def test_out_of_range_exit_2(args, fragment, mpi_tmp_path, capsys):
    argv = [*args, "--out", str(mpi_tmp_path / "out")] if "--out" not in args else [*args, "--lev", "0"]
    assert main(argv) == EXIT_INPUT
    assert_one_line(capsys, fragment)


def test_lev_refused_with_the_memory_estimate(mpi_tmp_path, capsys):
    assert main(["--lev", "30", "--out", str(mpi_tmp_path / "out")]) == EXIT_INPUT
    assert_one_line(capsys, "unknowns need about", "GiB of memory are available")
    assert not (mpi_tmp_path / "out").exists()  # refused before any work


# -- PETSc options the solver cannot use ----------------------------------------------------------------
@pytest.mark.parametrize(
    "options, fragment",
    [(["-coulomb_ksp_type", "nonsense"], "KSP type nonsense"), (["-coulomb_pc_type", "nonsense"], "PC type nonsense"),
     (["-coulomb_pc_type", "lu", "-coulomb_pc_factor_mat_solver_type", "nonsense"], "solver type nonsense")],
)
def test_unusable_petsc_options_exit_2(options, fragment, mpi_tmp_path, capsys):
    from petsc4py import PETSc

    assert main(["--lev", "0", "--out", str(mpi_tmp_path / "out"), *options]) == EXIT_INPUT
    assert_one_line(capsys, fragment)
    assert not any(k.startswith("coulomb_") for k in PETSc.Options().getAll())


# -- --start files that are not an earlier run's solution -----------------------------------------------
TRIANGLES = """<?xml version="1.0"?>
<Xdmf Version="3.0"><Domain><Grid Name="mesh" GridType="Uniform">
<Topology TopologyType="Triangle" NumberOfElements="1" NodesPerElement="3">
<DataItem Dimensions="1 3" Format="HDF">tri.h5:/topology</DataItem></Topology>
<Geometry GeometryType="XY"><DataItem Dimensions="3 2" Format="HDF">tri.h5:/geometry</DataItem></Geometry>
<Attribute Name="displacement" AttributeType="Vector" Center="Node">
<DataItem Dimensions="3 3" Format="HDF">tri.h5:/displacement</DataItem></Attribute>
</Grid></Domain></Xdmf>
"""


def test_start_files_that_are_not_solutions(mpi_tmp_path, capsys):
    garbage = shared_file(mpi_tmp_path / "garbage.xdmf", "this is not XML <<<")
    shared_file(mpi_tmp_path / "garbage.h5", b"\x00garbage" * 100)
    tri = shared_file(mpi_tmp_path / "tri.xdmf", TRIANGLES)
    if MPI.COMM_WORLD.rank == 0:
        with h5py.File(mpi_tmp_path / "tri.h5", "w") as h5:
            h5["topology"] = np.array([[0, 1, 2]])
            h5["geometry"] = np.zeros((3, 2))
            h5["displacement"] = np.zeros((3, 3))
    noh5 = shared_file(mpi_tmp_path / "noh5.xdmf", TRIANGLES)
    MPI.COMM_WORLD.barrier()
    for path, fragment in ((garbage, "not an XDMF"), (tri, "triangle"), (noh5, "does not exist")):
        assert main(["--lev", "0", "--start", str(path), "--out", str(mpi_tmp_path / "out")]) == EXIT_INPUT
        assert_one_line(capsys, "start", fragment)


def test_start_file_with_a_broken_field(mpi_tmp_path, capsys):
    """A real solution whose displacement does not fit its mesh (a file of another run pasted in)."""
    first = mpi_tmp_path / "first"
    assert main(["--lev", "0", "--out", str(first), "--quiet", "--no-plots"]) == 0
    capsys.readouterr()
    MPI.COMM_WORLD.barrier()
    if MPI.COMM_WORLD.rank == 0:
        with h5py.File(first / "solution.h5", "a") as h5:
            name = next(k for k in _datasets(h5) if "displacement" in k)
            del h5[name]
            h5[name] = np.zeros((5, 3))
    MPI.COMM_WORLD.barrier()
    status = main(["--lev", "0", "--start", str(first / "solution.xdmf"), "--out", str(mpi_tmp_path / "o")])
    assert status == EXIT_INPUT
    assert_one_line(capsys, "start", "'displacement' has shape (5, 3)")


def _datasets(h5: h5py.File) -> list[str]:
    names: list[str] = []
    h5.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
    return names


# -- gap expressions ------------------------------------------------------------------------------------
@pytest.mark.parametrize("gap, name", [("0.01 + 0*sin(1, x1)", "sin()"), ("max(x1, x2, x1)", "max()"),
                                       ("sin(x1, x2)", "sin()"), ("0.01 + hypot(x1)", "hypot()")])
def test_wrong_calls_exit_2_naming_the_function(gap, name, mpi_tmp_path, capsys):
    assert main(["--lev", "0", "--gap", gap, "--out", str(mpi_tmp_path / "out")]) == EXIT_INPUT
    assert_one_line(capsys, name, "argument")


def test_gap_expression_out_of_range_refused_before_the_mesh(mpi_tmp_path, capsys):
    assert main(["--lev", "0", "--gap", "x1 - 1", "--out", str(mpi_tmp_path / "out")]) == EXIT_INPUT
    assert_one_line(capsys, "outside [0, 1)")


ATOMS = st.sampled_from(["x1", "x2", "pi", "e", "0", "1", "0.5", "2", "1e300", "-3"])


def _calls(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    """Calls of every whitelisted function with 0 to 3 arguments (right and wrong arities)."""
    return st.builds(lambda f, args: f"{f}({', '.join(args)})", st.sampled_from(sorted(FUNCTIONS)),
                     st.lists(children, min_size=0, max_size=3))


EXPRESSIONS = st.recursive(
    ATOMS,
    lambda children: st.one_of(
        _calls(children),
        st.builds(lambda a, op, b: f"({a} {op} {b})", children, st.sampled_from(["+", "-", "*", "/", "**"]),
                  children),
        st.builds(lambda a: f"-{a}", children),
    ),
    max_leaves=12,
)


@settings(max_examples=300, deadline=None)
@given(text=EXPRESSIONS)
def test_no_expression_writes_into_its_inputs(text):
    """Property: an accepted expression never changes x1, x2 (whatever it computes); a rejected one raises
    InputError (never another exception)."""
    x1 = np.linspace(0.0, 2.0, 7)
    x2 = np.linspace(0.0, 1.0, 7)
    before1, before2 = x1.copy(), x2.copy()
    try:
        gap = parse_gap_expression(text)
    except InputError:
        return
    value = gap(x1, x2)
    assert value.shape == x1.shape and value.dtype == np.float64
    assert np.array_equal(x1, before1) and np.array_equal(x2, before2)
    assert value.base is None or (value.base is not x1 and value.base is not x2)


# -- no convergence is exit 3 ---------------------------------------------------------------------------
def test_unconverged_linear_solve_exits_3(mpi_tmp_path, capsys):
    """A body without contact nodes is one linear solve; when it fails, the run exits 3 (it exited 0). (With
    pc auto a stage that stops short hands the solve to the next, down to LU: an explicit pc fails.)"""
    scene = shared_file(mpi_tmp_path / "free.toml", "[body]\nlev = 1\ncontact = []\n[solver]\npc = 'ilu'\n")
    out = mpi_tmp_path / "out"
    from petsc4py import PETSc

    status = main(["--scene", str(scene), "--out", str(out), "--no-plots", "-coulomb_ksp_max_it", "1"])
    PETSc.Options().delValue("coulomb_ksp_max_it")
    assert status == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False
    if MPI.COMM_WORLD.rank == 0:
        assert "did not converge" in capsys.readouterr().err


@pytest.mark.parametrize("max_it", [1, 2])
def test_linear_solves_stuck_at_their_limit_exit_3(mpi_tmp_path, capsys, max_it):
    """Linear solves that reach ksp_max_it in KSP_LIMIT_STEPS consecutive Newton steps stop the solve: exit 3,
    reason ksp_limit, the last iterate written (before, each step only warned and the solve ran on: GAMG with
    --gamma-scale 1 spent 2000 iterations in every step)."""
    from petsc4py import PETSc

    from fenics_coulomb.scd.linear_solves import KSP_LIMIT_STEPS

    out = mpi_tmp_path / "out"
    status = main(["--lev", "2", "--out", str(out), "--no-plots", "--pc", "ilu", "-coulomb_ksp_max_it", str(max_it)])
    PETSc.Options().delValue("coulomb_ksp_max_it")
    assert status == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reason"] == "ksp_limit" and not summary["converged"]
    # the limited steps before the last used their inexact directions (an earlier step may have converged)
    history = summary["krylov_history"]
    assert len(history) == summary["newton_iterations"] >= KSP_LIMIT_STEPS - 1
    assert history[len(history) - (KSP_LIMIT_STEPS - 1):] == [max_it] * (KSP_LIMIT_STEPS - 1)
    assert (out / "solution.xdmf").exists() and (out / "solution.h5").exists()
    if MPI.COMM_WORLD.rank == 0:
        err = capsys.readouterr().err
        assert "iteration limit" in err and f"{KSP_LIMIT_STEPS} consecutive Newton steps" in err


# -- zero and tiny loads --------------------------------------------------------------------------------
@pytest.mark.parametrize("how", ["scale-0", "empty-tractions"])
def test_zero_load_converges_at_once(how, mpi_tmp_path):
    """From the paper's start (ũ = −d) a zero load stops at once with ũ = 0 (it ran 100 steps and exited 3)."""
    out = mpi_tmp_path / "out"
    if how == "scale-0":
        args = ["--lev", "2", "--load-scale", "0"]
    else:
        args = ["--scene", str(shared_file(mpi_tmp_path / "empty.toml", "[body]\nlev = 2\n[tractions]\n"))]
    assert main([*args, "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and summary["newton_iterations"] == 0
    assert summary["state_counts"]["open"] == summary["p"]
    with h5py.File(out / "solution.h5", "r") as h5:
        u = np.concatenate([np.asarray(h5[k][:]).ravel() for k in _datasets(h5) if "displacement" in k])
    assert np.all(u == 0.0)


def test_tiny_load_converges(mpi_tmp_path):
    """A load of 1e-12 GPa is resolved like any other (it ran 100 steps and exited 3)."""
    out = mpi_tmp_path / "out"
    assert main(["--lev", "2", "--load-scale", "1e-12", "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and 0 < summary["newton_iterations"] < 30


# -- the real command on 2 ranks ------------------------------------------------------------------------
def _mpirun(*args: str, cwd: Path | None = None, python: str = sys.executable) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX", "PRTE_"))}
    env["PYTHONPATH"] = str(ROOT)
    return subprocess.run(["mpirun", "-n", "2", python, *args], capture_output=True, text=True, timeout=120,
                          env=env, cwd=cwd)


def _own_lines(stderr: str) -> list[str]:
    """stderr without mpirun's own notices: the block between dashed lines it prints for a non-zero exit and
    the PMIx server's "[host:pid] PMIX ERROR: PMIX_ERR_UNREACH" it sometimes adds when ranks exit non-zero
    (OpenMPI 5/PMIx noise of the launcher, not of the ranks)."""
    lines, inside = [], False
    for line in stderr.splitlines():
        if line.startswith("-----"):
            inside = not inside
        elif not inside and line.strip() and not re.match(r"^\[[^\]]+:\d+\] PMIX ERROR: PMIX_ERR_UNREACH", line):
            lines.append(line)
    return lines


@pytest.mark.serial
@pytest.mark.multirank
@pytest.mark.parametrize(
    "args, fragment",
    [(["--lev", "abc"], "argument --lev: invalid int value: 'abc'"),
     (["--scene", "/dev/zero"], "not a regular file"),
     (["--lev", "0", "-coulomb_ksp_type", "nonsense"], "KSP type nonsense"),
     (["--lev", "30"], "GiB of memory are available"),
     (["--lev", "0", "--start", "/dev/null.xdmf"], "start")],
    ids=["argparse", "dev-zero", "petsc", "lev30", "start"],
)
def test_real_command_bad_input(args, fragment, tmp_path):
    proc = _mpirun("-m", "fenics_coulomb", *args, cwd=tmp_path)
    assert proc.returncode == EXIT_INPUT, proc.stderr
    lines = _own_lines(proc.stderr)
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in proc.stderr, proc.stderr
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.serial
@pytest.mark.multirank
def test_help_prints_once(tmp_path):
    proc = _mpirun("-m", "fenics_coulomb", "--help", cwd=tmp_path)
    assert proc.returncode == 0 and proc.stdout.count("usage:") == 1


@pytest.mark.serial
@pytest.mark.multirank
def test_python_spelling_of_the_usage_line(tmp_path):
    """The design's usage line `mpirun -n 2 python demos/cuboid.py` works (python, not only python3)."""
    proc = _mpirun("demos/cuboid.py", "--lev", "0", "--no-plots", "--quiet", "--out", str(tmp_path / "o"),
                   cwd=ROOT, python="python")
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["converged"] is True
