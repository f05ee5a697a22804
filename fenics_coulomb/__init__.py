"""fenics-coulomb: 3D Coulomb-friction contact of elastic bodies with rigid obstacles and with each other (quasi-static
load paths), by the SCD semismooth* Newton method.

The Python API: :class:`ContactProblem` (solve, report, checks), the obstacles :class:`Plane`, :class:`Sphere`,
:class:`Cylinder`, :class:`ContactPair` for two bodies, :class:`SolverSettings`, the results
(:class:`SolveResult`, :class:`ContactReport`, :class:`ContactState`), :func:`write_results` (the command
line's result set), :class:`XDMFTimeSeries` with :func:`contact_functions` (one grid per step), and the mesh
helpers :func:`read_gmsh` / :func:`box_partitioner` / :func:`create_partitioner` (deterministic partitions:
the same bits on a rerun). The module map and the flow of one solve are in docs/architecture.md.

Importing the package loads no scipy: the pairing, the mortar segmentation, surface obstacles and the two-body
coupling import ``scipy.spatial``, ``scipy.ndimage`` and ``scipy.sparse`` inside the functions that use them,
since every command and every rank of a launch pays the import (0.66 s instead of 0.83 s with scipy;
tests/model/test_imports.py keeps it so).
"""

from fenics_coulomb.errors import InputError, SolverError
from fenics_coulomb.model.obstacles import Cylinder, Plane, Sphere
from fenics_coulomb.model.surface import Surface
from fenics_coulomb.model.pairs import ContactPair
from fenics_coulomb.problem import ContactProblem
from fenics_coulomb.scd.records import IterationRecord, SolveResult
from fenics_coulomb.report import ContactNodes, ContactReport
from fenics_coulomb.scd.resolvent import ContactState
from fenics_coulomb.scenes.partition import box_partitioner, create_partitioner
from fenics_coulomb.scenes.meshes import read_gmsh
from fenics_coulomb.io.fields import CONTACT_STATES, contact_functions
from fenics_coulomb.io.xdmf import XDMFTimeSeries
from fenics_coulomb.settings import SolverSettings
from fenics_coulomb.io.writer import write_results

__version__ = "0.1.0"

__all__ = ["CONTACT_STATES", "ContactNodes", "ContactPair", "ContactProblem", "ContactReport", "ContactState",
           "Cylinder", "InputError", "IterationRecord", "Plane", "SolveResult", "SolverError", "SolverSettings",
           "Sphere", "Surface", "XDMFTimeSeries", "__version__", "box_partitioner", "contact_functions",
           "create_partitioner", "read_gmsh", "write_results"]
