"""``python3 -m fenics_coulomb``: see :mod:`fenics_coulomb.cli`."""

import sys

from fenics_coulomb.cli import run_command

sys.exit(run_command())
