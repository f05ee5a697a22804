"""MPI-safe pytest fixtures: run serially or as ``mpirun -n 2 python3 -m mpi4py -m pytest``."""

from __future__ import annotations

import gc
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from mpi4py import MPI

import pytest

from fenics_coulomb.model import ContactModel, Material
from fenics_coulomb.scene import create_cuboid, paper_tractions


@pytest.fixture(autouse=True)
def _collective_cleanup() -> Iterator[None]:
    """Collect garbage and synchronize after each test, so collective PETSc destructors run in step."""
    yield
    gc.collect()
    MPI.COMM_WORLD.barrier()


@pytest.fixture
def mpi_tmp_path() -> Iterator[Path]:
    """A temporary directory shared by all ranks (created on rank 0 and broadcast)."""
    comm = MPI.COMM_WORLD
    path = tempfile.mkdtemp(prefix="fenics-coulomb-") if comm.rank == 0 else None
    path = comm.bcast(path, root=0)
    yield Path(path)
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


def make_model(
    lev: int = 1,
    gap: str = "d3",
    load: str = "L2",
    friction: float = 0.23,
    comm: MPI.Comm = MPI.COMM_WORLD,
    scale: float = 1.0,
    material: Material | None = None,
) -> ContactModel:
    """A Section 7 scene as a ContactModel."""
    body = create_cuboid(comm, lev, gap)
    return ContactModel(body, material or Material(), friction, paper_tractions(load, scale))


@pytest.fixture
def model_factory() -> Iterator:
    """Build models and destroy them after the test."""
    created: list[ContactModel] = []

    def factory(*args, **kwargs) -> ContactModel:
        m = make_model(*args, **kwargs)
        created.append(m)
        return m

    yield factory
    for m in created:
        m.destroy()
