"""fenics-coulomb: 3D Coulomb-friction contact of elastic bodies with rigid obstacles and with each other (quasi-static
load paths), by the SCD semismooth* Newton method.

The Python API is :class:`ContactProblem` (``from fenics_coulomb import ContactProblem``); the module map
and the flow of one solve are in docs/architecture.md.
"""

from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.model.obstacles import Cylinder, Plane, Sphere
from fenics_coulomb.model.pairing import ContactPair
from fenics_coulomb.problem import ContactProblem
from fenics_coulomb.scd.records import IterationRecord, SolveResult
from fenics_coulomb.settings import SolverSettings

__version__ = "0.1.0"

__all__ = ["ContactPair", "ContactProblem", "Cylinder", "InputError", "IterationRecord", "Plane", "SolveResult", "SolverError",
           "SolverSettings", "Sphere", "__version__"]
