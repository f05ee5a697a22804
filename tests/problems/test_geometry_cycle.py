"""Geometry 2-cycles of node-to-surface (docs/sliding, "Not done yet" and "Where we deviate"): where a slave node's
closest point crosses a crease of the deformed master, either facet's normal pushes it across to the other, and
the issue's definitions have no fixed point. The nodes of such a cycle now tie their closest points across the
edge within 4 × the cycle's amplitude (the tied facets' mean normal), once per solve, which settles the cycles the
acceptance replay found (a slave node beside the lower block's edge after a slide; a slave over a soft master's
corner on tetrahedra, 7 nodes over the master's Kuhn diagonal): there the state no longer depends on the path,
the rank count or the partition. Only a cycle between two full-accuracy solves ties (a loose solve's may be its
error). A cycle that cannot be tied and is wider than the accepted one fails as soon as it comes back unshrunk,
naming its amplitude and the cure."""

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


def _mirror_pair(ends: tuple[float, float], method: str, friction: float, rtol: float,
                 upper_y: tuple[float, float] = (0.25, 0.75)) -> list[dict]:
    """The coarse hexahedral blocks of benchmarks/slide_matrix.py with the upper block at x1 ∈ [x0, x0 + 1] for
    both mirror-image ``ends`` (about x1 = 1), pressed: both runs, each converged within the update limit with
    every one of its 40 slave nodes in contact, and the second's force the mirror image of the first's (1e-6)."""
    from benchmarks.slide_matrix import Blocks

    runs = []
    for x0 in ends:
        blocks = Blocks(MPI.COMM_WORLD, "hexahedron", (10, 5, 3), (7, 4, 3), x0, method,
                        f"mirror_{method[:4]}_{x0:g}_", friction=friction, rtol=rtol, upper_y=upper_y)
        with blocks.problem:
            runs.append(blocks.solve(0.0))
    assert all(r["converged"] and r["updates"] < MAX_GEOMETRY_UPDATES for r in runs)
    assert len(runs[0]["nodes"]) == len(runs[1]["nodes"]) == 40
    mirror = runs[1]["force"] * np.array([-1.0, 1.0, 1.0])
    assert np.abs(runs[0]["force"] - mirror).max() <= 1e-6 * np.linalg.norm(runs[0]["force"])
    return runs


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


def test_a_wide_two_cycle_fails_at_once_and_names_what_settles_it(monkeypatch):
    """A coupling that cannot tie the cycle's nodes (as mortar's coverage cycles): the corner's 1e-4 cycle."""
    with _corner("node-to-surface") as problem:
        monkeypatch.setattr(problem.model.coupling, "tie", lambda *args: False)
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


def test_a_crease_cycle_is_tied_and_the_symmetric_corner_settles_symmetric():
    """The corner scene is symmetric about the plane x1 = x2 (both blocks, the press, the meshes' diagonals): the
    slave nodes on it swapped sides of the master's diagonal crease by 1e-4 at every update; tied, they settle on
    it."""
    with _corner("node-to-surface") as problem:
        uh, result = problem.solve()
        assert result.converged
        V = problem.V
        owned = V.dofmap.index_map.size_local
        x = V.tabulate_dof_coordinates()[:owned] + uh.x.array.reshape(-1, 3)[:owned]
        X = V.tabulate_dof_coordinates()[:owned]
        diagonal = (np.abs(X[:, 0] - X[:, 1]) < 1e-9) & (np.abs(X[:, 2] - 1e-3) < 1e-9) & (X[:, 0] < 1.0)
        off = MPI.COMM_WORLD.allreduce(float(np.max(np.abs(x[diagonal, 0] - x[diagonal, 1]), initial=0.0)), op=MPI.MAX)
        count = MPI.COMM_WORLD.allreduce(int(np.sum(diagonal)), op=MPI.SUM)
    assert count >= 5
    assert off < 1e-5  # the cycle's states lay 1e-4 off it, on either side


def test_mortar_settles_over_the_same_corner():
    with _corner("mortar") as problem:
        _, result = problem.solve()
        assert result.converged
        assert 0 < result.geometry_updates < MAX_GEOMETRY_UPDATES


def test_a_slide_in_one_solve_equals_the_static_press_through_a_tied_cycle():
    """The acceptance replay's case (benchmarks/slide_matrix.py, tetrahedra 24 × 12 × 4 / 13 × 7 × 3,
    node-to-surface): the block slid 0.8 in one static solve ended in one state of a 2-cycle at a slave node beside
    the lower block's edge, the static press of the translated mesh in the other — 3.3e-4 of the normal force and
    3.8e-3 of |u| apart (and 1 rank ≠ 2 ranks by as much); tied, they agree to the solve's accuracy. The issue's
    bound is 1e-6."""
    from benchmarks.slide_matrix import SLIDE, Blocks

    comm = MPI.COMM_WORLD
    runs, states = [], []
    for x0, slide in ((0.5, SLIDE), (0.5 + SLIDE, 0.0)):
        blocks = Blocks(comm, "tetrahedron", (24, 12, 4), (13, 7, 3), x0, "node-to-surface", f"cycle_{x0:g}_")
        with blocks.problem:
            runs.append(blocks.solve(slide))
            states.append(blocks.state(slide))
    assert all(r["converged"] for r in runs)
    assert {(round(x + SLIDE, 9), y, z) for x, y, z in runs[0]["nodes"]} == runs[1]["nodes"]
    assert np.allclose(states[0][:, :3], states[1][:, :3], atol=1e-9)
    scale = np.abs(states[1][:, 3:]).max()
    assert np.abs(states[0][:, 3:] - states[1][:, 3:]).max() <= 1e-6 * scale
    assert np.abs(runs[0]["force"] - runs[1]["force"]).max() <= 1e-6 * np.linalg.norm(runs[1]["force"])


def test_a_cycle_seen_at_a_loose_solve_is_not_tied():
    """Hexahedra, the block slid to x1 ∈ [1.03, 2.03] (a hostile replay of the tie): the loose first solves of the
    one-solve slide and of the static press cycle at a slave node over the master grid line x1 = 1.6, with other
    amplitudes (1.5e-4, 7.5e-5). Tied there, the two ended 1.25e-4 of |u| apart (F_x 1.4 %); the cycle is the loose
    solves' error, and untied they agree to the solve's accuracy."""
    from benchmarks.slide_matrix import SLIDE, Blocks

    comm = MPI.COMM_WORLD
    runs, states = [], []
    for x0, slide in ((1.03 - SLIDE, SLIDE), (1.03, 0.0)):
        blocks = Blocks(comm, "hexahedron", (10, 5, 3), (7, 4, 3), x0, "node-to-surface", f"loose_{x0:g}_")
        with blocks.problem:
            runs.append(blocks.solve(slide))
            states.append(blocks.state(slide))
    assert all(r["converged"] for r in runs)
    scale = np.abs(states[1][:, 3:]).max()
    assert np.abs(states[0][:, 3:] - states[1][:, 3:]).max() <= 1e-6 * scale
    assert np.abs(runs[0]["force"] - runs[1]["force"]).max() <= 1e-6 * np.linalg.norm(runs[1]["force"])


@pytest.mark.parametrize("method", ["node-to-surface", "mortar"])
def test_a_slave_flush_with_the_master_edge_under_friction_settles_mirror_symmetric(method):
    """Hexahedra, the upper block flush with the lower block's end (x1 ∈ [1, 2], and its mirror image [0, 1]),
    pressed, F = 0.3 (a hostile replay): the slave's edge nodes, pushed out by the blocks' different Poisson
    expansion, cycled between paired (the slip carries them past the master's edge) and free (they drop onto it):
    node-to-surface 1.9e-3 wide, a 2-cycle whose node was GAINED on the way back, so the tie missed it; mortar
    3.3e-3 wide, a 3-cycle through the coverage of the edge facets (exit 3 with 10 updates, both). Now the cycle's
    nodes, gained ones too, decide their geometry within its width — node-to-surface's closest point, mortar's
    coverage — and each scene settles on the mirror image of the other."""
    runs = _mirror_pair((1.0, 0.0), method, 0.3, 1e-10)
    assert runs[0]["nodes"] == {(round(2.0 - x, 9), y, z) for x, y, z in runs[1]["nodes"]}
    # friction carries the blocks' mismatch of expansion
    assert abs(runs[0]["force"][0]) > 0.05 * np.linalg.norm(runs[0]["force"])


def test_nodes_back_and_forth_while_the_rest_settles_are_tied_node_by_node():
    """Hexahedra, the flush end at x1 = 2, node-to-surface, F = 0.8, the default rtol: after the first tie the
    slave's edge nodes, one or two at a time, alternated between two partners while other nodes still changed
    theirs, so the whole geometry never repeated; the tied cycle came back unshrunk and the solve failed after 7
    updates (exit 3). A node back at its partner of two updates before, with another in between, is now a cycle of
    its own, and its nodes are added to the tied ones; the edge's other nodes, unpaired within the tie's width of
    their closest points, are paired (its reach). The mirror scene (x1 = 0) settles on the mirror image."""
    _mirror_pair((1.0, 0.0), "node-to-surface", 0.8, 1e-8)


def test_mortar_flush_sides_keep_the_slave_on_the_master():
    """Hexahedra, the upper block as wide as the lower one (both long sides flush, x2 ∈ [0, 1]) and 0.001 short of
    its end, F = 0.3, dual mortar (a hostile replay): the blocks' different Poisson expansion pushes the slave's
    side facets 1e-3 past the master's sides, whole rows of them turn uncovered, their nodes are freed and come
    back, 28 at a time; the cycles were tied row by row and the solve ran out of its 10 updates (exit 3). Once a
    cycle is tied, every slave facet is credited with the widest tie's border strip (mortar's reach, as
    node-to-surface's pairs the nodes left unpaired within it): all 40 nodes keep resting on the master, and the
    mirror scene (0.001 short of the other end) settles on the mirror image."""
    _mirror_pair((0.999, 0.001), "mortar", 0.3, 1e-8, upper_y=(0.0, 1.0))


def test_a_load_path_keeps_its_ties_from_step_to_step():
    """Hexahedra, mortar, the upper block as wide as the lower one, F = 0.8 (a hostile replay): pressed (its flush
    sides cycle and are tied), then slid 0.05. The slide's solve started untied, and the coverage front crossed the
    block one column of side facets per update, 4 nodes at a time, until the 10 updates ran out (exit 3): no cycle
    to tie. A path step keeps its previous step's ties (the same edges, the same ambiguity): the slide settles with
    every node still resting on the master, and the friction force stays within the cone (|Q| ≤ F·P)."""
    from benchmarks.slide_matrix import Blocks

    blocks = Blocks(MPI.COMM_WORLD, "hexahedron", (10, 5, 3), (7, 4, 3), 0.5, "mortar", "carry_", friction=0.8,
                    rtol=1e-8, upper_y=(0.0, 1.0))
    with blocks.problem:
        runs = [blocks.solve(0.0), blocks.solve(0.05)]
    assert all(r["converged"] and r["updates"] < MAX_GEOMETRY_UPDATES for r in runs)
    assert len(runs[1]["nodes"]) == 40
    force = runs[1]["force"]
    assert np.hypot(force[0], force[1]) <= 0.8 * force[2] * (1 + 1e-8)
