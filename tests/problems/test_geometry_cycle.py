"""A geometry iteration caught in a 2-cycle wider than the accepted one (docs/sliding, "Not done yet": a slave over a
master corner on tetrahedra): node-to-surface's constraint normal jumps where a slave node's closest point crosses a
crease of the deformed master, and 7 slave nodes over the master's Kuhn diagonal swap sides of it at every update.
The solve fails as soon as the same cycle comes back without shrinking, saying what it is and what settles it;
mortar settles on the same mesh."""

from __future__ import annotations

import re

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem
from fenics_coulomb.errors import SolverError
from fenics_coulomb.model.pairs import ContactPair
from fenics_coulomb.model.sliding import MAX_GEOMETRY_UPDATES

from meshes.two_blocks import TAGS, two_blocks

MASTER, SLAVE, LOWER_BOTTOM, UPPER_TOP = (TAGS[k] for k in ("lower_top", "upper_bottom", "lower_bottom", "upper_top"))


def _corner(method: str) -> ContactProblem:
    """The upper block [0.504, 1.504]² × [0.001, 0.501] (stiff) over the corner of the soft lower block
    [0, 1]² × [−1, 0] (its top bulges at the upper block's edges), the upper top pressed 0.03."""
    blocks = two_blocks(MPI.COMM_WORLD, lower=(1.0, 1.0, 1.0), n_lower=(6, 6, 3), upper_origin=(0.504, 0.504),
                        upper=(1.0, 1.0, 0.5), n_upper=(10, 10, 2), gap=1e-3, cell_type="tetrahedron")
    msh, ft = blocks.mesh, blocks.facet_tags
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    above = ufl.SpatialCoordinate(msh)[2] > 0.0
    E, nu = ufl.conditional(above, 200.0, 10.0), ufl.conditional(above, 0.3, 0.45)
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = ufl.sym(ufl.grad(u))
    a = ufl.inner(2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(3), ufl.sym(ufl.grad(v))) * ufl.dx
    bcs = [dolfinx.fem.dirichletbc(np.array([0.0, 0.0, -0.03]), dolfinx.fem.locate_dofs_topological(
               V, 2, ft.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)]
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, method=method)
    return ContactProblem(a, None, bcs, contact_pairs=[pair], petsc_options_prefix="cycle_", sliding="finite")


def test_a_wide_two_cycle_fails_at_once_and_names_what_settles_it():
    with _corner("node-to-surface") as problem:
        with pytest.raises(SolverError) as failed:
            problem.solve()
    message = str(failed.value)
    assert failed.value.reason == "geometry"
    assert "back and forth between two geometries" in message and "method = 'mortar'" in message
    updates = int(message.split("did not settle after ")[1].split(" updates")[0])
    assert updates < MAX_GEOMETRY_UPDATES  # the cycle seen twice, not run to the limit
    # the amplitude named lies beyond the accepted fraction of a cell
    found = re.search(r"differ by (\S+) \((\S+) of the smallest cell at the contact nodes, (\S+) accepted\)", message)
    assert found is not None
    assert float(found[2]) > float(found[3]) and float(found[1]) > 0.0


def test_mortar_settles_over_the_same_corner():
    with _corner("mortar") as problem:
        _, result = problem.solve()
        assert result.converged
        assert 0 < result.geometry_updates < MAX_GEOMETRY_UPDATES
