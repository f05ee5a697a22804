"""``python3 -m fenics_coulomb``: see :mod:`fenics_coulomb.cli`."""

import sys

from fenics_coulomb.cli import main

sys.exit(main())
