"""The two-body contact patch test of benchmarks/two_body_patch.py (issue 18), coarse, on 1 and 2 ranks.

Uniform pressure through the interface of two blocks of equal footprint: matching meshes and a slave mesh
nested in the master mesh transmit it exactly (round-off); non-matching meshes do not (node-to-surface
contact fails the patch test), but the total force stays close and the solution obeys the physics and the
force balance of the two bodies."""

from __future__ import annotations

import sys
from pathlib import Path

from mpi4py import MPI

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from two_body_patch import run  # noqa: E402


@pytest.mark.parametrize(("cell", "n_lower", "n_upper", "exact"), [
    ("hexahedron", (2, 2, 1), (2, 2, 1), True),
    ("tetrahedron", (2, 2, 1), (2, 2, 1), True),
    ("hexahedron", (2, 2, 1), (4, 4, 1), True),    # nested: slave nodes at master vertices, edge midpoints, centres
    ("hexahedron", (3, 3, 1), (4, 4, 1), False),
])
def test_patch(cell, n_lower, n_upper, exact):
    row = run(MPI.COMM_WORLD, cell, n_lower, n_upper)
    assert row["converged"] and row["checks"] < 1e-10
    assert row["contact_nodes"] == (n_upper[0] + 1) * (n_upper[1] + 1)
    if exact:
        assert row["max_pressure_error"] < 1e-10 and abs(row["force_error"]) < 1e-10 and row["balance"] < 1e-10
    else:
        assert row["max_pressure_error"] > 1e-3  # not passed: reported in docs/two-bodies/patch.md
        assert abs(row["force_error"]) < 0.05 and row["balance"] < 1e-10
