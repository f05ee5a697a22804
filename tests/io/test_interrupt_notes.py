"""What an interrupted load path's line says (runner._interrupted_note), and one output directory on every rank
(a symlinked --out resolved alike: the kept set lands where the line says, whichever rank is interrupted)."""

from __future__ import annotations

import os
from types import SimpleNamespace

from mpi4py import MPI

import pytest

from fenics_coulomb.io.results import ResultDirectory
from fenics_coulomb.runner import _interrupted_note


def _solve(step: int, substep: int = 1, substeps: int = 1) -> SimpleNamespace:
    return SimpleNamespace(step=step, substep=substep, substeps=substeps)


@pytest.mark.parametrize("solves, last, start_step, resume", [
    (3, _solve(3), None, "--start 'k dir'/solution.xdmf --start-step 3"),  # after whole step 3 of 6
    (5, _solve(2, 2, 4), None, "--start 'k dir'/solution.xdmf --start-step 1"),  # within step 2: step 1 is whole
    (1, _solve(1, 1, 4), None, ""),  # within the first step: nothing whole to resume from
    (2, _solve(2, 2, 4), 1, "--start 'a b/solution.xdmf' --start-step 1"),  # a resume within its first step
    (6, _solve(3, 2, 4), 1, "--start 'k dir'/solution.xdmf --start-step 2"),  # a resume past its first step
])
def test_the_resume_options_name_a_whole_step_that_exists(solves, last, start_step, resume):
    note = _interrupted_note(solves, last, 6, start_step, "a b/solution.xdmf")("'k dir'")
    assert note.startswith(f"the {solves} completed solve(s) of the path are kept in 'k dir'")
    assert note.endswith(f" (resume: {resume})" if resume else "'k dir'")


def test_a_symlinked_output_directory_is_the_same_on_every_rank(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    real, link = mpi_tmp_path / "real" / "results", mpi_tmp_path / "link"
    if comm.rank == 0:
        real.mkdir(parents=True)
        os.symlink(real, link)
    comm.barrier()
    out = ResultDirectory(comm, link)
    assert all(p == real.resolve() for p in comm.allgather(out.path))
