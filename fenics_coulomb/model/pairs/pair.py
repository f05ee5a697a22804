"""A contact pair (:class:`ContactPair`: the slave and master surfaces, friction, search distance, method) and
the pairing of all pairs (:class:`Pairing`: per owned contact node its stencil, gap and frame), and the contact map
it makes with the obstacles' contact nodes (:func:`merged_contact_map`).

Invalid fields are rejected when a pair is created (InputError, one line, the same on every rank).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.contact_map import ContactMap
from fenics_coulomb.model.pairs.registry import check_method

__all__ = ["ContactPair", "Pairing", "merged_contact_map"]

Array = npt.NDArray[np.float64]


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _is_real(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _tags(value: Any, key: str, owner: str) -> tuple[int, ...]:
    if _is_int(value):
        return (int(value),)
    if isinstance(value, (list, tuple, np.ndarray)) and all(_is_int(v) for v in value):
        if len(value) == 0:
            raise InputError(f"{owner}: {key} = {list(value)!r}: an empty surface (name at least one facet tag)")
        return tuple(int(v) for v in value)
    raise InputError(f"{owner}: {key} = {value!r}: must be a facet tag (an integer) or a list of them")


@dataclass(frozen=True)
class ContactPair:
    """A slave surface S, a master surface M (facet tag values of ``facet_tags``), a Coulomb coefficient.

    Attributes:
        facet_tags: The mesh's facet tags.
        slave: Tag value(s) of the slave surface S (its vertices become contact nodes).
        master: Tag value(s) of the master surface M.
        friction: Coulomb coefficient F >= 0.
        search_distance: Largest |g| of a contact node; default 0.1 × M's bounding-box diagonal.
        name: Optional name used in messages.
        method: A registered pair method (:mod:`fenics_coulomb.model.pairs.registry`): ``"mortar"`` (default:
            dual mortar, :mod:`fenics_coulomb.model.pairs.mortar`; passes the patch test) or ``"node-to-surface"``
            (each slave node against its closest master point, :mod:`fenics_coulomb.model.pairs.node_to_surface`).
    """

    facet_tags: dolfinx.mesh.MeshTags
    slave: int | Sequence[int]
    master: int | Sequence[int]
    friction: float = 0.0
    search_distance: float | None = None
    name: str | None = None
    method: str = "mortar"

    def __post_init__(self) -> None:
        owner = self.label
        check_method(self.method, owner)
        if self.name is not None and (not isinstance(self.name, str) or not self.name):
            raise InputError(f"contact pair: name = {self.name!r}: must be a non-empty string")
        _tags(self.slave, "slave", owner)
        _tags(self.master, "master", owner)
        if not _is_real(self.friction) or not math.isfinite(float(self.friction)) or float(self.friction) < 0:
            raise InputError(f"{owner}: friction = {self.friction!r}: must be a finite number >= 0")
        sd = self.search_distance
        if sd is not None and (not _is_real(sd) or not math.isfinite(float(sd)) or float(sd) <= 0):
            raise InputError(f"{owner}: search_distance = {sd!r}: must be a finite number > 0 (or None)")
        if not hasattr(self.facet_tags, "find") or getattr(self.facet_tags, "dim", None) is None:
            raise InputError(f"{owner}: facet_tags = {type(self.facet_tags).__name__}: must be dolfinx MeshTags")

    @property
    def label(self) -> str:
        """How messages name the pair (without its position; :func:`pair_surfaces` adds it)."""
        return f"contact pair {self.name!r}" if self.name else "contact pair"

    @property
    def slave_tags(self) -> tuple[int, ...]:
        """The slave tag values as a tuple."""
        return _tags(self.slave, "slave", self.label)

    @property
    def master_tags(self) -> tuple[int, ...]:
        """The master tag values as a tuple."""
        return _tags(self.master, "master", self.label)


@dataclass
class Pairing:
    """The contact nodes of all pairs owned by this rank (ascending local block).

    Attributes:
        blocks: LOCAL owned DOF-block index of each contact node, ascending, shape (m,).
        coordinates: x_s, shape (m, 3).
        closest: x_m, shape (m, 3).
        gap: g = (x_s − x_m)·n, shape (m,).
        frames: (t₁, t₂, n) as columns, shape (m, 3, 3).
        master_blocks: GLOBAL DOF-block indices of the stencil's master nodes, shape (m, k) (−1 padding):
            node-to-surface the chosen master facet's vertices (k = 4, padding for triangles); mortar the
            master nodes l with Φ_jl ≠ 0 (k the widest stencil on any rank, at least 4).
        weights: Φ_jl (node-to-surface: φ_j at x_m), 0 on padding, shape (m, k); rows sum to 1.
        area: Mortar D_j (the pressure is f_j·n_j / D_j); NaN for node-to-surface nodes, shape (m,).
        pair_index: Index of each node's pair, shape (m,).
        friction: The pair's F per node, shape (m,).
        num_global: Number of contact nodes on all ranks.
        free: The owned slave nodes that are NOT contact nodes but lie over a master surface (in its normal
            cone): beyond the search distance, or with a Dirichlet component. Keys ``blocks`` (local),
            ``gap``, ``normals``, ``master_blocks``, ``weights`` as above (the pair with the smallest |g|), for the
            penetration check after a solve
            (:meth:`fenics_coulomb.model.pairs.coupling.PairCoupling.free_slave_penetrations`).
        to_obstacles: The owned paired slave nodes the merge with the obstacles' contact nodes gave to an obstacle
            (the smaller gap), with the same keys as ``free``: their pair constraint is not enforced, and the check
            after a solve measures it (:meth:`~fenics_coulomb.model.pairs.coupling.PairCoupling.shared_depth`).
        shared: The number of paired slave nodes that are obstacle contact nodes too, on all ranks.
        partner_size: The diameter of the master facet beneath each node (small sliding's unit of a slide), shape
            (m,).
    """

    blocks: npt.NDArray[np.int32]
    coordinates: Array
    closest: Array
    gap: Array
    frames: Array
    master_blocks: npt.NDArray[np.int64]
    weights: Array
    area: Array
    pair_index: npt.NDArray[np.intp]
    friction: Array
    num_global: int
    free: dict[str, np.ndarray] = field(default_factory=dict)
    to_obstacles: dict[str, np.ndarray] = field(default_factory=dict)
    shared: int = 0
    partner_size: Array = field(default_factory=lambda: np.zeros(0))

    def subset(self, keep: npt.NDArray[np.bool_], comm: MPI.Comm) -> Pairing:
        """The pairing of the nodes ``keep`` selects (collective: the global count)."""
        return Pairing(blocks=self.blocks[keep], coordinates=self.coordinates[keep], closest=self.closest[keep],
                       gap=self.gap[keep], frames=self.frames[keep], master_blocks=self.master_blocks[keep],
                       weights=self.weights[keep], area=self.area[keep], pair_index=self.pair_index[keep],
                       friction=self.friction[keep], num_global=comm.allreduce(int(np.sum(keep)), op=MPI.SUM),
                       free=self.free, to_obstacles=self.to_obstacles, shared=self.shared,
                       partner_size=self.partner_size[keep])

    def to_free(self, drop: npt.NDArray[np.bool_], comm: MPI.Comm) -> Pairing:
        """The pairing without the nodes ``drop`` selects, which join ``free``: no contact nodes, their penetration
        measured after a solve (collective: the global count)."""
        kept = self.subset(~drop, comm)
        width = max([self.master_blocks.shape[1]] + ([self.free["master_blocks"].shape[1]] if self.free else []))

        def padded(a: npt.NDArray[Any], fill: float) -> npt.NDArray[Any]:
            out = np.full((a.shape[0], width), fill, dtype=a.dtype)
            out[:, :a.shape[1]] = a
            return out

        moved: dict[str, np.ndarray] = {
            "blocks": self.blocks[drop], "gap": self.gap[drop], "normals": self.normals[drop],
            "master_blocks": padded(self.master_blocks[drop], -1), "weights": padded(self.weights[drop], 0.0)}
        if self.free:
            old: dict[str, np.ndarray] = {**self.free, "master_blocks": padded(self.free["master_blocks"], -1),
                                          "weights": padded(self.free["weights"], 0.0)}
            moved = {k: np.concatenate([old[k], v]) for k, v in moved.items()}
        kept.free = moved
        return kept

    @property
    def normals(self) -> Array:
        """n of each contact node, shape (m, 3)."""
        return np.ascontiguousarray(self.frames[:, :, 2])

    @property
    def size(self) -> int:
        """Number of contact nodes owned by this rank."""
        return int(self.blocks.size)


def merged_contact_map(pairing: Pairing, held: npt.NDArray[np.bool_], obstacles: ContactMap | None,
                       obstacle_friction: Array, r0: int, comm: MPI.Comm
                       ) -> tuple[ContactMap, npt.NDArray[np.bool_], Array]:
    """The model's contact map of the pairs' slave nodes (``pairing``, their held components ``held``) and the
    obstacles' contact nodes (``obstacles``, their friction), ascending by local DOF block (``r0``: the rank's first
    global block); which of its nodes are the pairing's (in the pairing's order), and every node's friction
    (collective)."""
    blocks, coordinates, gap, frames = pairing.blocks, pairing.coordinates, pairing.gap, pairing.frames
    index: np.ndarray = -1 - pairing.pair_index  # pairs: −1 − pair index; obstacles: their index
    paired = np.ones(blocks.size, dtype=bool)
    node_friction = pairing.friction
    if obstacles is not None:
        blocks = np.concatenate([blocks, obstacles.blocks])
        coordinates = np.concatenate([coordinates, obstacles.coordinates])
        gap = np.concatenate([gap, obstacles.gap])
        frames = np.concatenate([frames, obstacles.frames])
        index = np.concatenate([index, obstacles.obstacle_index])
        held = np.concatenate([held, obstacles.held_components])
        paired = np.concatenate([paired, np.zeros(obstacles.size, dtype=bool)])
        node_friction = np.concatenate([node_friction, obstacle_friction])
    order = np.argsort(blocks, kind="stable")
    blocks = blocks[order].astype(np.int32)
    offsets = np.arange(3, dtype=np.int32)
    cmap = ContactMap(
        blocks=blocks, local_dofs=(3 * blocks[:, None] + offsets).astype(np.int32),
        global_dofs=3 * (blocks.astype(np.int64)[:, None] + r0) + offsets.astype(np.int64),
        coordinates=np.ascontiguousarray(coordinates[order]), gap=np.ascontiguousarray(gap[order]),
        frames=np.ascontiguousarray(frames[order]), obstacle_index=index[order],
        num_global=comm.allreduce(int(blocks.size), op=MPI.SUM), held=np.ascontiguousarray(held[order]))
    return cmap, paired[order], np.ascontiguousarray(np.asarray(node_friction, dtype=np.float64)[order])
