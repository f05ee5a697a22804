"""Small sliding says when it breaks (model/small_sliding.py): a contact node's slide against the master material
point beneath it, in units of THAT MASTER FACET's size — not the slave node's own cells (a coarse slave over a fine
master slid most of a master facet and was not warned: its slide was divided by the slave's larger cells)."""

from __future__ import annotations

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem
from fenics_coulomb.model.pairs import ContactPair
from fenics_coulomb.model.small_sliding import SMALL_SLIDE_WARNING

from meshes.two_blocks import TAGS, two_blocks

MASTER, SLAVE, LOWER_BOTTOM, UPPER_TOP = (TAGS[k] for k in ("lower_top", "upper_bottom", "lower_bottom", "upper_top"))


@pytest.mark.parametrize("method", ["node-to-surface", "mortar"])
def test_the_slide_is_measured_in_the_master_facets_size(method):
    comm = MPI.COMM_WORLD
    blocks = two_blocks(comm, lower=(1.0, 1.0, 0.5), n_lower=(8, 8, 2), upper_origin=(0.25, 0.25),
                        upper=(0.5, 0.5, 0.25), n_upper=(2, 2, 1), gap=1e-3)
    msh, ft = blocks.mesh, blocks.facet_tags
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    E, nu = 70.0, 0.3
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = ufl.sym(ufl.grad(u))
    a = ufl.inner(2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(3), ufl.sym(ufl.grad(v))) * ufl.dx
    slide = 0.1
    bcs = [dolfinx.fem.dirichletbc(np.array([slide, 0.0, -0.011]),
                                   dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_TOP)), V),
           dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM)), V)]
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, method=method)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], sliding="small",
                        petsc_options_prefix="small_slide_") as problem:
        uh, result = problem.solve()
        # independently: every slave node's displacement against the lower top's beneath its reference position
        # (the reference frames: the tangential part is (x1, x2)), over a master facet's diameter (8 × 8 cells of
        # 0.125: the Q1 facet's diagonal)
        x = V.tabulate_dof_coordinates()
        owned = V.dofmap.index_map.size_local
        slave = dolfinx.fem.locate_dofs_topological(V, 2, ft.find(SLAVE))
        slave = slave[slave < owned]
        below = x[slave].copy()
        below[:, 2] = -1e-12  # just inside the lower block's top cells
        tree = dolfinx.geometry.bb_tree(msh, 3)
        cells = dolfinx.geometry.compute_colliding_cells(msh, dolfinx.geometry.compute_collisions_points(
            tree, below), below)
        lower_cells = blocks.cell_tags.find(1)
        values = np.full((slave.size, 3), np.nan)
        for i in range(slave.size):  # a handful of nodes: one point evaluation each
            mine = np.intersect1d(cells.links(i), lower_cells)
            if mine.size:
                values[i] = uh.eval(below[i:i + 1], mine[:1])
    h_master = np.hypot(0.125, 0.125)
    relative = uh.x.array.reshape(-1, 3)[slave] - values
    local = float(np.nanmax(np.hypot(relative[:, 0], relative[:, 1]), initial=0.0)) / h_master
    expected = comm.allreduce(local, op=MPI.MAX)
    measured = result.largest_slide["slide_per_size"]
    assert expected > SMALL_SLIDE_WARNING  # the slide is most of a master facet: warned
    # node-to-surface's partner is the master point itself; mortar's w uses its weights Φ_jl over the node's
    # support, a weighted mean of the master displacement there (2e-4 from the point value on this mesh)
    assert measured == pytest.approx(expected, rel=1e-6 if method == "node-to-surface" else 1e-3)
