r"""Cycles of the finite-sliding geometry iteration (:mod:`fenics_coulomb.model.sliding`): where its definitions
have no fixed point.

**Nodes on a master edge.** The contact rules are discontinuous at a master edge. Node-to-surface: where a slave
node's closest point crosses an edge with a kink, the normal jumps from one facet's to the other's, and with it the
contact force; a node beside such an edge is projected onto facet A, its solution moves it over facet B, whose
solution moves it back. At the master's outer edge, paired and free alternate: a paired slave node flush with the
edge that the slip (friction) carries past it is free in the next geometry, where it drops onto the master and is
paired again. Dual mortar: a slave facet that reaches past the master's border by a strip is not fully covered, its
nodes are freed, and without their contact forces the slave's border moves back over the master. The exact fixed
point lies on the edge, where neither state's rule applies.

Such a cycle — the new geometry is the one solved with two (a 2-cycle) or three (a 3-cycle, through a geometry of
the same nodes whose data changed) updates before, a digest of the contact nodes and supports, the same on every
rank; or single nodes are back at their partner of two updates before, with another in between, while the rest
of the geometry still settles (:func:`node_states`) — decides the geometry of its nodes within :data:`CYCLE_TIE`
× its amplitude (``Coupling.tie``): the nodes that changed partner, lost it or gained one anywhere around the
cycle (for single nodes: those nodes, the amplitude their own motion). The ties add up over a solve, and a load
path's step keeps its previous step's (a static solve starts untied); a cycle whose nodes are all tied already is
not tied again but accepted or failed (below). Node-to-surface
ties their closest points within that width (the tied facets' mean normal; a node within it of its closest point
is paired, as one on the surface); the node's point and weights stay the round-off tie rule's, so no numbering
enters; and every node of the pair that the cone test leaves unpaired within the widest tie of its closest point
is paired as one on the surface (a reach: the other nodes of a flush edge, which would cycle next, one or two at a
time). Dual mortar credits every slave facet with an uncovered border strip as wide as the widest tie (their
D_j, M_jl, g̃_j stay those of the covered part): the reach again, for a flush border's whole rows of facets. The
iteration goes on. A cycle whose solves were not all at full accuracy is tied only when its amplitude exceeds
:data:`LOOSE_CYCLE_MARGIN` × those solves' displacement error bound: a loose solve's cycle may be its error.

Measured: a slave node beside the lower block's edge after a slide, its cycle 4e-5 wide: the slide in one solve and
the static press 3.3e-4 of the normal force apart, 1 rank ≠ 2 ranks; tied, 1e-10 and 5e-10. A slave over a soft
master's corner, 7 nodes over its Kuhn diagonal swapping sides by 1e-4: tied, it settles on the symmetry plane. A
slave flush with the master's end, F = 0.3, hexahedra: a node-to-surface 2-cycle 1.9e-3 wide (its node gained on
the way back, which the tie of the nodes that lost their partner alone missed) and a dual-mortar 3-cycle 3.3e-3
wide, exit 3 before; tied, each settles mirror-symmetric to its mirror scene. A loose cycle of 1.5e-4 against an
error bound of 6.4e-5 (the hexahedral one-solve slide at x0 = 1.03): not tied, the one-solve slide equals the static
press to 1.7e-9, where the tie put them 1.25e-4 of |u| apart (tests/problems/test_geometry_cycle.py).

A 2-cycle that remains, or one no pair can tie, ends the iteration when its two solutions differ by at most
:data:`CYCLE_TOLERANCE`·h (h the smallest cell diameter at the contact nodes): of its two solutions the one with the
smaller elastic energy ½uᵀKu is kept (its geometry solved once more if it was the earlier one; within
:data:`CYCLE_ENERGY_TIE` the smaller Σ_i u_i·:data:`CYCLE_DIRECTION`) and a warning names the nodes and the
amplitude; a wider one fails (exit 3) as soon as it comes back without its amplitude halved, naming the nodes, the
amplitude and the coupling's cure (``Coupling.cycle_cure``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

__all__ = ["CYCLE_TOLERANCE", "CYCLE_ENERGY_TIE", "CYCLE_TIE", "CYCLE_DIRECTION", "LOOSE_CYCLE_MARGIN", "Cycle",
           "find_cycle", "cycle_message", "node_states"]

Array = npt.NDArray[np.float64]

#: A 2-cycle of the geometry is accepted when its solutions differ by at most this × the smallest cell diameter at
#: the contact nodes; the smaller energy kept unless within this relative difference ...
CYCLE_TOLERANCE, CYCLE_ENERGY_TIE = 1e-3, 1e-7
#: ... then the smaller Σ_i u_i · this (the same for every partition: energies differed by 5e-9 with the partition).
CYCLE_DIRECTION = np.array([1.0, 1.0 / np.sqrt(2.0), 1.0 / np.sqrt(3.0)])
#: A cycle's nodes decide their geometry within this × its amplitude (once per solve).
CYCLE_TIE = 4.0
#: A cycle through loose solves is tied only when its amplitude exceeds this × their displacement error bound.
LOOSE_CYCLE_MARGIN = 100.0


@dataclass
class Cycle:
    """A cycle of the geometry iteration (the same on every rank).

    Attributes:
        length: 2 or 3 geometries.
        amplitude: The largest max-norm difference of the latest solution from the cycle's other solutions.
        blocks: This rank's nodes (local DOF blocks) that changed partner, lost or gained one around the cycle.
        accurate: Every solve of the cycle reached the full accuracy.
        tieable: Accurate, or its amplitude beyond :data:`LOOSE_CYCLE_MARGIN` × its loose solves' error bound.
        other: The solution of the geometry solved before the latest (a 2-cycle's other state).
        whole: The whole geometry cycles (its digest); else only some nodes do, the others settling meanwhile.
    """

    length: int
    amplitude: float
    blocks: npt.NDArray[np.int32]
    accurate: bool
    tieable: bool
    other: Array
    whole: bool = True


def node_states(size: int, r0: int, nodes: Sequence[npt.NDArray[np.int64]],
                rows: Sequence[npt.NDArray[np.int64]]) -> npt.NDArray[np.uint64]:
    """A digest of each owned node's partner in one geometry (0: not a contact node): ``nodes`` per kind (obstacle
    nodes, then each coupling's), GLOBAL blocks from ``r0`` on, and ``rows`` their obstacle index or sorted support's
    global master blocks (−1 padded). Nodes of different kinds with the same row differ."""
    state = np.zeros(size, np.uint64)
    width = max((r.shape[1] for r in rows), default=1)
    with np.errstate(over="ignore"):
        for kind, (n, r) in enumerate(zip(nodes, rows, strict=True)):
            digest = np.full(n.size, np.uint64(kind + 1) * np.uint64(0x9E3779B97F4A7C15), np.uint64)
            for column in np.pad(r, ((0, 0), (0, width - r.shape[1])), constant_values=-1).T:
                digest = digest * np.uint64(1099511628211) + column.astype(np.int64).view(np.uint64)
            state[np.asarray(n, np.int64) - r0] = digest | np.uint64(1)
    return state


def find_cycle(comm: MPI.Comm, solved: Sequence[tuple[str, Array, float]], moved: Sequence[npt.NDArray[np.int32]],
               states: Sequence[npt.NDArray[np.uint64]], signature: str, new_states: npt.NDArray[np.uint64],
               u: Array, rtol: float, error_per_rtol: float) -> Cycle | None:
    """The cycle that the next geometry (digest ``signature``, node states ``new_states``) closes, if any: the whole
    geometry back to one solved two or three updates before, or nodes back to their partner of two updates before
    that had another in between (collective).

    Args:
        comm: The mesh's communicator.
        solved: (digest, solution, reduction) of every geometry solved so far, the latest last (its solution ``u``).
        moved: The nodes that changed partner after each of them.
        states: Their :func:`node_states`.
        signature: The digest of the geometry the latest solution asks for.
        new_states: Its :func:`node_states`.
        u: The latest solution (physical, owned DOFs).
        rtol: The full accuracy's reduction.
        error_per_rtol: The displacement error per unit of reduction (relative to ‖u‖_∞).
    """
    back = [i for i in (len(solved) - 2, len(solved) - 3) if i >= 0 and solved[i][0] == signature]
    whole = bool(back)
    if whole:
        first = back[0]
        blocks = np.unique(np.concatenate(list(moved[first:]))).astype(np.int32)
    elif len(solved) >= 2:  # nodes back and forth while the rest of the geometry settles
        first = len(solved) - 2
        blocks = np.flatnonzero((new_states == states[-2]) & (new_states != states[-1])).astype(np.int32)
        if comm.allreduce(int(blocks.size), op=MPI.SUM) == 0:
            return None
    else:
        return None
    # the whole solution's change for a whole cycle; the cycling nodes' own motion where the rest still settles
    rows = slice(None) if whole else blocks
    amplitude = comm.allreduce(max(float(np.max(np.abs(u.reshape(-1, 3)[rows] - w.reshape(-1, 3)[rows]), initial=0.0))
                                   for _, w, _ in solved[first:-1]), op=MPI.MAX)
    loosest = max(r for _, _, r in solved[first:])
    scale = comm.allreduce(float(np.max(np.abs(u), initial=0.0)), op=MPI.MAX)
    accurate = loosest <= rtol
    tieable = accurate or amplitude > LOOSE_CYCLE_MARGIN * error_per_rtol * loosest * scale
    return Cycle(len(solved) - first, amplitude, blocks, accurate, tieable, solved[-2][1], whole)


def cycle_message(amplitude: float, h: float, cure: str) -> str:
    """The failure's clause for a cycle wider than the accepted one."""
    return (f"; back and forth between two geometries whose solutions differ by {amplitude:.3g} ({amplitude / h:.2g} "
            f"of the smallest cell at the contact nodes, {CYCLE_TOLERANCE:g} accepted){cure}")
