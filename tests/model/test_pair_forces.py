"""Per-pair forces with a master surface shared by two pairs: three bodies (1 and 2 ranks).

Two upper blocks side by side, each its own slave surface, both pressed (and dragged) onto ONE lower block whose
top is the master surface of both pairs; the upper blocks' bottoms lie over master facets that share the master
nodes on the line x1 = 1, so those nodes are in both pairs' stencils. Each pair's force on the master body comes
from its own stencil (f_l = −Σ_{j in pair} Φ_jl f_j), so it is minus the pair's force on its slave body; the
two pairs' master forces add up to what the lower block's support carries; and each pair's slave force is what
its upper block's support carries. The supports' reactions come from an assembly of our own
(tests/model/reaction_reference.py).
"""

from __future__ import annotations


from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
from reaction_reference import assembled_reactions, held_dofs
from test_support_reactions import lame

from fenics_coulomb import ContactPair, ContactProblem

from meshes.two_blocks import boxes_mesh  # noqa: E402

GAP, HEIGHT = 1e-3, 0.5
#: Facet tags: the lower block's top, bottom and sides; each upper block's bottom (slave), top and sides.
LOWER_TOP, LOWER_BOTTOM, SIDES = 1, 2, 3
UPPER = {"left": (4, 5), "right": (6, 7)}  # (bottom, top)
#: (origin, size) of the upper blocks: their bottoms end 0.05 on either side of the master grid line x1 = 1.
BOXES = {"left": ((0.2, 0.2), (0.75, 0.6)), "right": ((1.05, 0.2), (0.75, 0.6))}


def three_blocks(comm: MPI.Comm):
    """The lower block [0, 2] × [0, 1] × [−1, 0] (4 × 2 × 2 hexahedra: master grid lines every 0.5) and the two
    upper blocks (3 × 3 × 2 each) at height GAP; the mesh and its facet tags."""
    boxes = [((0.0, 0.0, -1.0), (2.0, 1.0, 1.0), (4, 2, 2))]
    boxes += [((*BOXES[k][0], GAP), (*BOXES[k][1], HEIGHT), (3, 3, 2)) for k in ("left", "right")]
    msh, cell_tags = boxes_mesh(comm, boxes)
    msh.topology.create_connectivity(2, 3)
    facets = dolfinx.mesh.exterior_facet_indices(msh.topology)
    f2c = msh.topology.connectivity(2, 3)
    body = cell_tags.values[f2c.array[f2c.offsets[facets]]]
    z = dolfinx.mesh.compute_midpoints(msh, 2, facets)[:, 2]
    values = np.full(facets.size, SIDES, dtype=np.int32)
    values[(body == 1) & np.isclose(z, 0.0)] = LOWER_TOP
    values[(body == 1) & np.isclose(z, -1.0)] = LOWER_BOTTOM
    for b, (bottom, top) in zip((2, 3), UPPER.values(), strict=True):
        values[(body == b) & np.isclose(z, GAP)] = bottom
        values[(body == b) & np.isclose(z, GAP + HEIGHT)] = top
    order = np.argsort(facets)
    return msh, dolfinx.mesh.meshtags(msh, 2, facets[order], values[order])


@pytest.mark.parametrize("method", ["mortar", "node-to-surface"])
def test_two_pairs_on_one_master(method):
    comm = MPI.COMM_WORLD
    msh, ft = three_blocks(comm)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    a = lame(V, 70.0, 0.3)
    blocks = {"lower": dolfinx.fem.locate_dofs_topological(V, 2, ft.find(LOWER_BOTTOM))}
    blocks |= {k: dolfinx.fem.locate_dofs_topological(V, 2, ft.find(top)) for k, (_, top) in UPPER.items()}
    moves = {"lower": [0.0, 0.0, 0.0], "left": [0.0015, 0.0, -0.004], "right": [-0.001, 0.0005, -0.006]}
    bcs = {k: dolfinx.fem.dirichletbc(np.array(moves[k]), blocks[k], V) for k in moves}
    pairs = [ContactPair(ft, slave=UPPER[k][0], master=LOWER_TOP, friction=0.3, method=method, name=k)
             for k in ("left", "right")]
    with ContactProblem(a, None, list(bcs.values()), contact_pairs=pairs, settings={"rtol": 1e-11},
                        petsc_options_prefix="three_") as problem:
        _, result = problem.solve()
        assert result.converged
        report = problem.report(result, reactions=bcs)
        pairing = problem.model.pairing
        # the master nodes both pairs' stencils use (global blocks)
        mine = [(pairing.pair_index == k)[:, None] & (pairing.weights != 0) for k in (0, 1)]
        used = [np.concatenate(comm.allgather(np.unique(pairing.master_blocks[m]))) for m in mine]
        ours = assembled_reactions(a, None, result.displacement, {k: held_dofs(V, b) for k, b in blocks.items()},
                                   comm)
    shared = np.intersect1d(used[0], used[1])
    assert shared[shared >= 0].size > 0  # the pairs share master nodes
    forces = {f["name"]: f for f in report.pair_forces}
    slave = {k: np.array(forces[k]["force_on_slave_body"]) for k in ("left", "right")}
    master = {k: np.array(forces[k]["force_on_master_body"]) for k in ("left", "right")}
    scale = max(np.linalg.norm(v) for v in slave.values())
    for k in ("left", "right"):
        assert slave[k][2] > 0, k  # each upper block is pushed up by the lower one
        assert np.linalg.norm(master[k] + slave[k]) <= 1e-8 * scale, (k, master[k], slave[k])
        assert forces[k]["slave_equilibrium"] < 1e-8, k  # the upper block's own residual agrees
        # the upper block's support carries its pair's force (no load on it)
        assert np.allclose(report.reactions[k], ours[k], rtol=0, atol=1e-10 * scale), k
        assert np.linalg.norm(slave[k] + ours[k]) <= 1e-8 * scale, k
    # the lower block's support carries both pairs' master forces
    assert np.allclose(report.reactions["lower"], ours["lower"], rtol=0, atol=1e-10 * scale)
    assert np.linalg.norm(master["left"] + master["right"] + ours["lower"]) <= 1e-8 * scale
