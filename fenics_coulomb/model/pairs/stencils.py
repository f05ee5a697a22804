"""What a pair method is given and what it returns: the interface of the registry of pair methods
(:mod:`fenics_coulomb.model.pairs.registry`).

A pair method pairs one contact pair's candidate slave nodes with its master surface in one configuration: it gets
a :class:`PairInput` (the surfaces gathered, the nodes, the search distance) and returns the :class:`Stencils` of
those nodes — the rows of Φ (master blocks and weights), the gap, the frame, which nodes are contact nodes, and the
node-to-surface projection of the other owned slave nodes (the free nodes' penetration check). The pairing
(:func:`fenics_coulomb.model.pairs.pairing.pair_surfaces`) does the rest: the tags, the checks, several pairs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.pairs.projection import Surface, tie_width

__all__ = ["PairInput", "Stencils"]

Array = npt.NDArray[np.float64]


@dataclass
class PairInput:
    """One contact pair in one configuration, as a pair method sees it.

    Attributes:
        comm: The mesh's communicator (a method may call collectives; every rank calls the method).
        label: How messages name the pair.
        x: The position of every local DOF block (owned and ghost) in the configuration, shape (blocks, 3).
        owned_slave: The owned slave DOF blocks (local indices, ascending).
        global_slave: Their global DOF-block indices.
        nodes: The candidate contact nodes: ``owned_slave`` without the excluded blocks (ascending).
        master: The master surface, gathered on every rank.
        size: The diameter of each master facet.
        rank: The lexicographic rank of each master facet (the tie rule of
            :func:`~fenics_coulomb.model.pairs.projection.project`).
        search: The search distance: the largest |g| of a contact node.
        gather_slave: The slave surface, gathered on every rank (collective; computed once, on the first call).
        resolution: The configuration's own displacement error (a length; 0 for the reference configuration):
            geometric decisions finer than it are not made (dual mortar: an uncovered border strip up to twice as
            wide counts as covered, :func:`~fenics_coulomb.model.pairs.segmentation.mortar_nodes`).
        held: The Cartesian components a support holds, of every local DOF block (owned and ghost), shape
            (blocks, 3); None: none (node-to-surface decides the normal cone of a held node in the directions it
            can move, :func:`~fenics_coulomb.model.pairs.node_to_surface.stencils`).
        ties: The nodes of geometry cycles as (sorted global DOF blocks, widths), the width within which their
            geometric decisions are made (None: round-off; :meth:`tie_width`).
    """

    comm: MPI.Comm
    label: str
    x: Array
    owned_slave: npt.NDArray[np.int32]
    global_slave: npt.NDArray[np.int64]
    nodes: npt.NDArray[np.int32]
    master: Surface
    size: Array
    rank: npt.NDArray[np.intp]
    search: float
    gather_slave: Callable[[], Surface]
    resolution: float = 0.0
    held: npt.NDArray[np.bool_] | None = None
    ties: tuple[npt.NDArray[np.int64], Array] | None = None

    @property
    def reach(self) -> float:
        """The widest tie (0: none): every node's or facet's decision left open within it is made as on the surface
        (node-to-surface's pairing, mortar's coverage; the flush border's other nodes, which would cycle next)."""
        return 0.0 if self.ties is None else float(self.ties[1].max(initial=0.0))

    def tie_width(self, blocks: npt.NDArray[np.int64]) -> Array:
        """The tie width of each of the GLOBAL DOF blocks ``blocks`` (0 for a node not tied)."""
        return tie_width(self.ties, blocks)


@dataclass
class Stencils:
    """A pair method's result for the candidate nodes ``PairInput.nodes`` (n of them, in that order).

    Attributes:
        gap: g per node (inf where the method computed none), shape (n,).
        frames: (t₁, t₂, n) as columns, shape (n, 3, 3).
        contact: Whether each node is a contact node of the pair (|g| <= the search distance included).
        closest: The master point the gap measures to, shape (n, 3).
        master_blocks: GLOBAL DOF blocks of each node's stencil, −1 padded, shape (n, k).
        weights: Φ_jl, 0 on the padding, shape (n, k).
        area: The node's own contact area (mortar D_j), NaN where the contact boundary's lumped area applies.
        pointwise: The node-to-surface distance where the node lies over M (inf elsewhere): the reference overlap
            check.
        others: The owned slave blocks that are not contact nodes of this pair (local, ascending).
        projected: :func:`~fenics_coulomb.model.pairs.projection.project` of ``others`` onto M.
        partner_size: The diameter of the master facet beneath each node (its node-to-surface closest point's;
            inf where none was computed): small sliding's unit of a slide, shape (n,).
    """

    gap: Array
    frames: Array
    contact: npt.NDArray[np.bool_]
    closest: Array
    master_blocks: npt.NDArray[np.int64]
    weights: Array
    area: Array
    pointwise: Array
    others: npt.NDArray[np.int32]
    projected: dict[str, Array]
    partner_size: Array
