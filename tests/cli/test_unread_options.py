"""PETSc options that no object of the solver reads are reported, not ignored silently.

A misspelt option (``ksp_rtoll``) or one of another preconditioner than the one in use (``pc_gamg_threshold`` with
ILU) used to be dropped without a word: ``petsc_options`` are scoped to the solver's calls and the command's
``-coulomb_*`` options removed when it ends, which also silences PETSc's own ``-options_left`` report. PETSc's "used"
flag of its options database (``PetscOptionsUsed``) tells which were read.
"""

from __future__ import annotations

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


def _pressed_block(comm: MPI.Comm):
    """A unit block pressed onto the plane x3 = 0 by a body force (a, L, bcs, contact)."""
    msh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.ones(3)], [3, 3, 3], dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = ufl.inner(ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))) * ufl.dx
    L = ufl.inner(ufl.as_vector((0.0, 0.0, -0.01)), v) * ufl.dx
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
