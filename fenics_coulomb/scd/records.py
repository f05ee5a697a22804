"""What a solve holds and reports: its iterates and Newton directions, one record per Newton iteration and the result
of the whole solve."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.scd.resolvent import OPEN, SLIP, STICK

__all__ = ["Iterate", "Direction", "IterationRecord", "global_state_counts", "SolveResult"]

Array = npt.NDArray[np.float64]


@dataclass
class Iterate:
    """An iterate u with its residual r = A u − l and its approximation step (e = u − d̂, v = d̂ and z on the
    contact nodes, ‖ŷ‖)."""

    u: Array
    r: Array
    e: Array
    v: Array
    z: Array
    residual: float


@dataclass
class Direction:
    """A Newton direction Δu with the Krylov iterations, forcing term and linear residual of its solve."""

    du: Array
    krylov_iterations: int
    forcing: float
    linear_residual: float



@dataclass
class IterationRecord:
    """One Newton iteration: residual after it, step length, Krylov iterations, contact states, the
    forcing term η of its linear solve and the relative unpreconditioned residual the solve reached."""

    iteration: int
    residual: float
    step_length: float
    krylov_iterations: int
    open: int
    stick: int
    slip: int
    forcing: float
    linear_residual: float


def global_state_counts(comm: MPI.Comm, states: npt.NDArray[np.int8]) -> dict[str, int]:
    """Global number of open / stick / slip contact nodes (collective)."""
    local = np.array([np.sum(states == s) for s in (OPEN, STICK, SLIP)], dtype=np.int64)
    total = comm.allreduce(local, op=MPI.SUM)
    return {"open": int(total[0]), "stick": int(total[1]), "slip": int(total[2])}


@dataclass
class SolveResult:
    """Outcome of a contact solve (arrays are this rank's owned entries; scalars are global).

    Attributes:
        u: Shifted displacement u = ũ + d (owned DOFs).
        displacement: Physical displacement ũ (owned DOFs).
        converged: Whether the stopping rule was met.
        reason: "converged" or the cause of failure.
        iterations: Newton iterations taken (1 for a linear solve).
        krylov_iterations: Total Krylov iterations.
        residual_history: ‖ŷ⁽ᵏ⁾‖, k = 0, 1, ...
        records: Per-iteration records (k >= 1).
        sets: Set of (6.9) per owned contact node at the final iterate.
        states: OPEN/STICK/SLIP per owned contact node.
        normal_force: Normal contact force λ = −ϑ >= 0 per owned contact node.
        tangential_force: Tangential contact force on the body in the node's frame (t₁, t₂ components),
            −g ∈ R² (opposite to the slip).
        contact_force: The contact force on the body per owned contact node, Cartesian, −Rᵢ zⁱ, shape (m, 3).
        gap: Final gap per owned contact node (from the approximation step, d̂3 >= 0).
        gamma: γ of the approximation step (off the contact nodes, and the cap of every γᵢ).
        node_gamma: (min, max) over the contact nodes of their γᵢ (see :mod:`fenics_coulomb.scd.newton`).
        rtol: The residual reduction used (``rtol``, or the one ``accuracy`` maps to).
        checks: The physics residuals of the solution (:func:`fenics_coulomb.model.checks.physics_residuals`), which
            decide whether a solve that met its stopping target counts as converged.
        target: The residual norm that ended the iteration, rtol·‖ŷ(ũ = 0)‖ or the round-off floor
            (:mod:`fenics_coulomb.scd.stopping`; 0 for a linear solve).
        timings: Wall time per phase in seconds (this rank).
        pc: The preconditioner used (``auto`` resolved) at the end of the solve.
        pc_history: The changes of preconditioner under ``auto`` so far (Newton step, from, to, the Krylov iterations
            of the stagnated solve, its reason; :meth:`fenics_coulomb.scd.newton.SCDNewtonSolver._escalate`).
        n: Unknowns after removing the Dirichlet DOFs (global).
        p: Contact nodes (global).
        counts: Global open/stick/slip counts at the final iterate.
        linear: Whether the result is the one linear solve of the predictor or the no-contact shortcut.
        relative_displacement: Contact pairs: the solver's unknown z (w_s on the slave contact nodes), owned
            DOFs; None for one body.
        master_force: Contact pairs: the reaction on the master nodes f_j = −Σ_s φ_sj f_s, owned DOFs.
        geometry_updates: Finite sliding: how often the contact geometry was evaluated again in the deformed
            configuration and the problem solved again (0: the first geometry held).
        largest_slide: Small sliding: the largest slide of a contact node against its partner in partner sizes and
            that node (:func:`fenics_coulomb.model.small_sliding.largest_slide`); empty for finite sliding.
        free_penetration: Contact pairs: the free slave nodes (over a master surface, but no contact nodes) that
            penetrate it, ``{"nodes": count, "depth": deepest −g}``; empty when none does.
        history_geometry: Finite sliding: the solve of the geometry iteration (0, 1, ...) each entry of
            ``residual_history`` belongs to, whose histories follow one another there and in ``records`` (each
            solve's first entry is its initial residual); empty: one solve.
        origin: The problem and its state that made the result (:meth:`ContactProblem.check_result
            <fenics_coulomb.problem.ContactProblem.check_result>`); None for a result no problem finished.
    """

    u: Array
    displacement: Array
    converged: bool
    reason: str
    iterations: int
    krylov_iterations: int
    residual_history: list[float]
    records: list[IterationRecord]
    sets: npt.NDArray[np.int8]
    states: npt.NDArray[np.int8]
    normal_force: Array
    tangential_force: Array
    gap: Array
    gamma: float
    contact_force: Array = field(default_factory=lambda: np.zeros((0, 3)))
    timings: dict[str, float] = field(default_factory=dict)
    pc: str = ""
    pc_history: list[dict[str, Any]] = field(default_factory=list)
    n: int = 0
    p: int = 0
    counts: dict[str, int] = field(default_factory=dict)
    linear: bool = False
    node_gamma: tuple[float, float] = (0.0, 0.0)
    rtol: float = 0.0
    target: float = 0.0
    checks: dict[str, Any] = field(default_factory=dict)
    relative_displacement: Array | None = None
    master_force: Array | None = None
    geometry_updates: int = 0
    largest_slide: dict[str, Any] = field(default_factory=dict)
    free_penetration: dict[str, Any] = field(default_factory=dict)
    history_geometry: list[int] = field(default_factory=list)
    origin: tuple[int, int] | None = None

    def state_counts(self, comm: MPI.Comm) -> dict[str, int]:
        """Global number of open / stick / slip contact nodes (collective)."""
        return global_state_counts(comm, self.states)

    def summary(self, comm: MPI.Comm) -> dict[str, Any]:
        """The solver's part of summary.json (collective; identical on all ranks)."""
        timings = {key: comm.allreduce(value, op=MPI.MAX) for key, value in self.timings.items()}
        return {
            "n": self.n,
            "p": self.p,
            "converged": self.converged,
            "reason": self.reason,
            "newton_iterations": self.iterations,
            "krylov_iterations": self.krylov_iterations,
            "residual_history": list(self.residual_history),
            "step_lengths": [rec.step_length for rec in self.records],
            "krylov_history": [rec.krylov_iterations for rec in self.records],
            "forcing_history": [rec.forcing for rec in self.records],
            "geometry_history": list(self.history_geometry) or [0] * len(self.residual_history),
            "wall_time_s": timings.get("total", 0.0),
            "state_counts": self.state_counts(comm),
            "gamma": self.gamma,
            "node_gamma": list(self.node_gamma),
            "rtol": self.rtol,
            "stopping_target": self.target,
            "physics_checks": dict(self.checks),
            "preconditioner": self.pc,
            "preconditioner_history": [dict(h) for h in self.pc_history],
            "timings_s": timings,
            "ranks": comm.size,
            "geometry_updates": self.geometry_updates,
            **({"small_sliding": dict(self.largest_slide)} if self.largest_slide else {}),
            **({"free_slave_penetration": dict(self.free_penetration)} if self.free_penetration else {}),
        }
