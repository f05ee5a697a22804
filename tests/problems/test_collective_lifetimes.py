"""PETSc objects whose destruction the garbage collector times must not desynchronize the ranks.

A Function's cached PETSc vector (``u.x.petsc_vec``) is destroyed when Python frees the Function, which the
cyclic collector does at a different moment on each rank. When it is the last PETSc object on its
communicator, PETSc frees its inner communicator on that rank only, and the next vector created on the same
function space duplicates the communicator on one rank while the others enter the vector's own collectives: a
deadlock with every rank spinning (fenics_coulomb/model/dof_values.py). The package never creates such a
vector; these tests hold it to that on the workflow a user runs, and run the deadlock's recipe end to end.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import dolfinx.la
import dolfinx.mesh
import pytest
from launching import ROOT, command_env
from uneven_collection import press


def test_no_function_of_a_solve_creates_a_petsc_vector(mpi_tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Solve, report, physics checks and a written result set never ask a DOLFINx vector for its PETSc vector
    (every ``x.petsc_vec`` access is counted)."""
    created: list[int] = []
    original = dolfinx.la.Vector.petsc_vec

    def counted(vector: dolfinx.la.Vector):  # type: ignore[no-untyped-def]
        created.append(1)
        return original.fget(vector)

    monkeypatch.setattr(dolfinx.la.Vector, "petsc_vec", property(counted))
    msh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [[0, 0, 0], [1, 1, 0.5]], [4, 4, 2],
                                  dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    uh, report = press(V, 0.01, str(mpi_tmp_path / "press"))
    assert (mpi_tmp_path / "press" / "summary.json").exists()
    assert report.obstacle_forces["ball"][2] < 0.0  # the ball pushes the block down
    assert MPI.COMM_WORLD.allreduce(len(created)) == 0
    _ = uh.x.petsc_vec  # the counter sees an access (the test can fail)
    assert len(created) == 1
    uh.x.petsc_vec.destroy()  # at a point every rank reaches


@pytest.mark.serial
@pytest.mark.multirank
def test_results_freed_unevenly_do_not_deadlock_the_next_solve(tmp_path: Path) -> None:
    """Two problems on one function space on 2 ranks, the first one's results freed by the collector on rank 0
    only (tests/problems/uneven_collection.py): the second solve completes."""
    cmd = ["mpirun", "-n", "2", sys.executable, str(ROOT / "tests" / "problems" / "uneven_collection.py"),
           str(tmp_path / "first")]
    try:
        run = subprocess.run(cmd, capture_output=True, text=True, env=command_env(display=False), timeout=240)
    except subprocess.TimeoutExpired:
        pytest.fail("the second solve deadlocked after the first one's results were freed on rank 0 only")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "second solve: ball force" in run.stdout
