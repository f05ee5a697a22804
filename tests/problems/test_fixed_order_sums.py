"""Three ranks, vertices shared by three of them: the stiffness matrix, the pairs' triple product and a contact
solve give the same bits every time (fenics_coulomb/model/reproducible.py; tests/problems/fixed_order_sums.py).

PETSc's own assembly and default triple product sum such an entry in message-arrival order: in the script's six
repeats they gave 3 and 4 different value arrays when measured (printed, not asserted: it depends on timing).
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from launching import ROOT, command_env


@pytest.mark.serial  # starts its own 3-rank job
@pytest.mark.multirank
def test_three_ranks_sum_in_a_fixed_order() -> None:
    cmd = ["mpirun", "--oversubscribe", "-n", "3", sys.executable,
           str(ROOT / "tests" / "problems" / "fixed_order_sums.py")]
    run = subprocess.run(cmd, capture_output=True, text=True, env=command_env(display=False), timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    lines = {line.split()[0]: line.split()[1:] for line in run.stdout.splitlines() if line.strip()}
    print(run.stdout)
    assert lines["matrix"][:2] == ["1", "6"], "the stiffness matrix differs between repeated assemblies"
    assert float(lines["matrix"][3]) <= 1e-14, "the matrix is not PETSc's assembly up to the order of its sums"
    assert lines["ptap"] == ["1", "12"], "the triple product differs between repeats (new or in place)"
    assert lines["solve"] == ["1", "2"], "two solves of one problem differ"
    assert float(lines["bc-matrix"][0]) <= 1e-14, "Dirichlet rows (ghosted cells, V.sub) differ from PETSc's"
