# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # Mindlin–Deresiewicz: a rigid sphere pressed on a block and dragged back and forth
#
# A quasi-static load path with the Python API (`ContactProblem.solve()` is one step of a path; issue 14):
# a rigid sphere is pressed into an elastic block (step 1), then dragged tangentially back and forth by
# less than gross sliding. Coulomb friction makes the response path dependent: the tangential force Q
# against the tangential displacement δ_t traces a hysteresis loop, and the stick zone under the sphere
# shrinks as |Q| grows. Both are compared with the classical theory of Cattaneo (1938), Mindlin (1949)
# and Mindlin & Deresiewicz (1953) (see Johnson, *Contact Mechanics*, §7.2–7.3).
#
# ```
# python3 benchmarks/mindlin.py --quick                       # a coarse mesh, a few steps (seconds)
# python3 benchmarks/mindlin.py --out docs/mindlin              # the numbers and figures of docs/mindlin (4 min)
# mpirun -n 2 python3 benchmarks/mindlin.py --out out/mindlin    # the same on 2 ranks
# python3 benchmarks/mindlin.py --redraw --out docs/mindlin     # figures and README.md again from summary.json
# ```

# %%
from __future__ import annotations

import argparse
import csv
import itertools
import json
import logging
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb import ContactProblem, ContactState, SolverError, Sphere, box_partitioner

logger = logging.getLogger("mindlin")

#: Material (GPa), lengths in mm (forces in kN). ν = 0.45: see "the coupling" below.
E, NU, FRICTION = 70.0, 0.45, 0.3
G = E / (2 * (1 + NU))
E_STAR = E / (1 - NU**2)
#: Sphere radius and the Hertz contact radius aimed at: the indentation depth δ_n = a²/R.
RADIUS, A_TARGET = 10.0, 1.0
DEPTH = A_TARGET**2 / RADIUS
#: The physics checks of every step (on the step's increment: friction against the slip increment).
PHYSICS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction",
           "reaction_balance")
#: Facet tags of the block.
TOP, BOTTOM, SIDES = 1, 2, 3

# %% [markdown]
# ## The theory
#
# **Hertz (step 1).** The sphere of radius R pushed a depth δ_n into the block makes a circular contact of
# radius a with the normal force P, a³ = 3PR/(4E*), E* = E/(1 − ν²) (for a half-space, a = √(R δ_n)).
# The finite block (clamped at the bottom) is stiffer than a half-space, so P and a are MEASURED from
# step 1 and the formulas below use them.
#
# **Cattaneo–Mindlin (first tangential loading).** Holding P, a tangential force Q < FP applied to the
# sphere makes an annulus c ≤ r ≤ a slip with the traction F·p(r), while the disc r < c sticks:
#
#     c = a (1 − Q/(FP))^{1/3},
#     Q(δ_t) = FP [1 − (1 − δ_t/δ_t*)^{3/2}],   δ_t* = 3FP(2 − ν)/(16 G a),
#
# δ_t the tangential displacement of the sphere against the body's far field; the initial stiffness is
# dQ/dδ_t = 8Ga/(2 − ν), and at δ_t = δ_t* the whole contact slides (gross sliding).
#
# **Mindlin–Deresiewicz (unloading and reloading).** Reversing from (δ_t^r, Q^r) a new slip annulus
# with the opposite traction grows from the edge, and the change of the state is twice the first-loading
# solution at half the change (Masing's rule):
#
#     Q(δ_t) = Q^r − 2 Q_CM((δ_t^r − δ_t)/2),   c' = a (1 − |Q − Q^r|/(2FP))^{1/3},
#
# so that cycling between ±Δ gives a closed loop traversed clockwise: unloading from (Δ, Q*) starts with
# the full-stick stiffness 8Ga/(2 − ν), lies BELOW the reloading branch (and below the first-loading curve)
# at every δ_t, passes δ_t = 0 with the reversed force Q* − 2 Q_CM(Δ/2) < 0 (Q_CM is concave) and ends at
# (−Δ, −Q*); reloading is its mirror image and returns to (Δ, Q*), where the tractions, hence the whole
# state, are those of the first loading again (the loop closes). The area of the loop is the energy
# dissipated by the slip per cycle.
#
# **The coupling.** The theory assumes that Q does not change the pressure and that pressing the sphere
# causes no tangential tractions. For a rigid indenter on an elastic body the tangential and normal
# problems are coupled through Dundurs' constant β = (1 − 2ν)/(2(1 − ν)) (0.29 for ν = 0.3); at ν = 0.45 it
# is 0.09, so the theory applies closely (with friction, pressing already makes a thin edge annulus slip
# radially inward — Spence's solution — which β → 0 removes). The price is that linear elements stiffen
# (lock) as ν → 1/2, moderately at ν = 0.45 on Q1 hexahedra, and that ILU-preconditioned GMRES stagnates:
# the demo uses GAMG.


# %%
def cm_force(delta: npt.ArrayLike, friction_force: float, delta_star: float) -> npt.NDArray[np.float64]:
    """Cattaneo–Mindlin Q(δ_t) on first loading (odd in δ_t, capped at F·P beyond gross sliding)."""
    delta = np.asarray(delta, dtype=np.float64)
    x = np.clip(np.abs(delta) / delta_star, 0.0, 1.0)
    return np.sign(delta) * friction_force * (1.0 - (1.0 - x) ** 1.5)


def delta_star(friction_force: float, a: float, shear_modulus: float = G, nu: float = NU) -> float:
    """δ_t* = 3FP(2 − ν)/(16 G a): the tangential displacement of gross sliding."""
    return 3.0 * friction_force * (2.0 - nu) / (16.0 * shear_modulus * a)


@dataclass
class Masing:
    """Mindlin–Deresiewicz along any path of δ_t: the last reversal point and the branch factor."""

    friction_force: float
    delta_star: float
    turn_delta: float = 0.0
    turn_force: float = 0.0
    factor: float = 1.0  # 1 on the virgin curve, 2 after a reversal
    direction: float = 0.0
    last_delta: float = 0.0
    last_force: float = 0.0

    def step(self, delta: float) -> tuple[float, float]:
        """Q and the stick-radius ratio c/a at the next δ_t of the path."""
        move = delta - self.last_delta
        if move != 0.0:
            direction = float(np.sign(move))
            if self.direction != 0.0 and direction != self.direction:
                self.turn_delta, self.turn_force, self.factor = self.last_delta, self.last_force, 2.0
            self.direction = direction
        k = self.factor
        change = float(cm_force((delta - self.turn_delta) / k, self.friction_force, self.delta_star)) * k
        force = self.turn_force + change
        ratio = max(1.0 - abs(change) / (k * self.friction_force), 0.0) ** (1.0 / 3.0)
        self.last_delta, self.last_force = delta, force
        return force, ratio


def loop_area(delta: npt.ArrayLike, force: npt.ArrayLike) -> float:
    """∮ Q dδ_t of a closed path (trapezoidal; positive for a clockwise loop in the (δ_t, Q) plane)."""
    d, q = np.asarray(delta, dtype=np.float64), np.asarray(force, dtype=np.float64)
    return float(np.sum(0.5 * (q[1:] + q[:-1]) * np.diff(d)))


# %% [markdown]
# ## The mesh: a block graded toward the contact
#
# The block [−W, W]² × [−D, 0] is a `create_box` of hexahedra whose vertices are moved by a coordinate
# map per direction: uniform cells of edge h within the core |x|, |y|, −z ≤ 1.25 a (the contact radius is
# about a), then cells growing by a constant ratio (1.35) up to the block's faces 10 a away; the grading
# is a tensor product, so the cells stay within an aspect ratio of about 10 (much stronger grading, e.g.
# 1.6 out to 16 a, makes GAMG stall). The bottom is clamped, the sides are free, the top is the contact
# boundary. `--quick` takes h = a/3, a 1.4 a core and the faces 6 a away.


# %%
def graded_coordinates(h: float, core: float, length: float, growth: float) -> npt.NDArray[np.float64]:
    """Node positions 0 = x₀ < x₁ < … = ``length``: spacing h up to ``core``, then growing by ``growth``."""
    nodes = list(np.arange(0.0, core + 0.5 * h, h))
    n_core = len(nodes)
    step = h
    while nodes[-1] < length:
        step *= growth
        nodes.append(nodes[-1] + step)
    nodes = np.asarray(nodes)
    # stretch the graded part so that the last node is exactly ``length``
    graded = nodes[n_core - 1:]
    nodes[n_core - 1:] = graded[0] + (graded - graded[0]) * (length - graded[0]) / (graded[-1] - graded[0])
    return nodes


@dataclass(frozen=True)
class MeshSpec:
    """The graded block: core cell size h, half-width W and depth D (all relative to a), growth ratio."""

    h: float = 1.0 / 4.0
    width: float = 10.0
    depth: float = 10.0
    growth: float = 1.35
    core: float = 1.25


QUICK_MESH = MeshSpec(h=1.0 / 3.0, width=6.0, depth=6.0, growth=1.5, core=1.4)


def graded_block(comm: MPI.Comm, spec: MeshSpec, a: float = A_TARGET) -> tuple[dolfinx.mesh.Mesh,
                                                                                 dolfinx.mesh.MeshTags]:
    """The graded block and its facet tags TOP, BOTTOM, SIDES (collective)."""
    lateral = graded_coordinates(spec.h * a, spec.core * a, spec.width * a, spec.growth)
    vertical = graded_coordinates(spec.h * a, spec.core * a, spec.depth * a, spec.growth)
    xs = np.concatenate([-lateral[:0:-1], lateral])
    zs = -vertical[::-1]
    n = [xs.size - 1, xs.size - 1, zs.size - 1]
    corners = [np.zeros(3), np.asarray(n, dtype=np.float64)]  # index space, mapped below
    msh = dolfinx.mesh.create_box(comm, corners, n, dolfinx.mesh.CellType.hexahedron,
                                  partitioner=box_partitioner(corners, n, dolfinx.mesh.GhostMode.none),
                                  ghost_mode=dolfinx.mesh.GhostMode.none)
    x = msh.geometry.x
    index = np.rint(x).astype(np.int64)
    x[:, 0], x[:, 1], x[:, 2] = xs[index[:, 0]], xs[index[:, 1]], zs[index[:, 2]]
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    W, D = xs[-1], -zs[0]
    where = [(TOP, lambda p: np.isclose(p[2], 0.0)), (BOTTOM, lambda p: np.isclose(p[2], -D)),
             (SIDES, lambda p: np.isclose(np.abs(p[0]), W) | np.isclose(np.abs(p[1]), W))]
    facets = [dolfinx.mesh.locate_entities_boundary(msh, fdim, f) for _, f in where]
    indices = np.hstack(facets).astype(np.int32)
    values = np.hstack([np.full(f.size, tag, np.int32) for (tag, _), f in zip(where, facets, strict=True)])
    indices, first = np.unique(indices, return_index=True)  # an edge facet keeps its first tag
    return msh, dolfinx.mesh.meshtags(msh, fdim, indices, values[first])


# %% [markdown]
# ## The problem
#
# The sphere is the obstacle `Sphere(center=(0, 0, R), radius=R, name="indenter")`, touching the block's
# top at the origin. Step 1 moves it down by δ_n (`problem.move("indenter", (0, 0, −δ_n))`), every later
# step drags it along x to δ_t (`move` takes the TOTAL displacement). Friction acts on the slip increment of
# each step, s = T(u_k − u_{k−1}) − T(δ_k − δ_{k−1}): this is what makes the path matter.
#
# Solver: GAMG (ILU stagnates at ν = 0.45) and Eisenstat–Walker forcing terms (`adaptive_tol`). The path is
# driven by the obstacle alone (no load, l̃ = 0), so the stopping rule's load-relative target is 0 and each
# step iterates down to the round-off floor of the residual; the superlinear tail of the adaptive forcing
# gets there in about half the Newton iterations of the fixed GMRES tolerance (6 instead of 12 per step,
# measured on the `--quick` mesh).


# %%
def elasticity(V: dolfinx.fem.FunctionSpace, young: float = E, nu: float = NU) -> ufl.Form:
    mu, lmbda = young / (2 * (1 + nu)), young * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    dx = ufl.Measure("dx", domain=V.mesh, metadata={"quadrature_degree": 2})
    return ufl.inner(2 * mu * eps(u) + lmbda * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * dx


def create_problem(comm: MPI.Comm, spec: MeshSpec, friction: float = FRICTION,
                   settings: dict | None = None, prefix: str = "mindlin_") -> ContactProblem:
    """The block, clamped at its bottom, under the sphere at its scene position (collective)."""
    msh, tags = graded_block(comm, spec)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    bottom = dolfinx.fem.locate_dofs_topological(V, 2, tags.find(BOTTOM))
    bc = dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType), bottom, V)
    sphere = Sphere(center=(0.0, 0.0, RADIUS), radius=RADIUS, name="indenter")
    return ContactProblem(elasticity(V), None, bcs=[bc], contact=(tags, [TOP]), friction=friction,
                          obstacles=[sphere], settings={"pc": "gamg", "adaptive_tol": True, **(settings or {})},
                          petsc_options_prefix=prefix)


# %% [markdown]
# ## Measuring Q, P, a and the stick radius
#
# * **Q, P**: the sums of the nodal contact forces on the body: Q its x component, P minus its z component.
# * **a**: the radius separating closed (stick or slip) from open contact nodes best, **c** the radius
#   separating stick from slip nodes among the closed ones: the threshold r* minimizing the number of nodes
#   on the wrong side (inner nodes beyond r*, outer nodes within it), midway between two consecutive rings
#   of nodes (nodes at the same distance from the axis; ties: the mean). Where the states change from one
#   ring to the next this is the midpoint between the outermost inner ring and the innermost outer one; a
#   few stray nodes do not move it.


# %%
def separating_radius(r: npt.ArrayLike, inner: npt.ArrayLike) -> float:
    """The radius separating the ``inner`` nodes (within) from the others (beyond) best (see above).

    Nodes at the same radius (up to round-off) are one ring: thresholds lie only between rings, so the
    result does not depend on the order of the nodes (nor on the number of ranks).
    """
    r, inner = np.asarray(r, dtype=np.float64), np.asarray(inner, dtype=bool)
    if not inner.any():
        return 0.0
    if inner.all():
        return float(r.max())
    rings, ring = np.unique(np.round(r / r.max(), 9), return_inverse=True)
    size = np.bincount(ring, minlength=rings.size)
    radius = np.bincount(ring, weights=r, minlength=rings.size) / size
    n_inner = np.bincount(ring, weights=inner.astype(np.float64), minlength=rings.size)
    # threshold k: the first k rings inside; misplaced = outer nodes within + inner nodes beyond
    outer_within = np.concatenate([[0], np.cumsum(size - n_inner)])
    inner_beyond = n_inner.sum() - np.concatenate([[0], np.cumsum(n_inner)])
    errors = outer_within + inner_beyond
    ks = np.flatnonzero(errors == errors.min())
    ks = ks[(ks > 0) & (ks < rings.size)] if np.any((ks > 0) & (ks < rings.size)) else ks
    mids = 0.5 * (radius[np.clip(ks - 1, 0, rings.size - 1)] + radius[np.clip(ks, 0, rings.size - 1)])
    return float(np.mean(mids))


@dataclass
class Step:
    """One step of the path (global values, the same on every rank)."""

    step: int
    branch: str
    delta_t: float
    force_t: float
    force_n: float
    contact_radius: float
    stick_radius: float
    md_force: float = float("nan")
    md_stick_radius: float = float("nan")
    counts: dict[str, int] = field(default_factory=dict)
    physics_residual: float = float("nan")
    newton_iterations: int = 0
    krylov_iterations: int = 0
    wall_time_s: float = 0.0


def measure(problem: ContactProblem, result, step: int, branch: str, delta_t: float, wall: float) -> Step:
    """The step's forces and radii (collective)."""
    comm = problem.model.comm
    cmap = problem.model.contact
    total = np.asarray(comm.allreduce(result.contact_force.sum(axis=0), op=MPI.SUM))
    r = np.hypot(cmap.coordinates[:, 0], cmap.coordinates[:, 1])
    gathered = comm.allgather((r, result.states))
    r_all = np.concatenate([g[0] for g in gathered])
    states = np.concatenate([g[1] for g in gathered])
    closed = states != ContactState.OPEN
    a = separating_radius(r_all, closed)
    c = separating_radius(r_all[closed], states[closed] == ContactState.STICK)
    checks = problem.checks(result)
    worst = max(checks[key] for key in PHYSICS)
    return Step(step=step, branch=branch, delta_t=delta_t, force_t=float(total[0]), force_n=-float(total[2]),
                contact_radius=a, stick_radius=c, counts=dict(result.counts), physics_residual=worst,
                newton_iterations=result.iterations,
                krylov_iterations=result.krylov_iterations, wall_time_s=wall)


# %% [markdown]
# ## The path
#
# Step 1 presses the sphere down by δ_n. From its P and a the gross-sliding displacement δ_t* follows,
# and the sphere is dragged 0 → +Δ → −Δ → +Δ with Δ = `amplitude`·δ_t* (< δ_t*: no gross sliding), in
# `substeps` equal steps for the first quarter and twice as many for each half cycle.


# %%
@dataclass
class Cycle:
    """The result of a run: the steps, the theory's constants and the mesh's size."""

    steps: list[Step]
    force_n: float
    contact_radius: float
    hertz_radius: float
    delta_star: float
    amplitude: float
    unknowns: int
    contact_nodes: int
    spec: MeshSpec
    snapshots: dict[int, npt.NDArray[np.float64]] = field(default_factory=dict)


def schedule(amplitude: float, substeps: int) -> list[tuple[str, float]]:
    """The tangential displacements 0 → Δ → −Δ → Δ with their branch names."""
    up = [("loading", amplitude * j / substeps) for j in range(1, substeps + 1)]
    down = [("unloading", amplitude * (1.0 - 2.0 * j / (2 * substeps))) for j in range(1, 2 * substeps + 1)]
    back = [("reloading", amplitude * (-1.0 + 2.0 * j / (2 * substeps))) for j in range(1, 2 * substeps + 1)]
    return up + down + back


def run_cycle(comm: MPI.Comm = MPI.COMM_WORLD, spec: MeshSpec = MeshSpec(), amplitude: float = 0.75,  # noqa: B008 (a frozen dataclass)
              substeps: int = 4, friction: float = FRICTION, settings: dict | None = None,
              keep: bool = False) -> Cycle:
    """Press, then cycle the sphere tangentially; measure every step (collective).

    With ``keep`` the owned displacement values of every step are kept in ``Cycle.snapshots``.
    """
    with create_problem(comm, spec, friction, settings) as problem:
        t0 = time.perf_counter()
        problem.move("indenter", (0.0, 0.0, -DEPTH))
        _, result = problem.solve()
        first = measure(problem, result, 1, "normal", 0.0, time.perf_counter() - t0)
        P, a = first.force_n, first.contact_radius
        hertz_a = (3.0 * P * RADIUS / (4.0 * E_STAR)) ** (1.0 / 3.0)
        star = delta_star(friction * P, hertz_a)
        md = Masing(friction * P, star)
        first.md_force, first.md_stick_radius = 0.0, hertz_a
        steps = [first]
        snapshots = {1: result.displacement.copy()} if keep else {}
        _log(comm, first)
        for k, (branch, d) in enumerate(schedule(amplitude * star, substeps), start=2):
            t0 = time.perf_counter()
            problem.move("indenter", (d, 0.0, -DEPTH))
            _, result = problem.solve()
            s = measure(problem, result, k, branch, d, time.perf_counter() - t0)
            q, ratio = md.step(d)
            s.md_force, s.md_stick_radius = q, ratio * hertz_a
            steps.append(s)
            if keep:
                snapshots[k] = result.displacement.copy()
            _log(comm, s)
        return Cycle(steps=steps, force_n=P, contact_radius=a, hertz_radius=hertz_a, delta_star=star,
                     amplitude=amplitude * star, unknowns=problem.n, contact_nodes=problem.p, spec=spec,
                     snapshots=snapshots)


def _log(comm: MPI.Comm, s: Step) -> None:
    if comm.rank == 0:
        logger.info("step %2d %-9s dt=%+.3e Q=%+.4e (MD %+.4e) P=%.4e a=%.3f c=%.3f (MD %.3f) "
                    "newton %d krylov %d %.1fs %s", s.step, s.branch, s.delta_t, s.force_t, s.md_force, s.force_n,
                    s.contact_radius, s.stick_radius, s.md_stick_radius, s.newton_iterations, s.krylov_iterations,
                    s.wall_time_s, s.counts)


# %% [markdown]
# ## Comparing with the theory
#
# The numbers reported (and written to `summary.json`): the error of Q at the end of the first loading
# against Cattaneo–Mindlin, the largest |Q − Q_MD|/FP over the path, how far the loop fails to close
# (Q at the end of the cycle against Q at the end of the first loading, both at δ_t = Δ), the loop area
# (the energy dissipated per cycle) against Mindlin–Deresiewicz's closed form
#
#     W = 9 (FP)² (2 − ν)/(10 G a) · [1 − (1 − Q*/FP)^{5/3} − (5Q*/(6FP)) (1 + (1 − Q*/FP)^{2/3})]
#
# and against the same trapezoidal rule applied to the theory's Q at the same δ_t (the steps are coarse),
# the stick radius against c of the theory, and the change of P during the cycle (the coupling).


# %%
def dissipation(friction_force: float, a: float, q_max: float, shear_modulus: float = G, nu: float = NU) -> float:
    """Mindlin–Deresiewicz's energy dissipated per cycle between ±Q* (Johnson, Contact Mechanics, (7.60))."""
    x = q_max / friction_force
    return (9.0 * friction_force**2 * (2.0 - nu) / (10.0 * shear_modulus * a)
            * (1.0 - (1.0 - x) ** (5.0 / 3.0) - 5.0 * x / 6.0 * (1.0 + (1.0 - x) ** (2.0 / 3.0))))


def evaluate(cycle: Cycle, friction: float = FRICTION) -> dict[str, float]:
    """The comparison with the theory (pure; the same on every rank)."""
    steps = cycle.steps
    fp = friction * cycle.force_n
    tangential = [s for s in steps if s.branch != "normal"]
    end_loading = [s for s in steps if s.branch == "loading"][-1]
    loop = [s for s in steps if s.step >= end_loading.step]
    d = np.array([s.delta_t for s in loop])
    q = np.array([s.force_t for s in loop])
    q_md = np.array([s.md_force for s in loop])
    zero_unloading = [s for s in steps if s.branch == "unloading" and abs(s.delta_t) < 1e-12 * cycle.amplitude]
    c_err = [abs(s.stick_radius - s.md_stick_radius) / cycle.hertz_radius for s in tangential]
    return {
        "friction_force": fp,
        "q_end_loading_over_fp": end_loading.force_t / fp,
        "cm_end_loading_over_fp": end_loading.md_force / fp,
        "err_end_loading": end_loading.force_t / end_loading.md_force - 1.0,
        "max_err_over_fp": max(abs(s.force_t - s.md_force) / fp for s in tangential),
        "closure_over_fp": (steps[-1].force_t - end_loading.force_t) / fp,
        "residual_unloading_over_fp": zero_unloading[0].force_t / fp if zero_unloading else float("nan"),
        "md_residual_unloading_over_fp": zero_unloading[0].md_force / fp if zero_unloading else float("nan"),
        "loop_area": loop_area(d, q),
        "md_loop_area_same_steps": loop_area(d, q_md),
        "md_loop_area_exact": dissipation(fp, cycle.hertz_radius, end_loading.md_force),
        "mean_stick_radius_err_over_a": float(np.mean(c_err)),
        "max_stick_radius_err_over_a": float(np.max(c_err)),
        "max_normal_force_change": max(abs(s.force_n / cycle.force_n - 1.0) for s in steps),
        "max_physics_residual": max(s.physics_residual for s in steps),
    }


# %% [markdown]
# ## Output: CSV, figures, README


# %%
CSV_FIELDS = ("step", "branch", "delta_t", "delta_t_over_delta_star", "Q", "Q_over_FP", "Q_MD_over_FP", "P",
              "contact_radius", "stick_radius", "c_formula", "open", "stick", "slip", "newton_iterations",
              "krylov_iterations", "physics_residual", "wall_time_s")


def csv_rows(cycle: Cycle, friction: float = FRICTION) -> list[dict[str, object]]:
    """One row per step."""
    fp = friction * cycle.force_n
    return [{"step": s.step, "branch": s.branch, "delta_t": f"{s.delta_t:.6e}",
             "delta_t_over_delta_star": f"{s.delta_t / cycle.delta_star:.4f}", "Q": f"{s.force_t:.6e}",
             "Q_over_FP": f"{s.force_t / fp:.5f}", "Q_MD_over_FP": f"{s.md_force / fp:.5f}", "P": f"{s.force_n:.6e}",
             "contact_radius": f"{s.contact_radius:.4f}", "stick_radius": f"{s.stick_radius:.4f}",
             "c_formula": f"{s.md_stick_radius:.4f}" if s.branch != "normal" else "",
             "open": s.counts.get("open", 0), "stick": s.counts.get("stick", 0), "slip": s.counts.get("slip", 0),
             "newton_iterations": s.newton_iterations, "krylov_iterations": s.krylov_iterations,
             "physics_residual": f"{s.physics_residual:.1e}", "wall_time_s": f"{s.wall_time_s:.2f}"}
            for s in cycle.steps]


def md_curves(cycle: Cycle, friction: float = FRICTION, points: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """The theory along the same path, finely sampled: (δ_t, Q)."""
    targets = [0.0] + [s.delta_t for s in cycle.steps if s.branch != "normal"]
    model = Masing(friction * cycle.force_n, cycle.delta_star)
    ds, qs = [0.0], [0.0]
    for start, end in itertools.pairwise(targets):
        for d in np.linspace(start, end, max(2, points // len(targets)))[1:]:
            ds.append(float(d))
            qs.append(model.step(float(d))[0])
    return np.array(ds), np.array(qs)


def plot(cycle: Cycle, out: Path, friction: float = FRICTION) -> list[str]:
    """hysteresis.png and stick_radius.png (rank 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fp, ds = friction * cycle.force_n, cycle.delta_star
    steps = [s for s in cycle.steps if s.branch != "normal"]
    d_md, q_md = md_curves(cycle, friction)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    ax.plot(d_md / ds, q_md / fp, "-", color="0.5", label="Mindlin–Deresiewicz")
    style = {"loading": ("o", "C0"), "unloading": ("v", "C3"), "reloading": ("^", "C2")}
    previous = cycle.steps[0]
    for s in steps:
        ax.plot([previous.delta_t / ds, s.delta_t / ds], [previous.force_t / fp, s.force_t / fp], "-",
                color=style[s.branch][1], lw=1)
        previous = s
    for branch, (marker, colour) in style.items():
        sel = [s for s in steps if s.branch == branch]
        ax.plot([s.delta_t / ds for s in sel], [s.force_t / fp for s in sel], marker, color=colour,
                label=f"FE, {branch}")
    ax.axhline(0.0, color="0.8", lw=0.5)
    ax.axvline(0.0, color="0.8", lw=0.5)
    ax.set_xlabel("tangential displacement of the sphere δ_t / δ_t*")
    ax.set_ylabel("tangential force Q / (F P)")
    ax.set_title(f"Sphere on a block, F = {friction}, ν = {NU}: hysteresis")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "hysteresis.png", dpi=120)
    plt.close(fig)

    a = cycle.hertz_radius
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2))
    k = [s.step for s in steps]
    left.plot(k, [s.md_stick_radius / a for s in steps], "-", color="0.5", label="c/a of the theory")
    half_cell = 0.5 * cycle.spec.h * A_TARGET / a  # the node rings' resolution
    for branch, (marker, colour) in style.items():
        sel = [s for s in steps if s.branch == branch]
        left.errorbar([s.step for s in sel], [s.stick_radius / a for s in sel], yerr=half_cell, fmt=marker,
                      color=colour, capsize=2, label=f"FE ± h/2, {branch}")
    left.set_xlabel("step")
    left.set_title("stick radius per step")
    left.set_ylabel("stick radius c / a")
    left.set_ylim(0.0, 1.2)
    left.xaxis.get_major_locator().set_params(integer=True)
    left.legend(fontsize=8)
    first = [cycle.steps[0]] + [s for s in steps if s.branch == "loading"]
    x = np.linspace(0.0, max(s.force_t / fp for s in first), 100)
    right.plot(x, (1.0 - x) ** (1.0 / 3.0), "-", color="0.5", label="c = a (1 − Q/(FP))^(1/3)")
    right.errorbar([s.force_t / fp for s in first], [s.stick_radius / a for s in first], yerr=half_cell, fmt="o",
                   color="C0", capsize=2, label="FE ± h/2, first loading (Q = 0: pressed only)")
    right.set_xlabel("Q / (F P)")
    right.set_title("first loading: Cattaneo–Mindlin")
    right.set_ylabel("stick radius c / a")
    right.set_ylim(0.0, 1.2)
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "stick_radius.png", dpi=120)
    plt.close(fig)
    return ["hysteresis.png", "stick_radius.png"]


#: The discussion of docs/mindlin/README.md (written for the default mesh; the numbers are those of its table).
DISCUSSION = """## Why the finite-element loop differs from the theory

The loop has the theory's shape and orientation: unloading starts with the full-stick stiffness, lies below
the reloading branch, reverses the force before δ_t returns to 0 and the loop closes at (Δ, Q*) (Masing).
The differences, in the order of their size:

* **Pressing already uses up friction at the edge (the coupling).** With ν = 0.45 the normal and tangential
  problems are weakly coupled (β = 0.09), so pressing the sphere with F = 0.3 makes the outer ring of the
  contact slip radially (step 1: the stick radius is about 0.8 a, not a; Spence's problem). Those nodes
  start the tangential loading with |t| = Fλ already, so the first loading is softer than Cattaneo–Mindlin
  from the start: the error is largest in the first substep and shrinks as the slip annulus grows and the
  radial tractions turn into the drag direction. Measured FROM EACH TURNING POINT the unloading and reloading
  branches agree with Masing's rule to about 1–2 % of their change (the first unloading substep changes Q by
  +1.3 % more than the theory), the residual force at δ_t = 0 to about 1 % of itself.
* **The finite block and the mesh.** The theory's δ_t is measured against the far field of a half-space, the
  FE's against the block's clamped bottom 10 a below, with free sides 10 a away; the Cerruti far field of a
  half-space at r = 10 a is about 6 % of the contact compliance (2 − ν)/(8Ga), so cutting it off (clamped
  bottom: stiffer; free sides: softer) changes the compliance by a few per cent either way. Linear hexahedra
  stiffen as ν → 1/2 (moderately at 0.45). Both act on the elastic (stick) compliance: the first substep after
  each reversal, with nearly the whole contact stuck, is 1.3 % stiffer than the theory.
* **a from P.** The formulas use the contact radius of Hertz's a³ = 3PR/(4E*) with the measured P; the closed
  nodes give a radius up to h/2 larger (the node rings are h apart), and δ_t* ∝ 1/a.
* **The stick radius** is quantized by the node rings around the axis: it moves in jumps of up to h (the
  error bars in the figure are ±h/2) and follows c = a(1 − Q/(FP))^{1/3} (and c' on the reversal branches)
  within a quarter of a cell on average (the table's mean and largest |c − c_MD|/a against h/a).
* **The loop area** (the dissipated energy) is a trapezoidal sum over the coarse steps: compare it with the
  same sum over the theory's Q at the same steps (within 1 %); the exact area is larger by about as much
  again.

P changes by about 0.1 % during the cycle (the theory's assumption: Q does not change the pressure),
and every step satisfies equilibrium, Signorini, the friction cone and the slip-increment direction to round-off
(largest physics residual in the table).
"""


def readme(cycle: Cycle, numbers: dict[str, float], command: str, ranks: int, wall: float,
           friction: float = FRICTION) -> str:
    """docs/mindlin/README.md: the set-up, the table and the comparison."""
    fp, ds, a = friction * cycle.force_n, cycle.delta_star, cycle.hertz_radius
    rows = "\n".join(
        f"| {s.step} | {s.branch} | {s.delta_t / ds:+.3f} | {s.force_t / fp:+.4f} | "
        f"{(s.md_force / fp):+.4f} | {s.force_n:.4f} | {s.stick_radius / a:.3f} | "
        + (f"{s.md_stick_radius / a:.3f}" if s.branch != "normal" else "–")
        + f" | {s.counts.get('stick', 0)}/{s.counts.get('slip', 0)} | {s.newton_iterations} | {s.krylov_iterations} |"
        for s in cycle.steps)
    n = numbers
    W, D = cycle.spec.width * A_TARGET, cycle.spec.depth * A_TARGET
    comparison = "\n".join(f"| {what} | {fe} | {theory} |" for what, fe, theory in (
        ("Q/FP at the end of the first loading (δ_t = Δ)", f"{n['q_end_loading_over_fp']:.4f}",
         f"{n['cm_end_loading_over_fp']:.4f} (error {n['err_end_loading']:+.1%})"),
        ("largest \\|Q − Q_MD\\|/FP over the path", f"{n['max_err_over_fp']:.4f}", "0"),
        ("Q/FP at δ_t = 0 on unloading (residual force)", f"{n['residual_unloading_over_fp']:+.4f}",
         f"{n['md_residual_unloading_over_fp']:+.4f}"),
        ("loop closure (Q_end − Q at the end of loading)/FP", f"{n['closure_over_fp']:+.4f}", "0"),
        ("loop area ∮Q dδ_t (energy per cycle, kN·mm)", f"{n['loop_area']:.4e}",
         f"{n['md_loop_area_same_steps']:.4e} (same steps), {n['md_loop_area_exact']:.4e} (exact)"),
        ("stick radius: mean / largest \\|c − c_MD\\|/a",
         f"{n['mean_stick_radius_err_over_a']:.3f} / {n['max_stick_radius_err_over_a']:.3f}",
         f"h/a = {cycle.spec.h:.3f}"),
        ("largest change of P during the cycle", f"{n['max_normal_force_change']:.2e}", "0 (uncoupled)"),
        ("largest physics residual of a step (equilibrium, Signorini, cone, slip direction, balance)",
         f"{n['max_physics_residual']:.1e}", ""),
    ))
    return f"""# Mindlin–Deresiewicz: a rigid sphere pressed on a block and dragged back and forth

Generated by `{command}` ({ranks} rank(s), {wall:.0f} s wall time on the shared 2-core machine) from
[`benchmarks/mindlin.py`](../../benchmarks/mindlin.py), which derives the theory and explains the set-up. Files:
`mindlin.csv` (one row per step), `summary.json` (the set-up and the numbers below), `hysteresis.png`,
`stick_radius.png`.

**Set-up.** A rigid sphere (R = {RADIUS:g} mm) is pressed δ_n = {DEPTH:g} mm into an elastic block
(E = {E:g} GPa, ν = {NU}, F = {friction}; [−{W:g}, {W:g}]² × [−{D:g}, 0] mm, clamped bottom, free sides,
Q1 hexahedra of edge h = {cycle.spec.h:.3g} a near the contact graded outward; {cycle.unknowns} unknowns,
{cycle.contact_nodes} contact nodes) in step 1, then dragged along x by the obstacle displacement
δ_t: 0 → +Δ → −Δ → +Δ, Δ = {cycle.amplitude / ds:.2f} δ_t*, one solve per step, friction on each step's slip
increment. Step 1 gives P = {cycle.force_n:.4f} kN and, by Hertz's a³ = 3PR/(4E*), a = {a:.4f} mm (the
closed nodes reach a = {cycle.contact_radius:.3f} mm, resolution h); from these δ_t* = 3FP(2 − ν)/(16Ga)
= {ds:.4e} mm.

![hysteresis](hysteresis.png)

![stick radius](stick_radius.png)

| step | branch | δ_t/δ_t* | Q/FP (FE) | Q/FP (MD) | P (kN) | c/a (FE) | c/a (MD) | stick/slip nodes | Newton | Krylov |
|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|
{rows}

## Comparison

| quantity | FE | theory |
|---|---:|---:|
{comparison}

{DISCUSSION}
"""


def write_outputs(cycle: Cycle, out: Path, command: str, wall: float, friction: float = FRICTION,
                  ranks: int | None = None) -> dict:
    """mindlin.csv, summary.json, the figures and README.md into ``out`` (rank 0 writes)."""
    numbers = evaluate(cycle, friction)
    comm = MPI.COMM_WORLD
    ranks = comm.size if ranks is None else ranks
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "mindlin.csv", "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(CSV_FIELDS))
            writer.writeheader()
            writer.writerows(csv_rows(cycle, friction))
        data = {"setup": {"E": E, "nu": NU, "friction": friction, "sphere_radius": RADIUS, "depth": DEPTH,
                          "mesh": asdict(cycle.spec), "unknowns": cycle.unknowns, "contact_nodes": cycle.contact_nodes,
                          "P": cycle.force_n, "a_hertz": cycle.hertz_radius, "a_nodes": cycle.contact_radius,
                          "delta_star": cycle.delta_star, "amplitude": cycle.amplitude, "ranks": ranks,
                          "wall_time_s": wall, "command": command},
                "comparison": numbers,
                "steps": [asdict(s) for s in cycle.steps]}
        (out / "summary.json").write_text(json.dumps(data, indent=1) + "\n")
        plot(cycle, out, friction)
        (out / "README.md").write_text(readme(cycle, numbers, command, ranks, wall, friction))
    comm.barrier()
    return numbers


def load_cycle(path: Path) -> tuple[Cycle, str, float, float, int]:
    """A run's cycle, command, wall time, friction and ranks from its summary.json (to redraw the figures and
    README.md after a change of their code without solving again)."""
    data = json.loads(Path(path).read_text())
    setup = data["setup"]
    steps = [Step(**step) for step in data["steps"]]
    cycle = Cycle(steps=steps, force_n=setup["P"], contact_radius=setup["a_nodes"], hertz_radius=setup["a_hertz"],
                  delta_star=setup["delta_star"], amplitude=setup["amplitude"], unknowns=setup["unknowns"],
                  contact_nodes=setup["contact_nodes"], spec=MeshSpec(**setup["mesh"]))
    return cycle, setup["command"], setup["wall_time_s"], setup["friction"], setup["ranks"]


# %% [markdown]
# ## Running it


# %%
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Mindlin–Deresiewicz hysteresis of a sphere dragged on a block")
    parser.add_argument("--quick", action="store_true", help="the coarse mesh and 2 substeps (seconds)")
    parser.add_argument("--h", type=float, default=None, help="core cell size / a")
    parser.add_argument("--width", type=float, default=None, help="half-width = depth of the block / a")
    parser.add_argument("--growth", type=float, default=None, help="cell growth ratio outside the core")
    parser.add_argument("--substeps", type=int, default=None,
                        help="steps of the first loading quarter (default 4, --quick 2); 2x per half cycle")
    parser.add_argument("--amplitude", type=float, default=0.75, help="Δ/δ_t* (< 1: no gross sliding)")
    parser.add_argument("--friction", type=float, default=FRICTION)
    parser.add_argument("--pc", default="gamg", help="preconditioner (ILU stagnates at ν = 0.45)")
    parser.add_argument("--out", default=None, help="write mindlin.csv, summary.json, figures, README.md here")
    parser.add_argument("-v", "--verbose", action="store_true", help="the Newton iterations too")
    parser.add_argument("--redraw", action="store_true",
                        help="only redraw the figures and README.md of --out from its summary.json")
    args = parser.parse_args(argv)
    for name, value, ok, allowed in (
            ("--amplitude", args.amplitude, 0.0 < args.amplitude < 1.0, "in (0, 1): below gross sliding"),
            ("--friction", args.friction, 0.0 < args.friction < np.inf, "> 0"),
            ("--substeps", args.substeps, args.substeps is None or args.substeps >= 1, ">= 1"),
            ("--h", args.h, args.h is None or 0.0 < args.h <= 0.5, "in (0, 0.5]"),
            ("--width", args.width, args.width is None or 2.0 <= args.width < np.inf, ">= 2"),
            ("--growth", args.growth, args.growth is None or 1.0 < args.growth <= 2.0, "in (1, 2]")):
        if not ok:
            parser.error(f"{name} {value!r}: must be {allowed}")  # exit 2 on every rank, before any MPI call
    comm = MPI.COMM_WORLD
    if args.redraw:
        if not args.out:
            parser.error("--redraw needs --out")
        cycle, command, wall, friction, ranks = load_cycle(Path(args.out) / "summary.json")
        write_outputs(cycle, Path(args.out), command, wall, friction, ranks)
        return 0
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(message)s")
    logger.setLevel(logging.INFO)
    spec = QUICK_MESH if args.quick else MeshSpec()
    changes = {key: getattr(args, key) for key in ("h", "width", "growth") if getattr(args, key) is not None}
    if "width" in changes:
        changes["depth"] = changes["width"]
    spec = MeshSpec(**{**asdict(spec), **changes})
    substeps = args.substeps or (2 if args.quick else 4)
    t0 = time.perf_counter()
    try:
        cycle = run_cycle(comm, spec, args.amplitude, substeps, args.friction, settings={"pc": args.pc})
    except SolverError as err:
        if comm.rank == 0:
            print(f"a step did not converge ({err.reason}): {err}", file=sys.stderr)
        return 3
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    numbers = evaluate(cycle, args.friction)
    if args.out:
        command = "python3 benchmarks/mindlin.py " + " ".join(argv if argv is not None else sys.argv[1:])
        if comm.size > 1:
            command = f"mpirun -n {comm.size} " + command
        write_outputs(cycle, Path(args.out), command, wall, args.friction)
    if comm.rank == 0:
        print(f"n = {cycle.unknowns}, P = {cycle.force_n:.4f}, a = {cycle.hertz_radius:.4f} (nodes "
              f"{cycle.contact_radius:.3f}), δ_t* = {cycle.delta_star:.4e}; Q/FP at Δ: FE "
              f"{numbers['q_end_loading_over_fp']:.4f}, Cattaneo–Mindlin {numbers['cm_end_loading_over_fp']:.4f} "
              f"({numbers['err_end_loading']:+.1%}); largest |Q − Q_MD|/FP {numbers['max_err_over_fp']:.4f}; "
              f"loop area {numbers['loop_area']:.4e} (MD {numbers['md_loop_area_exact']:.4e}); "
              f"{wall:.0f} s" + (f"; results in {args.out}/" if args.out else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
