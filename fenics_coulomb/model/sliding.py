r"""Finite sliding: when the contact geometry of a configuration has settled.

Small strain and small rotations stay (A assembled once); the contact geometry G(u) — the contact nodes, the
node-to-surface stencils or the dual-mortar data of every pair, the obstacles' closest points, gaps, normals and
frames — is evaluated with both surfaces at x = X + u (``ContactModel.configure``). A solve linearizes G about u⁽ᵐ⁾:

    pairs       g_j(X + u⁽ᵐ⁾) + n_j·(w_j − w_j⁽ᵐ⁾),   w_j = u_s − Σ_l Φ_jl u_l   (the unknown z on slave node j),
    obstacles   g_i(X + u⁽ᵐ⁾) + n_i·(u_i − u_i⁽ᵐ⁾),

i.e. the model's constant gap is g(X + u⁽ᵐ⁾) − n·w⁽ᵐ⁾ (for a plane exactly g(X): its gap is affine in x and its
frame constant, so a plane needs no update). The slip of a step is T_j[(u_s − u_s^{k−1}) − Σ_l Φ_jl (u_l −
u_l^{k−1})] with the stencil of the step's own geometry: the relative motion against the master material point
beneath the node (:meth:`ContactProblem._history <fenics_coulomb.problem.ContactProblem._history>` maps the
previous step's physical u with the current Φ).

**The geometry iteration.** u⁽⁰⁾ is the previous step's converged u (the reference configuration for a static
solve); u⁽ᵐ⁺¹⁾ solves the problem with G(u⁽ᵐ⁾) linearized about u⁽ᵐ⁾, started from u⁽ᵐ⁾. It stops when G(u⁽ᵐ⁺¹⁾)

1. has the same contact nodes and stencil supports (the master nodes with |Φ_jl| > ε/h_j of every node, h_j the
   largest cell diameter at node j: a weight that moves the stencil's point by less than the accuracy ε is no
   support — a node converging onto a master edge would otherwise flip between the facets on both sides
   forever; for an obstacle node its obstacle), and
2. differs from G(u⁽ᵐ⁾)'s linearization at u⁽ᵐ⁺¹⁾ by at most ε = e·‖u⁽ᵐ⁺¹⁾‖_∞ in every node's constraint
   data (or, at full accuracy, by a change that stopped shrinking between two updates with the same nodes and
   supports and lies below the geometry's round-off, :data:`ROUND_OFF_CAP` × the mesh's extent):
   Δ_j = ((g_j^new − g_j^lin)² + |P_j^new s_j^new − P_j^old s_j^old|²)^{1/2}, with g^lin the linearized gap at
   u⁽ᵐ⁺¹⁾, s the step's relative displacement increment through the node's stencil and P = I − n nᵀ the tangential
   projection (basis-free: the friction law is isotropic).

Why ε. Solving again changes only these data, by Δ at most. The solution of the contact problem depends on its
gap and slip data as a projection does on the constraint set it projects onto: shifting the set by Δ moves the
solution by at most Δ in the constrained components (non-expansive in the energy norm; the elastic fill-in
decays from there), so another solve could move u by ≲ max Δ ≤ e‖u‖_∞ with e the solve's own relative
displacement accuracy, e = ERROR_PER_RTOL·rtol (:data:`fenics_coulomb.settings.ERROR_PER_RTOL`: twice the
largest ratio measured in docs/tradeoff, the bound ``--accuracy`` uses). At most :data:`MAX_GEOMETRY_UPDATES`
updates; then the solve fails (exit 3) naming the nodes whose pairing keeps changing.

**Open nodes.** The rules above are checked on the nodes the solution presses, and on every node that
penetrates its partner in the new geometry (gap < −ε at X + u⁽ᵐ⁺¹⁾, gained candidates included). An open node
(no force) whose new gap is ≥ −ε satisfies the new geometry's constraint with the force it has, zero, whatever
its partner or stencil; solving again would not move u on its account. Without this, the candidates beside a
contact patch (every slave node within the search distance) change their stencils with every update while
nothing presses them (the two-body demo: 29 of 87 candidates changed partner in its first update, 5 nodes in
contact).

**Accuracy of the intermediate solves.** Only the last solve's accuracy reaches the answer: an intermediate
solution serves to place the next geometry, and the iteration damps its error (u⁽ᵐ⁺¹⁾'s error moves G(u⁽ᵐ⁺¹⁾) and
with it u⁽ᵐ⁺²⁾ by the iteration's contraction, measured 1/30–1/100 per update). :class:`GeometryIteration`
therefore solves the first geometry to the reduction √rtol (when the geometry can change at all: pairs or a curved
obstacle; with planes only every solve is to rtol, bit for bit as small sliding), a geometry after a change of
Δ to θ·Δ/(e_r‖u‖_∞) (θ = :data:`LOOSE_FACTOR`, e_r = ERROR_PER_RTOL: a displacement error a tenth of the change
that prompted the update), never looser than the previous solve and never tighter than rtol; when the geometry of a
loose solve has settled, the same geometry is solved on to rtol and checked again. An update whose solve starts
already converged (no Newton step: u⁽ᵐ⁺¹⁾ = u⁽ᵐ⁾, the configuration itself) has settled without another check (a
loose one is solved on to rtol); a reduction within 10× of rtol is rtol (no separate solve on to rtol).
The reduction never increases, so once at rtol the iteration is the plain one above.

**Updates the residual does not see.** The stopping target bounds the residual's 2-norm over every DOF, rtol ×
‖ŷ(u = 0)‖; a geometry change of Δ at a few nodes changes that norm by about their stiffness × Δ, which can lie
below the target while the solution would move by Δ there. A solve that, right after an update, starts already
converged is therefore solved on until its start's residual has shrunk by ε/(2Δ) (at most by 1/2; after a change
of partners by LOOSE_FACTOR), and its solution is checked as any other. Measured (the two-body demo's mesh, the
block's top clamped, F = 0.3, LU, rtol 1e-7): the last update's change 1.22e-7 against ε = 1.6e-8, the start
residual 6.5e-7 under the target 1.44e-6, and the answer 1.19e-7 (59 rtol |u|∞) from rtol 1e-10's, where small
sliding ends 9 rtol |u|∞ away; now 0.56 rtol |u|∞. demos/scenes/slide_off.toml against its rtol 1e-11 path: up to
1.4e-6 in u (24 rtol |u|∞) and 0.18 % in the pressure before, 1.2e-8 and 2e-5 now, for 38 Newton steps / 287
Krylov iterations instead of 29 / 206.

**Nodes on a master edge.** Where the definitions have no fixed point (a slave node at a master edge: 2- and
3-cycles of the geometry), the cycle's nodes decide their geometry within its amplitude, once per solve, or the
cycle is accepted or fails: :mod:`fenics_coulomb.model.geometry_cycles`.
"""

from __future__ import annotations

import hashlib
import math
import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.geometry_cycles import (CYCLE_DIRECTION, CYCLE_ENERGY_TIE, CYCLE_TIE, CYCLE_TOLERANCE,
                                                  cycle_message, find_cycle, node_states)

if TYPE_CHECKING:  # pragma: no cover
    from fenics_coulomb.model.contact_model import ContactModel
    from fenics_coulomb.model.pairs import Pairing

__all__ = ["ACCURACY_SHARE", "ACCURACY_FLOOR", "MAX_GEOMETRY_UPDATES", "ROUND_OFF_STAGNATION", "ROUND_OFF_CAP",
           "LOOSE_FACTOR", "GeometryChange",
           "GeometryIteration", "geometry_change"]

Array = npt.NDArray[np.float64]

logger = logging.getLogger(__name__)

#: The most geometry updates of one solve (finite sliding).
MAX_GEOMETRY_UPDATES = 10

#: The geometry's round-off: a check at full accuracy whose nodes and supports are unchanged, like the previous
#: such check's, and whose largest change did not shrink below this × the previous one (the iteration contracts by
#: 1/30–1/100 per update; see "Accuracy of the intermediate solves") has reached the noise of its own data ...
ROUND_OFF_STAGNATION = 0.5
#: ... provided that change is below this × the mesh's extent (its bounding box's diagonal): then it is settled.
#: A configuration's gaps, normals and mortar weights come from coordinates of that size through projections,
#: clippings and quadratures whose relative error lies far above machine precision (measured: changes of 4e-11 on
#: blocks of extent 2.3 that no further update reduced, a drag patch test at rtol 1e-12 whose ε = 8.6e-13 then
#: never settled); another solve could not make u more accurate than its data.
ROUND_OFF_CAP = 1e-9

#: With an accuracy asked, the geometry's own error may take this share of it (the other half is the solve's and a
#: path's history).
ACCURACY_SHARE = 0.5

#: ... and a change below this × the mesh's extent counts as none (the coordinates' round-off, amplified by the
#: projections: the drag's first solves saw 2e-14–5e-14 at extent 2.4; ROUND_OFF_CAP is far too coarse here: the
#: cylinder roller's change of 9.5e-10 still moved u by 1.2 EPS at EPS 1e-6).
ACCURACY_FLOOR = 1e-12

#: An intermediate geometry is solved to a displacement error of this × the geometry change that prompted it (see
#: "Accuracy of the intermediate solves").
LOOSE_FACTOR = 0.1


@dataclass
class GeometryChange:
    """How G(u⁽ᵐ⁺¹⁾) differs from the geometry a solve used (the same on every rank).

    Attributes:
        settled: Same nodes and supports, and ``discrepancy`` <= ``tolerance``: no update needed.
        changed: The number of contact nodes that gained, lost or changed their partner (nodes or obstacle).
        discrepancy: The largest Δ_j over the nodes that kept their partner.
        tolerance: ε = e·‖u‖_∞.
        where: Current positions of up to three changed nodes (or of the node of the largest Δ_j).
        pairing: The pairing of X + u⁽ᵐ⁺¹⁾ (contact pairs; None for obstacles only), to adopt for the next solve.
    """

    settled: bool
    changed: int
    discrepancy: float
    tolerance: float
    where: list[tuple[float, float, float]] = field(default_factory=list)
    pairing: Pairing | None = None
    #: The contact nodes and supports of the geometry solved with and of the new one (equal on every rank).
    old_signature: str = ""
    new_signature: str = ""
    #: The new geometry's own displacement error (a length): its pairing's and its obstacles' ties were made to it.
    resolution: float = 0.0
    #: This rank's nodes of the coupling (pairs, local DOF blocks) that changed partner, lost it or gained one.
    moved_blocks: npt.NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, np.int32))
    #: Per owned node, a digest of its partner in either geometry (0: none; :func:`.geometry_cycles.node_states`).
    old_states: npt.NDArray[np.uint64] = field(default_factory=lambda: np.zeros(0, np.uint64))
    new_states: npt.NDArray[np.uint64] = field(default_factory=lambda: np.zeros(0, np.uint64))

    def describe(self) -> str:
        """One line for logs and errors."""
        at = ", ".join("(" + ", ".join(f"{c:.6g}" for c in x) + ")" for x in self.where)
        if self.changed:
            return f"{self.changed} contact node(s) changed partner, e.g. at {at}"
        return f"largest change of a gap or slip {self.discrepancy:.3g} > {self.tolerance:.3g} at {at}"


def _tangential(n: Array, v: Array) -> Array:
    return v - np.einsum("ij,ij->i", n, v)[:, None] * n


def _signature(comm: MPI.Comm, nodes: npt.NDArray[np.int64], rows: npt.NDArray[np.int64]) -> str:
    """A digest of the contact nodes (GLOBAL block indices) and their rows (obstacle index, or the sorted support's
    global master blocks, −1 padded), the same on every rank and for every partition (collective)."""
    rows = np.asarray(rows, np.int64)
    data = np.column_stack([np.asarray(nodes, np.int64).reshape(-1, 1), rows.reshape(len(nodes), rows.shape[-1])])
    width = comm.allreduce(data.shape[1], op=MPI.MAX)
    padded = np.full((data.shape[0], width), -1, np.int64)
    padded[:, :data.shape[1]] = data
    everyone = np.concatenate(comm.allgather(padded))
    everyone = everyone[np.lexsort(everyone.T[::-1])]
    return hashlib.sha256(everyone.tobytes()).hexdigest()


def _gather_where(comm: MPI.Comm, x: Array) -> list[tuple[float, float, float]]:
    everyone = np.concatenate(comm.allgather(np.asarray(x, dtype=np.float64).reshape(-1, 3)[:3]))
    order = np.lexsort(everyone.T[::-1]) if everyone.size else np.zeros(0, np.intp)
    return [(float(everyone[i, 0]), float(everyone[i, 1]), float(everyone[i, 2])) for i in order[:3]]


def geometry_change(model: ContactModel, u: Array, z: Array, previous: Array | None, accuracy: float,
                    active: npt.NDArray[np.bool_] | None = None, error: float = 0.0,
                    force: Array | None = None) -> GeometryChange:
    """Compare the contact geometry of X + u with the linearization the solve used (collective).

    Args:
        model: The contact model as it was solved (configured and placed).
        u: The solution's physical displacement, owned DOFs.
        z: The solution in the model's unknown (z = M⁻¹u; u for one body), owned DOFs.
        previous: The previous step's physical displacement (owned DOFs), None for 0.
        accuracy: The solve's relative displacement accuracy e (ε = e·‖u‖_∞).
        active: Per contact node of the model, whether the solution presses it (not open); None: every node.
            An open node whose gap in the new geometry is ≥ −ε is satisfied by the solution whatever its
            partner: its changes do not count (see the module docstring, "Open nodes").
        error: The relative displacement error of ``u`` itself (its solve's, a loose one's too): the pairing of
            X + u is made to error·‖u‖_∞ (:class:`~fenics_coulomb.model.pairs.stencils.PairInput`), and so are a
            triangulated obstacle's ties.
        force: The solution's contact force per contact node (m, 3), None: none. An obstacle node's normal that
            turned by Δn counts as the displacement |Δn|·|f|/k (k its stiffness, the diagonal of the elastic
            energy's matrix): the force's direction, and with it the node's response, turns with the normal —
            at a faceted obstacle's vertex the normal may turn where neither the gap nor the slip changes.
    """
    comm = model.comm
    cmap = model.contact
    ug = model.ghosted(u)
    U = ug.reshape(-1, 3)
    scale = comm.allreduce(float(np.max(np.abs(u), initial=0.0)), op=MPI.MAX)
    tolerance = accuracy * scale
    pressed = np.ones(cmap.size, dtype=bool) if active is None else np.asarray(active, dtype=bool)
    paired = model.coupling.paired_mask(cmap.size)
    rigid = np.flatnonzero(~paired)
    delta = np.zeros(cmap.size)
    moved = np.zeros(cmap.size, dtype=bool)
    x_now = cmap.coordinates + U[cmap.blocks]
    index: npt.NDArray[np.signedinteger] = np.zeros(0, np.intp)
    stiffness = model.coupling.node_stiffness(model) if force is not None and model.obstacles else None  # all ranks
    if rigid.size:
        uc = U[cmap.blocks[rigid]]
        index, g, n, _ = model.placement.closest(model.obstacles, x_now[rigid], error * scale)
        relevant = pressed[rigid] | (g < -tolerance)
        moved[rigid] = (index != cmap.obstacle_index[rigid]) & relevant
        n_old = cmap.frames[rigid][:, :, 2]
        linear = cmap.gap[rigid] + np.einsum("ij,ij->i", n_old, uc)
        v = uc - model.offset[rigid]
        dt = _tangential(n, v) - _tangential(n_old, v)
        turned = np.zeros(rigid.size)
        if stiffness is not None and force is not None:  # the normal's turn, as the displacement of its force
            turned = np.linalg.norm(n - n_old, axis=1) * np.linalg.norm(force[rigid], axis=1) / stiffness[rigid]
        delta[rigid] = np.where(relevant, np.sqrt((g - linear) ** 2 + np.einsum("ij,ij->i", dt, dt) + turned ** 2),
                                0.0)
    r0 = model.V.dofmap.index_map.local_range[0]
    pairs = model.coupling.stencil_change(model, u, z, previous, tolerance, pressed, error * scale)  # its own nodes
    moved[paired] = pairs.moved[paired]
    delta[paired] = pairs.delta[paired]
    gained_at = pairs.gained_at
    old_nodes, new_nodes = [cmap.blocks[rigid] + r0, *pairs.old_nodes], [cmap.blocks[rigid] + r0, *pairs.new_nodes]
    old_rows = [cmap.obstacle_index[rigid].reshape(-1, 1), *pairs.old_rows]
    new_rows = [index.reshape(-1, 1), *pairs.new_rows]
    delta[moved] = 0.0
    changed = comm.allreduce(int(np.sum(moved)) + int(gained_at.shape[0]), op=MPI.SUM)  # pressed or penetrating
    discrepancy = comm.allreduce(float(np.max(delta, initial=0.0)), op=MPI.MAX)
    if changed:
        where = _gather_where(comm, np.concatenate([x_now[moved], gained_at]))
    else:
        mine = delta.size and float(delta.max()) == discrepancy and discrepancy > 0.0
        where = _gather_where(comm, x_now[np.argmax(delta)][None, :] if mine else np.zeros((0, 3)))
    settled = changed == 0 and discrepancy <= tolerance

    def signature(nodes: list[npt.NDArray[np.int64]], rows: list[npt.NDArray[np.int64]]) -> str:
        width = max(r.shape[1] for r in rows)
        wide = [np.pad(r, ((0, 0), (0, width - r.shape[1])), constant_values=-1) for r in rows]
        # obstacle rows and pair rows apart: an obstacle index 0 is not a master block 0
        kind = [np.full((n.size, 1), k, np.int64) for k, n in enumerate(nodes)]
        return _signature(comm, np.concatenate(nodes), np.column_stack([np.concatenate(kind), np.concatenate(wide)]))

    owned = model.V.dofmap.index_map.size_local
    return GeometryChange(settled, changed, discrepancy, tolerance, where, pairs.pairing,
                          signature(old_nodes, old_rows), signature(new_nodes, new_rows), error * scale,
                          np.union1d(cmap.blocks[moved & paired], pairs.gained_blocks).astype(np.int32),
                          node_states(owned, r0, old_nodes, old_rows), node_states(owned, r0, new_nodes, new_rows))


@dataclass
class Step:
    """What the geometry iteration does after a solve.

    Attributes:
        action: "settled" (the solve is the answer), "update" (solve in G(u⁽ᵐ⁺¹⁾), adopting ``change.pairing``),
            "continue" (solve the same geometry on to rtol from the solution) or "fail" (no settling).
        change: The comparison of the geometries (None when none was needed).
        message: One line for the log or the error.
    """

    action: str
    change: GeometryChange | None = None
    message: str = ""


class GeometryIteration:
    """The decisions of one solve's geometry iteration (collective; the same on every rank): the reduction of
    every solve, when the geometry has settled, 2-cycles across master edges, the limit of updates. The solving
    itself stays with :class:`~fenics_coulomb.problem.ContactProblem`.

    Args:
        model: The contact model (configured and placed for the first solve).
        rtol: The solve's residual reduction; e = ``error_per_rtol``·rtol its relative displacement accuracy.
        error_per_rtol: The displacement error per unit of residual reduction.
        previous: The previous step's physical displacement (owned DOFs), None for 0.
    """

    def __init__(self, model: ContactModel, rtol: float, error_per_rtol: float, previous: Array | None,
                 accuracy: float | None = None) -> None:
        self.model = model
        #: A displacement accuracy asked for (``SolverSettings.accuracy``; None: the tolerance ε alone), see
        #: :meth:`_accurate`.
        self.accuracy = accuracy
        #: The largest displacement change per unit of the geometry change that prompted an update (None: none
        #: measured yet), and the last update's (change, solution before it).
        self.amplification: float | None = None
        self._update: tuple[float, Array] | None = None
        self.rtol = float(rtol)
        self.error_per_rtol = float(error_per_rtol)
        self.previous = previous
        fixed = not model.coupling.follows_configuration and all(o.affine for o in model.obstacles)
        #: The reduction of the next solve (never increasing).
        self.reduction = self.rtol if fixed else max(self.rtol, min(self.rtol ** 0.5, 1e-3))
        #: Geometry updates so far.
        self.updates = 0
        self._solved: list[tuple[str, Array, float]] = []  # (geometry, solution, reduction) of every solve
        self._moved: list[npt.NDArray[np.int32]] = []  # the nodes that changed partner after each of them
        self._states: list[npt.NDArray[np.uint64]] = []  # their nodes' partners (node_states)
        self._last = False
        self._cycle: float | None = None  # the amplitude of the last 2-cycle too wide to accept
        if previous is None:  # a path step keeps its previous step's ties: the same edges, the same ambiguity
            model.coupling.ties = None
        self._unchanged: float | None = None  # the last full-accuracy check's change with the same nodes
        self._pending: GeometryChange | None = None  # the last update's change, until a Newton step has followed it
        self._restore: float | None = None  # the reduction after a solve tightened to resolve an update
        x = model.V.mesh.geometry.x
        lo, hi = np.empty(3), np.empty(3)
        model.comm.Allreduce(np.ascontiguousarray(x.min(axis=0, initial=np.inf)), lo, op=MPI.MIN)
        model.comm.Allreduce(np.ascontiguousarray(x.max(axis=0, initial=-np.inf)), hi, op=MPI.MAX)
        #: The mesh's extent (its bounding box's diagonal), the scale of the geometry's round-off.
        self.extent = float(np.linalg.norm(hi - lo))

    def _at_configuration(self, u: Array, iterations: int) -> bool:
        """Whether a solve without a Newton step returned the configuration its geometry was evaluated at."""
        model = self.model
        if iterations or model.configuration is None:
            return False
        size = u.size
        configuration = model.configuration[:size]
        scale = model.comm.allreduce(float(np.max(np.abs(u), initial=0.0)), op=MPI.MAX)
        off = model.comm.allreduce(float(np.max(np.abs(u - configuration), initial=0.0)), op=MPI.MAX)
        return off <= 1e-12 * scale

    def after(self, u: Array, z: Array, reduction: float, iterations: int,
              active: npt.NDArray[np.bool_] | None = None, start: float = 0.0, force: Array | None = None) -> Step:
        """Decide after a solve to ``reduction`` with ``iterations`` Newton steps whose solution is ``u``
        (physical) / ``z`` (the model's unknown), both on the owned DOFs, pressing the contact nodes ``active``
        (None: every node counts) with the contact forces ``force`` (per node, (m, 3); None: not compared), its
        start's residual ``start`` times its target (collective)."""
        model, rtol = self.model, self.rtol
        if self._restore is not None:
            self.reduction, self._restore = self._restore, None
        if self._last:  # the kept geometry of an accepted 2-cycle, solved once more
            return Step("settled")
        pending = self._pending
        if iterations:  # a Newton step has followed the last update
            self._pending = None
        if self._at_configuration(u, iterations):  # G(u⁽ᵐ⁺¹⁾) = G(u⁽ᵐ⁾), exactly linearized
            if reduction <= rtol and pending is not None and 0.0 < start <= 1.0:
                # The start met the target in the geometry just updated: the residual's 2-norm does not see a
                # change of a few nodes' data, though it may move u there by up to Δ (see "Updates the
                # residual does not see"): solved on until the start's residual has shrunk by ε/(2Δ)
                self._pending = None
                factor = (min(0.5 * pending.tolerance / pending.discrepancy, 0.5)
                          if not pending.changed and pending.discrepancy > 0.0 else LOOSE_FACTOR)
                self._restore = self.reduction
                self.reduction = reduction * start * factor
                return Step("continue", None, f"the start meets the target of the updated geometry: solved on to "
                                              f"{self.reduction:.3g} to resolve its change")
            if reduction <= rtol:
                return Step("settled")
            self.reduction = rtol
            return Step("continue", None, f"the start meets the loose reduction {reduction:.3g}: solved on to rtol "
                                          f"{rtol:g}")
        self._measure(u, iterations, reduction <= rtol)
        change = geometry_change(model, u, z, self.previous, self.error_per_rtol * rtol, active,
                                 self.error_per_rtol * reduction, force)
        forced = change.settled and not self._accurate(change, u)  # ε met, the accuracy asked not
        change.settled = change.settled and not forced
        self._solved.append((change.old_signature, u, reduction))
        self._moved.append(change.moved_blocks)
        self._states.append(change.old_states)
        if change.settled:
            if reduction <= rtol:
                return Step("settled", change)
            self.reduction = rtol
            return Step("continue", change, f"the geometry settled: solved on to rtol {rtol:g}")
        if not change.changed and reduction <= rtol:
            previous, self._unchanged = self._unchanged, change.discrepancy
            if (previous is not None and change.discrepancy >= ROUND_OFF_STAGNATION * previous
                    and change.discrepancy <= ROUND_OFF_CAP * self.extent):
                if model.comm.rank == 0:
                    logger.info("finite sliding: the geometry's largest change %.3g no longer shrinks (%.3g before) "
                                "and lies below its round-off %.3g: settled", change.discrepancy, previous,
                                ROUND_OFF_CAP * self.extent)
                return Step("settled", change)
        else:
            self._unchanged = None
        measured = "none measured yet" if self.amplification is None else f"{self.amplification:.3g} measured"
        step = Step("update", change, change.describe() if not forced else
                    f"largest change of a gap or slip {change.discrepancy:.3g} (ε {change.tolerance:.3g}), times the "
                    f"displacement per change ({measured}), may exceed the accuracy {self.accuracy:g} asked")
        self._pending = change
        # measured between two solves at the full accuracy only: from a loose solve, the first change (a drag's whole
        # increment) moves u in another pattern than the iteration's last ones
        self._update = (change.discrepancy, u.copy()) if self.accuracy is not None and not change.changed \
            and change.discrepancy > ACCURACY_FLOOR * self.extent and reduction <= rtol else None
        solved, message = self._solved, ""
        cycle = find_cycle(model.comm, solved, self._moved, self._states, change.new_signature, change.new_states, u,
                           rtol, self.error_per_rtol) if change.changed else None
        if cycle is not None:
            if not cycle.accurate:
                self.reduction = rtol  # a cycle seen at loose accuracy: look again at rtol
            width = np.full(cycle.blocks.size, CYCLE_TIE * cycle.amplitude)
            if cycle.tieable and model.coupling.tie(model, cycle.blocks, width):  # nodes not tied before: again
                change = geometry_change(model, u, z, self.previous, self.error_per_rtol * rtol, active,
                                         self.error_per_rtol * reduction, force)
                # a tied geometry may share a cycle state's digest
                self._pending, self._solved, self._moved, self._states = change, [], [], []
                step = Step("update", change, f"a {cycle.length}-cycle ({cycle.amplitude:.3g}): its nodes' geometry "
                                              f"decided within {CYCLE_TIE * cycle.amplitude:.3g}")
            elif cycle.accurate and cycle.length == 2 and cycle.whole:
                h = model.comm.allreduce(float(np.min(model.node_size()[model.contact.blocks], initial=np.inf)),
                                         op=MPI.MIN)
                if cycle.amplitude <= CYCLE_TOLERANCE * h:
                    if model.comm.rank == 0:
                        logger.warning("finite sliding: %s, back and forth between two geometries whose solutions "
                                       "differ by %.3g (%.2g of the smallest cell at the contact nodes): the one of "
                                       "the smaller elastic energy is kept", change.describe(), cycle.amplitude,
                                       cycle.amplitude / h)
                    now, other = model.elastic_energy(u), model.elastic_energy(cycle.other)
                    if abs(now - other) <= CYCLE_ENERGY_TIE * max(abs(now), abs(other)):
                        now, other = (float(model.comm.allreduce(w.reshape(-1, 3).sum(axis=0), op=MPI.SUM)
                                            @ CYCLE_DIRECTION) for w in (u, cycle.other))
                    if now <= other:
                        return Step("settled", change)
                    self._last = True  # one more solve, in the other geometry of the cycle
                else:
                    message = cycle_message(cycle.amplitude, h, model.coupling.cycle_cure())
                    previous, self._cycle = self._cycle, cycle.amplitude
                    if previous is not None and cycle.amplitude > 0.5 * previous:  # the same cycle, not shrinking
                        return Step("fail", change, f"finite sliding: the contact geometry did not settle after "
                                                    f"{self.updates} updates ({change.describe()}){message}")
        if self.updates == MAX_GEOMETRY_UPDATES:
            return Step("fail", change, f"finite sliding: the contact geometry did not settle after "
                                        f"{self.updates} updates ({change.describe()}){message}")
        if not change.changed:
            scale = model.comm.allreduce(float(np.max(np.abs(u), initial=0.0)), op=MPI.MAX)
            wanted = LOOSE_FACTOR * change.discrepancy / (self.error_per_rtol * scale) if scale > 0 else rtol
            self.reduction = min(self.reduction, rtol if wanted <= 10.0 * rtol else wanted)
        if 2 * self.updates >= MAX_GEOMETRY_UPDATES:
            self.reduction = rtol
        self.updates += 1
        return step

    def _measure(self, u: Array, iterations: int, accurate: bool) -> None:
        """After the solve that followed an update prompted by a change Δ of the data (max-norm), both solves at the
        full accuracy (``accurate``: this one): how far it moved u per unit of Δ, in the 2-norm of the accuracy
        (collective)."""
        if self._update is None or not iterations or not accurate:
            return
        delta, before = self._update
        self._update = None
        moved = math.sqrt(self.model.comm.allreduce(float(np.dot(u - before, u - before)), op=MPI.SUM))
        self.amplification = max(self.amplification or 0.0, moved / delta)

    def _accurate(self, change: GeometryChange, u: Array) -> bool:
        """With an accuracy asked: whether the new geometry's change Δ could move u by more than it, judged by
        the displacement per unit of data change the updates so far measured (Δ·A ≤ ACCURACY_SHARE·accuracy·‖u‖₂;
        none measured yet: no change at all). The tolerance ε bounds Δ, not u: a change of 6.7e-8 against ε = 1e-7
        left the cylinder roller's u 1.06e-6 (16 Δ) from the settled geometry's, 7.8 EPS in the 2-norm (collective)."""
        if self.accuracy is None or change.changed or change.discrepancy <= ACCURACY_FLOOR * self.extent:
            return True  # a change at the coordinates' round-off: nothing another solve could resolve
        if self.amplification is None:
            return False
        size = math.sqrt(self.model.comm.allreduce(float(np.dot(u, u)), op=MPI.SUM))
        return change.discrepancy * self.amplification <= ACCURACY_SHARE * self.accuracy * size
