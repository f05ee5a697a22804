"""PETSc options that no object of the solver reads are reported, not ignored silently.

A misspelt option (``ksp_rtoll``) or one of another preconditioner than the one in use (``pc_gamg_threshold`` with
ILU) used to be dropped without a word: ``petsc_options`` are scoped to the solver's calls and the command's
``-coulomb_*`` options removed when it ends, which also silences PETSc's own ``-options_left`` report. PETSc's "used"
flag of its options database (``PetscOptionsUsed``) tells which were read. A review found three holes, tested here:
the command's trial KSP (the options' check before the run) marked options read; nested iteration's coarse levels
warned of the command's options in the API's words, also of those the fine level read; and options a preconditioner
reads at its first set-up were named when no linear solve had run (a zero load).
"""

from __future__ import annotations

import json
import logging

from mpi4py import MPI

import dolfinx
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem, SolverSettings
from fenics_coulomb.cli import main
from fenics_coulomb.scd.options import option_read


class Collect(logging.Handler):
    """The messages of the warnings logged."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def _pressed_block(comm: MPI.Comm, load: float = -0.01):
    """A unit block pressed onto the plane x3 = 0 by a body force ``load`` (a, L, bcs, contact)."""
    msh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.ones(3)], [3, 3, 3], dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = ufl.inner(ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))) * ufl.dx
    L = ufl.inner(dolfinx.fem.Constant(msh, np.array([0.0, 0.0, load])), v) * ufl.dx
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    side = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[0], 0.0))
    tags = dolfinx.mesh.meshtags(msh, 2, bottom, np.ones(bottom.size, dtype=np.int32))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, side), V)
    return a, L, [bc], (tags, [1])


def test_option_read_tells_a_read_option_from_an_unread_one():
    """The flag is PETSc's: set by a KSP's setFromOptions for the options it queries, not for a misspelt one."""
    from petsc4py import PETSc

    opts = PETSc.Options()
    opts["unread_test_ksp_rtol"] = 1e-3
    opts["unread_test_ksp_rtoll"] = 1e-3
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    try:
        assert option_read("unread_test_ksp_rtol") is False
        ksp.setOptionsPrefix("unread_test_")
        ksp.setFromOptions()
        assert option_read("unread_test_ksp_rtol") is True
        assert option_read("unread_test_ksp_rtoll") is False
    finally:
        ksp.destroy()
        opts.delValue("unread_test_ksp_rtol")
        opts.delValue("unread_test_ksp_rtoll")


@pytest.mark.parametrize("pc, unread", [("gamg", ["ksp_rtoll"]), ("ilu", ["ksp_rtoll", "pc_gamg_threshold"])])
def test_api_options_no_object_reads_are_warned_once(pc, unread):
    """ContactProblem's petsc_options: the misspelt name is named (and, with ILU, the GAMG option), the options the
    KSP and its preconditioner read are not; once per solver, not at every solve."""
    if pc == "ilu" and MPI.COMM_WORLD.size > 1:
        pc = "hypre"  # no parallel ILU: another preconditioner than GAMG
    collect = Collect()
    log = logging.getLogger("fenics_coulomb.scd.linear_solves")
    log.addHandler(collect)
    options = {"ksp_rtoll": 1e-3, "ksp_gmres_restart": 50, "pc_gamg_threshold": 0.01}
    try:
        a, L, bcs, contact = _pressed_block(MPI.COMM_WORLD)
        with ContactProblem(a, L, bcs, contact, friction=0.3, settings=SolverSettings(pc=pc),
                            petsc_options_prefix="unread_", petsc_options=options) as problem:
            for _ in range(2):
                assert problem.solve()[1].converged
    finally:
        log.removeHandler(collect)
    reported = [m for m in collect.messages if m.startswith("petsc_options not read")]
    if MPI.COMM_WORLD.rank == 0:
        assert len(reported) == 1, collect.messages
        assert reported[0].split(": ", 1)[1].split(" — ")[0] == ", ".join(unread)
    else:
        assert reported == []


def test_command_options_no_object_reads_are_warned(mpi_tmp_path, capsys):
    """The command's -coulomb_* options: the misspelt one named on stderr, exit 0; the options read are not."""
    status = main(["--lev", "1", "--out", str(mpi_tmp_path / "o"), "--quiet", "--no-plots", "-coulomb_ksp_rtoll",
                   "1e-3", "-coulomb_ksp_gmres_restart", "40"])
    assert status == 0
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        line = next(x for x in err.splitlines() if x.startswith("PETSc options not read"))
        assert line.split(": ", 1)[1].split(" — ")[0] == "-coulomb_ksp_rtoll"


def test_api_options_read_at_the_first_set_up_are_not_named_before_it():
    """A first solve under zero load runs no linear solve: GAMG's level options, read at its first set-up, are not
    named then, nor after the next solve, which reads them."""
    collect = Collect()
    log = logging.getLogger("fenics_coulomb.scd.linear_solves")
    log.addHandler(collect)
    try:
        for load in (0.0, -0.01):
            a, L, bcs, contact = _pressed_block(MPI.COMM_WORLD, load)
            with ContactProblem(a, L, bcs, contact, friction=0.3, settings=SolverSettings(pc="gamg"),
                                petsc_options_prefix="unread_setup_",
                                petsc_options={"mg_levels_ksp_max_it": 2}) as problem:
                first = problem.solve()[1]
                assert first.converged and (first.krylov_iterations == 0) == (load == 0.0)
                problem.solve()
    finally:
        log.removeHandler(collect)
    assert not [m for m in collect.messages if m.startswith("petsc_options not read")], collect.messages


def _unread_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if "not read" in line]


@pytest.mark.parametrize("args, unread", [
    (["--lev", "1", "--pc", "gamg", "-coulomb_pc_factor_levels", "2"], "-coulomb_pc_factor_levels"),
    (["--lev", "1", "--pc", "lu", "-coulomb_pc_gamg_threshold", "0.02", "-coulomb_ksp_gmres_restart", "40"],
     "-coulomb_pc_gamg_threshold"),
    (["--lev", "4", "--nested", "2", "--pc", "gamg", "-coulomb_pc_gamg_threshold", "0.01", "-coulomb_ksp_rtoll",
      "1"], "-coulomb_ksp_rtoll"),
    (["--lev", "2", "--load-scale", "0", "--pc", "gamg", "-coulomb_mg_levels_pc_type", "jacobi"], None),
])
def test_command_names_each_unread_option_once(args, unread, mpi_tmp_path, capsys):
    """The options the command's own check read on its trial KSP (ILU, the ranges) still count as unread when no
    solver reads them; nested iteration's coarse levels leave the warning to the command (one line, none in the
    API's words); under zero load, which solves nothing, nothing is named."""
    assert main([*args, "--out", str(mpi_tmp_path / "o"), "--quiet", "--no-plots"]) == 0
    lines = _unread_lines(capsys.readouterr().err)
    if MPI.COMM_WORLD.rank != 0 or unread is None:
        assert lines == []
    else:
        assert len(lines) == 1 and lines[0].startswith("PETSc options not read by any solver object"), lines
        assert lines[0].split(": ", 1)[1].split(" — ")[0] == unread


@pytest.mark.serial
def test_command_counts_options_only_a_coarse_level_reads_or_only_the_fine_one(mpi_tmp_path, capsys):
    """lev 7 with the defaults: nested iteration's coarse level (lev 5) runs ILU and the fine level GAMG: the GAMG
    options the fine level read, and the ILU option only the coarse level read, are not named."""
    assert main(["--lev", "7", "--out", str(mpi_tmp_path / "o"), "--quiet", "--no-plots", "-coulomb_pc_gamg_threshold",
                 "0.01", "-coulomb_pc_factor_levels", "1"]) == 0
    assert _unread_lines(capsys.readouterr().err) == []
    summary = json.loads((mpi_tmp_path / "o" / "summary.json").read_text())
    assert summary["preconditioner"] == "gamg" and summary["nested"]["levels"] == [5]


def test_factor_options_on_several_ranks_point_to_block_jacobi(mpi_tmp_path, capsys):
    """ILU on several ranks runs inside block Jacobi, which reads its options as sub_pc_factor_*: an unread
    -coulomb_pc_factor_levels says so there (on one rank ILU reads it, and nothing is named)."""
    pc = "ilu" if MPI.COMM_WORLD.size == 1 else "bjacobi"
    assert main(["--lev", "1", "--pc", "ilu", "--out", str(mpi_tmp_path / "o"), "--quiet", "--no-plots",
                 "-coulomb_pc_factor_levels", "1"]) == 0
    lines = _unread_lines(capsys.readouterr().err)
    if MPI.COMM_WORLD.rank != 0 or pc == "ilu":
        assert lines == []
    else:
        assert len(lines) == 1 and "-coulomb_pc_factor_levels" in lines[0] and "prefix sub_" in lines[0]
