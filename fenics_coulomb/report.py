"""What a contact user reads off a solve: forces per obstacle and pair, reactions, the contact nodes.

:meth:`fenics_coulomb.ContactProblem.report` turns a :class:`~fenics_coulomb.scd.records.SolveResult` (whose
arrays are each rank's owned entries) into a :class:`ContactReport` that is the same on every rank: the
contact nodes are gathered and ordered by their reference coordinates (lexicographically in x₁, x₂, x₃ to 1e-9
of the contact surface's extent: an order that does not depend on the partition) and the totals are summed in that
order, so a script reads the same numbers on 1, 2 or 3 ranks (to the solver's round-off across rank counts)::

    with ContactProblem(a, L, bcs=[clamp], contact=(tags, [top]), obstacles=[ball],
                        petsc_options_prefix="press_") as problem:
        _, result = problem.solve()
        report = problem.report(result, reactions={"bottom": clamp})
        report.total_force, report.reactions["bottom"], report.contact_radius(center=(0.5, 0.5, 0.5))

Definitions (the same as summary.json's and the XDMF fields'):

* the contact force on the body at a node is the solver's −Rᵢ zⁱ (Cartesian); ``normal_force`` its normal
  part λ ≥ 0, ``pressure`` = λ / area (force per area, the ``contact_pressure`` output field) with ``area`` =
  ∫ φᵢ ds over the contact boundary (the lumped facet area; the mortar D_j on a dual mortar pair's slave nodes);
* ``obstacle_forces[name]`` = Σ of the contact forces on the nodes that touch that obstacle (the force the
  obstacle exerts on the body); ``pair_forces`` = the force each contact pair exerts on its slave body and, from
  that pair's own stencil, on its master body (:func:`fenics_coulomb.model.pairs.forces.pair_forces`);
* ``reactions[name]`` = Σ over the DOFs the support holds (its components only: a condition on ``V.sub(i)`` or
  a roller has none in the components it leaves free) of K ũ − l̃⁰ assembled without boundary conditions, minus
  the contact forces acting on those DOFs: the force the support exerts on the body
  (:func:`fenics_coulomb.model.checks.boundary_reactions`);
* equilibrium: Σ reactions + Σ obstacle forces + applied load = 0 up to the stopping tolerance (the pairs'
  forces are internal: each pair's force on its master body is minus its force on its slave body).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.checks import boundary_reactions
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.forces import contact_areas
from fenics_coulomb.model.obstacles import Obstacle, obstacle_names
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scd.resolvent import OPEN, ContactState

__all__ = ["ContactNodes", "ContactReport", "make_report", "nodal_pressure", "reaction_groups"]

Array = npt.NDArray[np.float64]


def nodal_pressure(normal_force: npt.ArrayLike, area: npt.ArrayLike) -> Array:
    """The contact pressure per node, λ / area (force per area; 0 where the area is 0): the one definition of
    ``ContactNodes.pressure`` and of the ``contact_pressure`` output field."""
    force = np.asarray(normal_force, dtype=np.float64).reshape(-1)
    area = np.asarray(area, dtype=np.float64).reshape(-1)
    return np.divide(force, area, out=np.zeros_like(force), where=area > 0)


def _finite_vector(value: Any, name: str) -> Array:
    """``value`` as 3 finite numbers, or InputError naming it (contact_radius's arguments)."""
    try:
        vector = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        vector = np.zeros(0)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise InputError(f"contact_radius: {name} = {value!r}: must be 3 finite numbers")
    return vector


@dataclass(frozen=True)
class ContactNodes:
    """Every contact node of the problem (all ranks), ordered by reference coordinates (x₁, then x₂, then x₃).

    Attributes:
        coordinates: Reference coordinates, shape (p, 3).
        normal: The outward unit normal of the node's obstacle (or master surface), shape (p, 3).
        area: The node's share of the contact surface: ∫ φᵢ ds, or the mortar D_j on a dual mortar pair's
            slave nodes, shape (p,).
        force: Contact force on the body (Cartesian), shape (p, 3).
        normal_force: Its normal part λ ≥ 0, shape (p,).
        pressure: The contact pressure λ / area (force per area, 0 where the area is 0; the ``contact_pressure``
            output field), shape (p,).
        gap: The gap at the solution (≥ 0), shape (p,).
        state: :class:`~fenics_coulomb.scd.resolvent.ContactState` codes (0 open, 1 stick, 2 slip), shape (p,).
        obstacle: Index of the node's obstacle in the problem's list, −1 for a contact-pair (slave) node.
        position: The node's current position X + u, shape (p, 3).
        partner: Its partner point in the current configuration, position − gap·normal: the closest point of its
            obstacle, or the master point beneath a slave node along its normal (the node-to-surface closest
            point; for dual mortar the point the weighted gap measures to), shape (p, 3).
    """

    coordinates: Array
    normal: Array
    area: Array
    force: Array
    normal_force: Array
    pressure: Array
    gap: Array
    state: npt.NDArray[np.int8]
    obstacle: npt.NDArray[np.int64]
    position: Array = field(default_factory=lambda: np.zeros((0, 3)))
    partner: Array = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def closed(self) -> npt.NDArray[np.bool_]:
        """The nodes in contact (stick or slip)."""
        return self.state != OPEN

    def states(self) -> list[ContactState]:
        """The states as :class:`~fenics_coulomb.scd.resolvent.ContactState` members."""
        return [ContactState(int(s)) for s in self.state]


@dataclass(frozen=True)
class ContactReport:
    """Forces and contact nodes of one solve, the same on every rank (see the module docstring).

    Attributes:
        total_force: Σ of the obstacles' contact forces on the body (the bodies): the forces of contact pairs act
            between two bodies and cancel in it (they are in ``pair_forces``), so that total_force + Σ reactions +
            applied_load = 0.
        obstacle_forces: Per obstacle (its ``name``, or "KIND N" by its position in the list), the force it
            exerts on the body.
        pair_forces: Per contact pair, the forces on its slave and master bodies (empty for one body).
        reactions: Per named Dirichlet boundary, the force the support exerts on the body.
        applied_load: Σ of the nodal applied loads (tractions and body forces).
        nodes: The contact nodes.
    """

    total_force: Array
    obstacle_forces: dict[str, Array]
    pair_forces: list[dict[str, Any]]
    reactions: dict[str, Array]
    applied_load: Array
    nodes: ContactNodes
    extra: dict[str, Any] = field(default_factory=dict)

    def __str__(self) -> str:
        """A few lines an engineer reads: the resultants, per obstacle, pair and support, and the contact nodes (the
        dataclass's repr lists every node)."""
        def vector(v: npt.ArrayLike) -> str:
            return "(" + ", ".join(f"{c:.6g}" for c in np.asarray(v, dtype=np.float64)) + ")"

        closed = self.nodes.closed
        lines = [f"contact force on the body {vector(self.total_force)}, applied load {vector(self.applied_load)}"]
        lines += [f"  obstacle {name}: {vector(force)}" for name, force in self.obstacle_forces.items()]
        for i, pair in enumerate(self.pair_forces):
            slave, master = vector(pair["force_on_slave_body"]), vector(pair["force_on_master_body"])
            label = pair.get("name") or f"pair {i + 1}"
            lines.append(f"  {label}: on the slave body {slave}, on the master body {master}")
        lines += [f"  reaction {name}: {vector(force)}" for name, force in self.reactions.items()]
        peak = float(np.max(self.nodes.pressure, initial=0.0))
        lines.append(f"{int(np.sum(closed))} of {closed.size} contact nodes in contact, peak pressure {peak:.6g}")
        return "\n".join(lines)

    def contact_radius(self, center: npt.ArrayLike, normal: npt.ArrayLike | None = None) -> float:
        """The largest distance of a node in contact from the line through ``center`` along ``normal``.

        Args:
            center: A point of the contact's axis (e.g. the initial contact point).
            normal: The axis direction; default the mean normal of the nodes in contact.

        Returns:
            The radius (0 when no node is in contact). On a mesh it is a node position: it resolves the true
            radius to about one element.
        """
        centre = _finite_vector(center, "center")
        if normal is not None and not np.any(_finite_vector(normal, "normal")):
            raise InputError(f"contact_radius: normal = {normal!r}: a zero vector has no direction")
        closed = self.nodes.closed
        if not np.any(closed):
            return 0.0
        n = np.asarray(normal, dtype=np.float64) if normal is not None else self.nodes.normal[closed].mean(axis=0)
        n = n / max(float(np.max(np.abs(n))), np.finfo(float).tiny)  # scaled first: 1e-300 or 1e308 are directions
        length = float(np.linalg.norm(n))
        if not np.isfinite(length) or length == 0.0:
            raise InputError(f"contact_radius: normal {normal!r} is not a non-zero finite vector")
        n = n / length
        d = self.nodes.coordinates[closed] - centre
        radial = d - np.outer(d @ n, n)
        return float(np.max(np.linalg.norm(radial, axis=1)))


def reaction_groups(V: dolfinx.fem.FunctionSpace, bcs: Mapping[str, Any]) -> dict[str, Any]:
    """The named supports of ``bcs``, checked, as :func:`~fenics_coulomb.model.checks.boundary_reactions` takes
    them (collective: a bad entry on any rank is an InputError on every rank).

    Args:
        V: The problem's vector space.
        bcs: name → a ``dolfinx.fem.DirichletBC`` (on V or on ``V.sub(i)``: its reaction has the components the
            condition holds) or an array of local node blocks (owned and ghost: the components of those nodes
            the problem's conditions hold).

    Returns:
        name → the DirichletBC itself, or the node blocks as a sorted int32 array.
    """
    message = ""
    groups: dict[str, Any] = {}
    try:
        groups = _reaction_groups(V, bcs)
    except InputError as err:
        message = str(err)
    check_all(V.mesh.comm, not message, message)
    names = V.mesh.comm.allgather(sorted(groups))  # node blocks are per rank, the names must be every rank's
    check_all(V.mesh.comm, all(n == names[0] for n in names),
              f"reactions: the names differ between ranks ({names[0]} on rank 0, "
              f"{next((n for n in names if n != names[0]), names[0])} on another): give every name on every rank "
              "(an empty array of node blocks where a rank has none)")
    return groups


def _reaction_groups(V: dolfinx.fem.FunctionSpace, bcs: Mapping[str, Any]) -> dict[str, Any]:
    if not isinstance(bcs, Mapping):
        raise InputError(f"reactions = {type(bcs).__name__}: give a dict name -> DirichletBC (or node blocks)")
    bs = V.dofmap.index_map_bs
    nodes = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    groups: dict[str, Any] = {}
    for name, bc in bcs.items():
        if not isinstance(name, str) or not name:
            raise InputError(f"reactions: name {name!r} must be a non-empty string")
        conditions = [bc] if isinstance(bc, dolfinx.fem.DirichletBC) else list(bc) if isinstance(bc, list | tuple) \
            and bc and all(isinstance(c, dolfinx.fem.DirichletBC) for c in bc) else None
        if conditions is not None:
            for condition in conditions:
                space = condition.function_space
                if getattr(space.mesh, "_cpp_object", space.mesh) is not getattr(V.mesh, "_cpp_object", V.mesh) \
                        or space.dofmap.index_map.size_global != V.dofmap.index_map.size_global \
                        or space.dofmap.index_map_bs != bs:
                    raise InputError(f"reactions[{name!r}]: a boundary condition of another function space (give "
                                     "one of the problem's bcs, on V or V.sub(i))")
            # the DOFs they hold: their components only (a condition on V.sub(i))
            groups[str(name)] = bc if isinstance(bc, dolfinx.fem.DirichletBC) else conditions
        else:
            try:
                blocks = np.asarray(bc)
            except (TypeError, ValueError):
                blocks = np.zeros(0, dtype=object)
            if blocks.ndim != 1 or (blocks.size and (blocks.dtype.kind not in "iu" or blocks.min() < 0
                                                     or blocks.max() >= nodes)):
                raise InputError(f"reactions[{name!r}] = {type(bc).__name__}: give a DirichletBC of bcs (or a list "
                                 f"of them) or an array of this rank's node blocks (integers in [0, {nodes}))")
            groups[str(name)] = np.unique(blocks.astype(np.int32))
    return groups


def _gather(comm: MPI.Comm, local: np.ndarray, order: np.ndarray) -> np.ndarray:
    return np.concatenate(comm.allgather(np.ascontiguousarray(local)), axis=0)[order]


def make_report(model: ContactModel, result: SolveResult, obstacles: Sequence[Obstacle],
                reactions: Mapping[str, Any] | None = None) -> ContactReport:
    """The :class:`ContactReport` of ``result`` (collective). ``reactions``: name → DirichletBC or node blocks."""
    if not isinstance(result, SolveResult):
        raise InputError(f"report: result = {type(result).__name__}: give the SolveResult of the problem's solve()")
    comm = model.comm
    cmap = model.contact
    x = np.concatenate(comm.allgather(np.ascontiguousarray(cmap.coordinates)), axis=0).reshape(-1, 3)
    # coordinates rounded to 1e-9 of the contact surface's extent: a mesh generator's round-off (which differs
    # with the partition: -9e-18 or 4e-18 for 0) must not change the order
    scale = float(np.max(np.ptp(x, axis=0))) if x.size else 1.0
    key = np.round(x / (scale or 1.0), 9)
    order = np.lexsort((key[:, 2], key[:, 1], key[:, 0]))
    force = np.asarray(result.contact_force, dtype=np.float64).reshape(-1, 3)
    area = contact_areas(model)
    normal_force = np.asarray(result.normal_force, dtype=np.float64)
    pressure = nodal_pressure(normal_force, area)
    which = np.asarray(cmap.obstacle_index, dtype=np.int64).copy()
    which[model.coupling.paired_mask(cmap.size)] = -1  # a pair's slave node: no obstacle
    u = np.asarray(result.displacement, dtype=np.float64).reshape(-1, 3)[cmap.blocks]
    position = _gather(comm, cmap.coordinates, order) + _gather(comm, u, order)
    gap = _gather(comm, np.asarray(result.gap, dtype=np.float64), order)
    normal = _gather(comm, cmap.normals, order)
    nodes = ContactNodes(
        coordinates=_gather(comm, cmap.coordinates, order),
        normal=normal,
        area=_gather(comm, area, order),
        force=_gather(comm, force, order),
        normal_force=_gather(comm, normal_force, order),
        pressure=_gather(comm, pressure, order),
        gap=gap,
        state=_gather(comm, np.asarray(result.states, dtype=np.int8), order),
        obstacle=_gather(comm, which, order),
        position=position,
        partner=position - gap[:, None] * normal,
    )
    per_obstacle: dict[str, Array] = {}
    for i, name in enumerate(obstacle_names(obstacles)):
        per_obstacle[name] = nodes.force[nodes.obstacle == i].sum(axis=0)
    groups = reaction_groups(model.V, reactions or {})
    held = np.unique(np.asarray(model.dirichlet_rows) // 3)
    for name, group in groups.items():  # node blocks no condition holds have no reaction: 0 would mislead
        if isinstance(group, np.ndarray):
            n = comm.allreduce(np.array([group.size, np.isin(group, held).sum()], dtype=np.int64), op=MPI.SUM)
            if n[0] and not n[1]:  # (no node on any rank: nothing named, a zero reaction)
                raise InputError(f"reactions[{name!r}]: none of its {int(n[0])} node(s) is held by a boundary "
                                 "condition of the problem (a reaction is the force a support exerts on the nodes it "
                                 "holds)")
    load = model.owned_load()  # assembled once: the reactions and the applied load's resultant
    support = boundary_reactions(model, result.displacement, groups, result.master_force,
                                 result.contact_force, load) if groups else {}
    return ContactReport(
        total_force=nodes.force[nodes.obstacle >= 0].sum(axis=0),  # a pair's forces are internal
        obstacle_forces=per_obstacle,
        pair_forces=model.coupling.pair_forces(model, result),
        reactions={name: np.asarray(v) for name, v in support.items()},
        applied_load=np.asarray(model.total_load(load), dtype=np.float64),
        nodes=nodes,
    )
