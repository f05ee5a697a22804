r"""A tied 2-cycle's answer against an independent brute-force geometry + Alart–Curnier solver (serial).

The slide-off blocks of `benchmarks/slide_matrix.py` on tetrahedra (10 × 5 × 3 / 7 × 4 × 3), the upper block flush
with the lower block's end x1 = 2, pressed 0.01, F = 0.3, node-to-surface, rtol 1e-12: an edge node cycles between
paired and free, and the library ties it (model/geometry_cycles.py). The reference evaluates the tied definitions at
the library's final configuration X + u with the library's tie widths — its own brute-force closest points on ALL
master triangles, tie sets, normal cone (NNLS), normal rule and reach — and solves the contact problem linearized
there (tests/brute_force.py, Alart–Curnier): the library's answer is that fixed point (the same contact nodes and
supports, u and the contact forces to 1e-8). Without the ties the same configuration frees the edge node, so the
tie decides the answer: the untied definitions have no fixed point here.
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt
import pytest
from scipy.optimize import nnls

from benchmarks.slide_matrix import LOWER_TOP, UPPER_BOTTOM, Blocks

from test_finite_sliding_brute_force import _prescribed, closest_on_triangles, coupling, frames_of

Array = npt.NDArray[np.float64]


def _cone_distance(d: Array, normals: Array) -> float:
    """dist(d, cone{normals}) by non-negative least squares."""
    return float(nnls(normals.T, d)[1])


def tied_geometry(x: Array, slave: npt.NDArray[np.int64], triangles: npt.NDArray[np.int64], width: Array,
                  reach: float, search: float) -> dict[str, Array]:
    """The node-to-surface geometry of the slave nodes at the positions ``x`` (every block) with tie widths
    ``width`` (per slave node) and ``reach``, by brute force (the rules of model/pairs/projection.py)."""
    tri = x[triangles]
    best, bary, dist = closest_on_triangles(x[slave], tri)
    facet_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    facet_n *= np.sign(facet_n[:, 2])[:, None] / np.linalg.norm(facet_n, axis=1)[:, None]  # out of the lower block
    h_t = np.max([np.linalg.norm(tri[:, i] - tri[:, j], axis=1) for i, j in ((0, 1), (1, 2), (2, 0))], axis=0)
    m = slave.size
    out = {k: np.zeros((m, 3)) for k in ("n", "phi")}
    out["stencil"] = np.zeros((m, 3), np.int64)
    out["g"], out["paired"] = np.zeros(m), np.zeros(m, dtype=bool)
    for j in range(m):
        k = int(np.argmin(dist[j]))
        h = h_t[k]
        tol = max(1e-10 * h, width[j])
        tied = np.flatnonzero((dist[j] <= dist[j, k] + tol) & (np.linalg.norm(best[j] - best[j, k], axis=1) <= tol))
        xm, phi = best[j, k], bary[j, k]
        d = x[slave[j]] - xm
        mean = facet_n[tied].sum(axis=0)
        mean /= np.linalg.norm(mean)
        if np.linalg.norm(d) <= tol:
            n, paired = mean, True
        elif tied.size > 1 or phi.min() <= 1e-10:  # an edge or vertex: ±d in the cone of the tied normals
            plus, minus = _cone_distance(d, facet_n[tied]), _cone_distance(-d, facet_n[tied])
            paired = min(plus, minus) <= 1e-8 * h
            unit = d / np.linalg.norm(d)
            n = unit if plus <= 1e-8 * h else -unit if minus <= 1e-8 * h else facet_n[k]
            if paired and min(plus, minus) > 1e-3 * np.linalg.norm(d):  # a vague direction: the cone's mean
                n = mean
        else:
            n = facet_n[k]
            paired = np.linalg.norm(d - (d @ n) * n) <= 1e-8 * h
        if not paired and np.linalg.norm(d) <= reach:  # within a cycle's reach of its closest point
            n, paired = mean, True
        out["n"][j], out["phi"][j], out["stencil"][j] = n, phi, triangles[k]
        out["g"][j], out["paired"][j] = d @ n, paired and abs(d @ n) <= search
    return out


@pytest.mark.serial
def test_a_tied_cycle_is_the_fixed_point_of_the_tied_definitions():
    from brute_force import solve_contact

    blocks = Blocks(MPI.COMM_SELF, "tetrahedron", (10, 5, 3), (7, 4, 3), 1.0, "node-to-surface", "tied_bf_",
                    friction=0.3, rtol=1e-12)
    V, ft = blocks.V, blocks.facet_tags
    X = V.tabulate_dof_coordinates()
    K = dolfinx.fem.assemble_matrix(dolfinx.fem.form(blocks.a)).to_scipy().tocsr()  # no boundary conditions
    slave = np.sort(dolfinx.fem.locate_dofs_topological(V, 2, ft.find(UPPER_BOTTOM))).astype(np.int64)
    triangles = np.sort(np.array([dolfinx.fem.locate_dofs_topological(V, 2, [f]) for f in ft.find(LOWER_TOP)]), axis=1)
    with blocks.problem as problem:
        run = blocks.solve(0.0)
        assert run["converged"]
        model = problem.model
        tied, widths = model.coupling.ties  # the tie happened: the edge node's 2-cycle
        assert tied.size >= 1 and widths.max() > 0.0
        u_lib = problem.u.x.array.copy()
        result = problem.solve()[1]  # the solve again, from its own answer: nothing moves (its forces below)
        u_again = problem.u.x.array.copy()
        pairing = model.pairing
        order = np.argsort(pairing.blocks)
        lib_blocks = pairing.blocks[order]
        lib_support = np.sort(np.where(pairing.weights != 0.0, pairing.master_blocks, -1), axis=1)[order]
        f_lib = result.contact_force[order]
        D, values = _prescribed(V, blocks.bcs)
    assert np.linalg.norm(u_again - u_lib) <= 1e-10 * np.linalg.norm(u_lib)
    width = np.zeros(slave.size)
    width[np.searchsorted(slave, tied)] = widths  # one rank: global blocks are local ones
    x = X + u_lib.reshape(-1, 3)
    search = 0.1 * np.linalg.norm(X[triangles].reshape(-1, 3).max(axis=0) - X[triangles].reshape(-1, 3).min(axis=0))
    ref = tied_geometry(x, slave, triangles, width, float(widths.max()), search)
    # the same contact nodes and supports
    nodes = slave[ref["paired"]]
    assert np.array_equal(nodes, lib_blocks)
    ref_support = np.sort(np.where(ref["phi"] > 1e-12, ref["stencil"], -1), axis=1)[ref["paired"]]
    assert np.array_equal(lib_support[:, -3:], ref_support)
    # the contact problem linearized at u_lib in that geometry: its solution is u_lib
    n_dofs = K.shape[0]
    stencil, phi, n, g = (ref[k][ref["paired"]] for k in ("stencil", "phi", "n", "g"))
    G = coupling(nodes, stencil, phi, n_dofs)
    R = frames_of(n)
    gaps = g - np.einsum("ij,ij->i", n, (G @ u_lib).reshape(-1, 3))
    sol = solve_contact(K, np.zeros(n_dofs), 3 * nodes[:, None] + np.arange(3), gaps, 0.3, frames=R,
                        shifts=np.zeros((nodes.size, 2)), dirichlet=(D, values), coupling=G, tol=1e-14)
    assert np.linalg.norm(sol.u - u_lib) <= 1e-8 * np.linalg.norm(sol.u)
    force = np.einsum("iab,ib->ia", R, sol.force)
    assert np.abs(f_lib - force).max() <= 1e-8 * np.abs(force).max()
    # without the ties the same configuration frees the tied node: the untied definitions move on from here
    untied = tied_geometry(x, slave, triangles, np.zeros(slave.size), 0.0, search)
    assert not np.array_equal(untied["paired"], ref["paired"])
