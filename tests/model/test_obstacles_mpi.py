"""The collective overlap check (issue 13) on 1 and 2 ranks: every rank raises the same one-line message, naming
the deepest node over all ranks, before any solve."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.obstacle_checks import check_not_overlapping
from fenics_coulomb.model.obstacles import DEFAULT_PLANE, Sphere


def test_overlap_message_names_the_deepest_node_on_every_rank():
    comm = MPI.COMM_WORLD
    rank, size = comm.rank, comm.size
    # each rank owns a few bottom nodes; the deepest overlap of the ball sits on the last rank
    x = np.array([[0.1 * rank, 0.0, 0.05], [0.5, 0.5, 0.05 - 0.01 * (rank + 1)]])
    ball = Sphere(center=[0.5, 0.5, -0.5], radius=0.545, name="ball")  # top at x3 = 0.045
    depth = 0.045 - (0.05 - 0.01 * size)
    deepest = f"node (0.5, 0.5, {0.05 - 0.01 * size:.6g}) lies {depth:.6g} inside"
    with pytest.raises(InputError) as err:
        check_not_overlapping([DEFAULT_PLANE, ball.moved([0, 0, 0.04])], x, comm=comm)
    msg = str(err.value)
    assert "ball" in msg and deepest in msg and "\n" not in msg, msg
    assert comm.allgather(msg) == [msg] * size
    # a rank without nodes takes part; no overlap at all raises nothing anywhere
    check_not_overlapping([DEFAULT_PLANE], x if rank == 0 else np.zeros((0, 3)), comm=comm)
    with pytest.raises(InputError, match="ball"):
        check_not_overlapping([ball], x if rank == size - 1 else np.zeros((0, 3)), comm=comm)
