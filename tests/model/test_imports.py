"""Importing the package and its command line loads no scipy, nor does a one-body solve of the command
(fenics_coulomb/__init__.py: every command and every rank of a launch pays the import)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import sys
{code}
loaded = sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy."))
print("scipy modules:", len(loaded), loaded[:3])
"""

ONE_BODY = """
import runpy
sys.argv = ["fenics_coulomb", "--lev", "1", "--no-plots", "--quiet", "--out", {out!r}]
try:
    runpy.run_module("fenics_coulomb", run_name="__main__")
except SystemExit as stop:
    assert stop.code in (0, None), stop.code
"""

PAIRING = """
import numpy as np
from fenics_coulomb.model.pairs.projection import Surface, project
X = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
project(np.full((1, 3), 0.25), Surface(X, np.array([[0, 1, 2]]), np.ones(1)), np.ones(1), np.zeros(1, np.intp))
"""


def scipy_modules(code: str) -> int:
    """The number of scipy modules loaded after running ``code`` in a fresh interpreter."""
    proc = subprocess.run([sys.executable, "-c", PROBE.format(code=code)], capture_output=True, text=True, cwd=ROOT,
                          timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    line = [text for text in proc.stdout.splitlines() if text.startswith("scipy modules:")][-1]
    return int(line.split()[2])


@pytest.mark.serial  # starts its own interpreter
@pytest.mark.parametrize("module", ["fenics_coulomb", "fenics_coulomb.cli", "fenics_coulomb.runner"])
def test_import_loads_no_scipy(module):
    assert scipy_modules(f"import {module}") == 0


@pytest.mark.serial  # starts its own interpreter
def test_a_one_body_solve_loads_no_scipy(tmp_path):
    assert scipy_modules(ONE_BODY.format(out=str(tmp_path / "out"))) == 0
    assert (tmp_path / "out" / "summary.json").is_file()


@pytest.mark.serial  # starts its own interpreter
def test_the_probe_sees_scipy_where_it_is_used():
    """The control: a node-to-facet projection (a KD-tree) loads scipy, so the tests above can fail."""
    assert scipy_modules(PAIRING) > 0
