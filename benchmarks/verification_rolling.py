"""Case 8 of the verification table: steady tractive rolling of a rigid roller against Carter's creep law.

A plane-strain SLICE of the block of benchmarks/rolling_carter.py: one hexahedron thick in x2, rollers u2 = 0 on
both x2 faces (the contact nodes keep their held u2: the roller's motion has no x2 component), a rigid roller of
radius R (the analytic ``Cylinder``, axis along x2) pressed by the depth d and rolled along +x1 with the creep ξ:
step k translates it to s_k = s_0 + k Δ and turns it by θ_k = θ_0 + k Δ (1 + ξ)/R about its own axis. Before
rolling, the roller is turned IN PLACE by θ_0 (``preload``): this pre-loads the block's bulk, a shear spring in
series with the contact that a roll from Q = 0 takes a long way to wind up (docs/verification §8). Q and P are
the contact forces per unit length (the slice's total over its thickness W); the run stops when Q changed by
less than ``STEADY_TOL`` over the last ``STEADY_STEPS`` steps (the issue's rule) AND the distance to the steady
Q that the transient's geometric decay leaves (``remaining``) is below ``STEADY_TOL``/2, or at ``max_steps``.

Carter (1926; Johnson, Contact Mechanics (1985), §8.2): ξ = (μa/R)(1 − √(1 − Q/μP)), a² = 4PR/(πE*),
E* = E/(1 − ν²) for the rigid roller; the stick zone at the LEADING edge, of width 2a' = 2a√(1 − Q/μP).
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from fenics_coulomb import ContactProblem, ContactState, Cylinder
from fenics_coulomb.scenes.partition import box_partitioner

__all__ = ["E", "NU", "MU", "R", "DEPTH", "CARTER_LEVELS", "CARTER_RUNS", "carter_rows",
           "carter_reference", "carter_creep", "hertz_half_width",
           "slice_block", "roll", "remaining", "ranks_agreement"]

LOG = logging.getLogger("verification")

#: The block's material (β = (1 − 2ν)/(2(1 − ν)) = 0.0196 against the rigid roller), the friction, the roller's
#: radius and its depth of indentation.
E, NU, MU, R, DEPTH = 70.0, 0.49, 0.3, 1.0, 0.01
#: Rule of the steady state: Q changed by less than STEADY_TOL (relative) over the last STEADY_STEPS steps (the
#: issue's rule), and the transient's remainder ``remaining`` below STEADY_TOL/2 (two starts then agree to
#: STEADY_TOL).
STEADY_TOL, STEADY_STEPS = 1e-3, 5
#: The far-field correction's cycle (rolled distance between two corrections).
CYCLE = 0.2
#: Mesh levels: (node spacing h on the track, the block's extent [x0, x1], depth H, the track [t0, t1], cells
#: across the depth, the rolling step Δ as a multiple of h, the transient's relaxation length L: Q(s) − Q∞ decays
#: like exp(−s/L), measured on long rolls without correction (docs/verification §8: 0.25 at H = 1, 0.21–0.23 at
#: H = 4; H = 2 not measured, taken as H = 1's)).
CARTER_LEVELS: dict[int, dict[str, Any]] = {
    -1: {"h": 0.02, "x": (-1.0, 1.5), "H": 1.0, "track": (-0.12, 0.3), "nz": 10, "step": 1, "L": 0.25},  # the test's
    0: {"h": 0.02, "x": (-1.5, 2.5), "H": 1.0, "track": (-0.15, 0.95), "nz": 10, "step": 1, "L": 0.25},
    1: {"h": 0.01, "x": (-1.5, 2.5), "H": 1.0, "track": (-0.15, 0.95), "nz": 16, "step": 1, "L": 0.25},
    2: {"h": 0.005, "x": (-1.5, 2.5), "H": 1.0, "track": (-0.15, 0.95), "nz": 24, "step": 2, "L": 0.25},
    # deeper blocks (the far field's depth H): the squeeze-out of the bonded, almost incompressible layer
    10: {"h": 0.02, "x": (-4.0, 5.0), "H": 2.0, "track": (-0.15, 0.95), "nz": 14, "step": 1, "L": 0.25},
    # the table's: a longer track (the relaxation changes once the leading edge is within ≈ 0.2 of its end)
    11: {"h": 0.02, "x": (-8.0, 9.0), "H": 4.0, "track": (-0.15, 1.25), "nz": 20, "step": 1, "L": 0.23},
    12: {"h": 0.014, "x": (-8.0, 9.0), "H": 4.0, "track": (-0.15, 1.25), "nz": 24, "step": 1, "L": 0.23},
}
#: The roll ends this far before the track's end (the leading edge ≈ 0.23 before it).
TRACK_MARGIN = 0.3


def e_star() -> float:
    """E* = E/(1 − ν²): the plane-strain modulus of the block against the rigid roller."""
    return E / (1.0 - NU**2)


def hertz_half_width(P: float) -> float:
    """2D Hertz: the half-width a of the contact strip under the load P per unit length, a² = 4PR/(πE*)."""
    return math.sqrt(4.0 * P * R / (math.pi * e_star()))


def carter_creep(Q: float, P: float, a: float) -> float:
    """Carter's creep for the tangential force Q and the normal force P (per unit length) and the half-width a:
    ξ = (μa/R)(1 − √(1 − Q/μP)) (nan for Q >= μP: full slip)."""
    ratio = Q / (MU * P)
    return MU * a / R * (1.0 - math.sqrt(1.0 - ratio)) if ratio < 1.0 else math.nan


def carter_reference(creep: float, P: float) -> float:
    """The tangential force per unit length Carter gives for the creep ξ under P: Q = μP(1 − (1 − ξR/μa)²)."""
    a = hertz_half_width(P)
    return MU * P * (1.0 - (1.0 - creep * R / (MU * a)) ** 2)


def slice_block(comm: MPI.Comm, level: int) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, float]:
    """The slice [x0, x1] × [0, W] × [−H, 0], W = h, one hexahedron thick: spacing h on the track, growing
    geometrically (ratio ≤ 1.15) towards the ends; z = −H ζ² graded toward the top. Facet tags: top 1, bottom 2,
    the x2 faces 3. Returns the mesh, the tags and W."""
    spec = CARTER_LEVELS[level]
    h, (x0, x1), H, (t0, t1), nz = spec["h"], spec["x"], spec["H"], spec["track"], spec["nz"]
    track = np.linspace(t0, t1, round((t1 - t0) / h) + 1)

    def grow(length: float) -> np.ndarray:
        steps, d = [], h
        while sum(steps) < length:
            d = min(d * 1.15, 0.1 * H)
            steps.append(d)
        return np.cumsum(steps) * length / sum(steps)

    xs = np.concatenate([t0 - grow(t0 - x0)[::-1], track, t1 + grow(x1 - t1)])
    nx = xs.size - 1
    corners = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]
    msh = dolfinx.mesh.create_box(comm, corners, [nx, 1, nz], dolfinx.mesh.CellType.hexahedron,
                                  partitioner=box_partitioner(corners, [nx, 1, nz], dolfinx.mesh.GhostMode.none))
    x = msh.geometry.x
    x[:, 0] = np.interp(x[:, 0], np.linspace(0.0, 1.0, nx + 1), xs)
    x[:, 1] *= h
    x[:, 2] = -H * (1.0 - x[:, 2]) ** spec.get("grade", 2.0)
    located = [dolfinx.mesh.locate_entities_boundary(msh, 2, f) for f in (
        lambda p: np.isclose(p[2], 0.0), lambda p: np.isclose(p[2], -H),
        lambda p: np.isclose(p[1], 0.0) | np.isclose(p[1], h))]
    facets = np.concatenate(located)
    values = np.concatenate([np.full(f.size, i + 1, np.int32) for i, f in enumerate(located)])
    order = np.argsort(facets)
    return msh, dolfinx.mesh.meshtags(msh, 2, facets[order].astype(np.int32), values[order]), h


def _forces(comm: MPI.Comm, result: Any, width: float) -> tuple[float, float]:
    """(P, Q) per unit length: the roller's push on the block (down) and its traction (backwards, −x1)."""
    force = comm.allreduce(np.asarray(result.contact_force, dtype=np.float64).reshape(-1, 3).sum(axis=0),
                           op=MPI.SUM)
    return -float(force[2]) / width, -float(force[0]) / width


def _surface_u1(comm: MPI.Comm, u: Any, V: Any) -> np.ndarray:
    """(x1, u1) of the top surface's nodes on the face x2 = 0 (reference x1), gathered on every rank, sorted."""
    owned = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:owned]
    top = np.flatnonzero(np.isclose(x[:, 2], 0.0) & np.isclose(x[:, 1], 0.0))
    values = u.x.array.reshape(-1, 3)[:owned]
    rows = np.concatenate(comm.allgather(np.column_stack([x[top, 0], values[top, 0]])))
    return rows[np.argsort(rows[:, 0])]


def remaining(qs: list[float], step: float, length: float) -> float:
    """The distance to the steady Q that a geometric transient leaves, relative to the last Q.

    Q_k − Q∞ = A r^k with r = exp(−Δ/L) per step: Q∞ − Q_k = (Q_k − Q_{k−n}) ρ/(1 − ρ), ρ = r^n, n =
    ``STEADY_STEPS``. The change over n steps is taken as the largest of the last n such changes (the stick zone's
    node-by-node jitter makes a single one fall near zero, and a turn's transient passes an extremum): on a pure
    geometric tail this is the oldest change, the remainder times r^−(n−1) (conservative); nan until 2n steps
    exist.
    """
    n = STEADY_STEPS
    if len(qs) < 2 * n:
        return math.nan
    change = max(abs(qs[-1 - j] - qs[-1 - j - n]) for j in range(n))
    rho = math.exp(-n * step / length)
    return change * rho / (1.0 - rho) / abs(qs[-1])


def roll(comm: MPI.Comm, creep: float, level: int = 0, preload: float = 1.0, max_steps: int | None = None,
         min_steps: int = 0, nu: float = NU, reduced: bool = True, pc: str = "lu", cycle: float | None = None
         ) -> dict[str, Any]:
    """Press, pre-load and roll the roller until Q is steady (the issue's rule) at mesh ``level``.

    Args:
        comm: The communicator.
        creep: The prescribed creep ξ.
        level: The mesh level (``CARTER_LEVELS``).
        preload: Turn the roller in place until Q reaches ``preload`` × Carter's Q for ξ under the pressed P
            (0: no pre-load, the roll starts from Q = 0).
        max_steps: The longest roll (steps; default: until ``TRACK_MARGIN`` before the track's end).
        min_steps: Roll at least this many steps.
        cycle: The rolled distance between two far-field corrections (default ``CYCLE``; 0: none).

    Returns:
        The steady (or last) state: P, Q, a (closed nodes and 2D Hertz), the stick zone, Carter's creep for the
        measured Q, P and a, the step the rule held at, the Q history, unknowns and wall time.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    spec = CARTER_LEVELS[level]
    msh, tags, width = slice_block(comm, level)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, tags.find(2)), V)
    V2, _ = V.sub(1).collapse()
    zero = dolfinx.fem.Function(V2)
    faces = dolfinx.fem.locate_dofs_topological((V.sub(1), V2), 2, tags.find(3))
    rollers = dolfinx.fem.dirichletbc(zero, faces, V.sub(1))
    lame_mu, lame_lambda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w: Any) -> Any:
        return ufl.sym(ufl.grad(w))

    # selective reduced integration: the volumetric term at the cell centre (ν -> 1/2: no volumetric locking)
    dx_vol = ufl.dx(metadata={"quadrature_degree": 1 if reduced else 2})
    a_form = (ufl.inner(2 * lame_mu * eps(u), eps(v)) * ufl.dx
              + lame_lambda * ufl.tr(eps(u)) * ufl.tr(eps(v)) * dx_vol)
    centre = [0.0, 0.0, R]
    axis = [0.0, 1.0, 0.0]
    step = spec["step"] * spec["h"]
    if max_steps is None:
        max_steps = int((spec["track"][1] - TRACK_MARGIN) / step + 1e-9)
    every = round((CYCLE if cycle is None else cycle) / step)  # steps between two far-field corrections
    history: list[tuple[float, float, float, float]] = []  # (rolled distance, P, Q, angle)
    prefix = f"carter{level}_"
    with ContactProblem(a_form, None, bcs=[clamp, rollers], contact=(tags, [1]), friction=MU,
                        obstacles=[Cylinder(point=centre, axis=axis, radius=R, displacement=(0, 0, -DEPTH),
                                            name="roller")],
                        settings={"rtol": 1e-10, "pc": pc}, petsc_options_prefix=prefix) as problem:

        def solve(s: float, angle: float) -> tuple[Any, float, float]:
            problem.move("roller", (s, 0.0, -DEPTH), rotation=[math.degrees(angle), axis, centre])
            _, result = problem.solve()
            if not result.converged:
                raise RuntimeError(f"Carter level {level}, ξ = {creep}: s = {s:g}, θ = {angle:g}: {result.reason}")
            P, Q = _forces(comm, result, width)
            history.append((s, P, Q, angle))
            return result, P, Q

        result, P0, Q = solve(0.0, 0.0)
        unknowns = result.n
        target = preload * carter_reference(creep, P0)
        angle = 0.0
        if preload > 0.0:
            # turn in place by increments of the surface displacement, then one secant step onto the target
            increment = 5e-4  # of the surface displacement R θ
            while Q < target:
                angle += increment / R
                result, P, Q = solve(0.0, angle)
            previous_angle, previous_q = history[-2][3], history[-2][2]
            angle = previous_angle + (target - previous_q) / (Q - previous_q) * (angle - previous_angle)
            result, P, Q = solve(0.0, angle)
        preload_steps = len(history) - 1
        slope = angle / max(Q - history[0][2], 1e-300) if preload > 0.0 else 0.0  # dθ/dQ of the turn in place
        steady_at = None
        qs: list[float] = []
        corrections: list[tuple[int, float]] = []
        last = 0  # the step of the last correction's decision
        turned = 0  # the step of the last turn in place
        left = math.nan
        for k in range(1, max_steps + 1):
            result, P, Q = solve(k * step, angle + k * step * (1 + creep) / R)
            qs.append(Q)
            left = remaining(qs[turned:], step, spec["L"])
            if comm.rank == 0 and k % 10 == 0:
                LOG.info(f"Carter level {level} ξ = {creep} preload {preload}: step {k}, s = {k * step:.3f}, "
                         f"P {P:.6f}, Q {Q:.6f}, Q/μP {Q / (MU * P):.4f}, remaining {left:.1e}")
            # the rule, after the first cycle (the stick zone's move from the centre to the leading edge makes Q
            # turn, which the rule alone would take for steady) and never across a turn; Q is the same number on
            # every rank (an allreduce), so every rank decides alike
            if (k - turned > STEADY_STEPS and abs(Q - qs[-1 - STEADY_STEPS]) <= STEADY_TOL * abs(Q)
                    and left <= STEADY_TOL / 2 and k >= max(min_steps, every)):
                steady_at = k
                break
            m = every // 4
            if every >= 4 and slope and k - last == every:
                # the far field's relaxation Q(s) -> Q∞ is geometric: Aitken's Δ² on the last three quarter-cycles
                # gives Q∞; turning the roller in place by (Q∞ − Q) dθ/dQ winds the far field up to it
                q1, q2, q3 = qs[-1 - 2 * m], qs[-1 - m], Q
                d1, d2 = q2 - q1, q3 - q2
                if d1 * d2 > 0 and abs(d2) < abs(d1):
                    target = q3 - d2 * d2 / (d2 - d1)
                    if abs(target - Q) > 2 * STEADY_TOL * abs(Q):
                        angle += (target - Q) * slope
                        result, P, Q = solve(k * step, angle + k * step * (1 + creep) / R)
                        corrections.append((k, target))
                        qs[-1] = Q
                        turned = k - 1  # qs[turned:] starts with the turned state
                last = k
        report = problem.report(result)
        surface = _surface_u1(comm, problem.u, V)
    rolled = len(qs) * step
    nodes = report.nodes
    face = np.isclose(nodes.coordinates[:, 1], 0.0, atol=1e-12)
    x = nodes.coordinates[face, 0] - rolled
    order = np.argsort(x)
    x, state = x[order], nodes.state[face][order]
    closed = state != ContactState.OPEN
    h = spec["h"]
    a_nodes = 0.5 * (x[closed].max() - x[closed].min() + h)
    stick = state == ContactState.STICK
    xs, xe = (float(x[stick].min()), float(x[stick].max())) if stick.any() else (math.nan, math.nan)
    a_hertz = hertz_half_width(P)
    ratio = Q / (MU * P)
    # the surface strain ∂u1/∂x1 over the stick zone (least squares over its nodes): the creep the kinematics give
    inside = (surface[:, 0] - rolled >= xs - 1e-9) & (surface[:, 0] - rolled <= xe + 1e-9) if stick.any() else []
    stick_strain = float(np.polyfit(surface[inside, 0], surface[inside, 1], 1)[0]) if np.sum(inside) > 1 else math.nan
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    cpu = comm.allreduce(time.process_time() - c0, op=MPI.SUM)  # over the ranks
    return {"creep": creep, "level": level, "h": h, "step": step, "P": P, "Q": Q, "Q/muP": ratio,
            "a_nodes": a_nodes, "a_hertz": a_hertz, "centre": float(0.5 * (x[closed].max() + x[closed].min())),
            "stick_from": xs, "stick_to": xe, "stick_width": (xe - xs + h) if stick.any() else 0.0,
            "stick_width_ref": 2 * a_hertz * math.sqrt(max(1.0 - ratio, 0.0)),
            "creep_carter": carter_creep(Q, P, a_hertz), "creep_carter_nodes": carter_creep(Q, P, a_nodes),
            "Q_carter": carter_reference(creep, P), "stick_strain": stick_strain, "steady_at": steady_at,
            "rolled": rolled, "remaining": left,
            "preload_steps": preload_steps, "preload": preload, "corrections": corrections, "history": history,
            "unknowns": unknowns, "wall": wall, "cpu": cpu}


#: The table's runs: (creep, level) — the deep block H = 4 at h = 0.02 = a/3.4 and h = 0.014 = a/4.8 (the shallow
#: blocks H = 1 and 2 and the creep 0.005 are in docs/verification §8's text); the first level of the larger creep
#: is also rolled on one rank (compared solve by solve) and from a second start, which pre-loads this fraction of
#: Carter's Q.
CARTER_RUNS = ((0.01, 11), (0.01, 12))
SECOND_START = 0.5
SOURCE = ("Johnson, Contact Mechanics (1985), §8.2 (Carter 1926): ξ = (μa/R)(1 − √(1 − Q/μP)), "
          "a² = 4PR/(πE*)")


def _steady_note(r: dict[str, Any]) -> str:
    qs = [q for _, _, q, _ in r["history"]]
    change = abs(qs[-1] - qs[-1 - STEADY_STEPS]) / abs(qs[-1])
    steps = round(r["rolled"] / r["step"])
    where = (f"steady at step {r['steady_at']} (rolled {r['rolled']:.2f} = {r['rolled'] / r['a_hertz']:.1f} a; Q "
             f"changed {change:.1e} over the last {STEADY_STEPS} steps)" if r["steady_at"] is not None else
             f"NOT steady after {steps} steps (rolled {r['rolled']:.2f}): Q changed {change:.1e} over the last "
             f"{STEADY_STEPS} steps")
    return (f"{where}; the transient's remainder {r['remaining']:.1e} (L = {CARTER_LEVELS[r['level']]['L']:g}); "
            f"pre-load {r['preload']:g} × Carter's Q, {len(r['corrections'])} far-field correction(s); surface "
            f"strain over the stick zone {r['stick_strain']:.5f}; {r['cpu']:.0f} CPU-s over the ranks")


def _ranks_agree(two: dict[str, Any], one: list[tuple[float, float, float, float]]) -> float:
    """Largest relative difference of P and Q between the two-rank roll and the one-rank roll ``one`` (its
    history) over every solve both made (nan if they stopped at different solves: a decision taken apart)."""
    if len(one) != len(two["history"]):
        return math.nan
    return max(abs(a[j] - b[j]) / abs(b[j]) for a, b in zip(two["history"], one) for j in (1, 2))


def ranks_agreement(comm: MPI.Comm, creep: float = 0.01, level: int = 11, steps: int = 12) -> dict[str, Any]:
    """The first ``steps`` rolling steps on ``comm`` and on its rank 0 alone (``MPI.COMM_SELF``): the largest
    relative difference of P and Q over every solve (the pre-load's turns, the steps, a correction's turn), both
    rolls' solves, wall and CPU seconds. A cheaper 1 vs 2 ranks check than carter_rows' whole roll (§8: a loaded
    machine)."""
    two = roll(comm, creep, level, max_steps=steps)
    one = roll(MPI.COMM_SELF, creep, level, max_steps=steps) if comm.rank == 0 else None
    one = comm.bcast(None if one is None else {k: one[k] for k in ("history", "wall", "cpu")})
    return {"agree": _ranks_agree(two, one["history"]), "solves": (len(two["history"]), len(one["history"])),
            "corrections": two["corrections"], "wall": (two["wall"], one["wall"]), "cpu": (two["cpu"], one["cpu"])}


def carter_rows(comm: MPI.Comm, runs: tuple[tuple[float, int], ...] = CARTER_RUNS, second_start: bool = True
                ) -> list[dict[str, Any]]:
    """Case 8's rows: per (creep, level) the creep Carter gives for the measured steady Q, P and a against the
    prescribed one; the first run of the larger creep also rolled on one rank (compared solve by solve) and rolled
    from a second start (the attractor; not with ``second_start=False``)."""
    rows: list[dict[str, Any]] = []
    case = "8. steady rolling (Carter)"
    done: dict[tuple[float, int], dict[str, Any]] = {}
    previous: dict[float, float] = {}
    compared = max(c for c, _ in runs), min(lvl for c, lvl in runs if c == max(c for c, _ in runs))
    for creep, level in runs:
        r = done[creep, level] = roll(comm, creep, level)
        agree = "—"
        if (creep, level) == compared and comm.size > 1:
            one = roll(MPI.COMM_SELF, creep, level) if comm.rank == 0 else None
            one = comm.bcast(None if one is None else one["history"])
            agree = f"{_ranks_agree(r, one):.1e}"
        error = r["creep_carter"] / creep - 1.0
        if comm.rank == 0:
            LOG.info(f"Carter: ξ = {creep}, level {level}: P {r['P']:.6f}, Q {r['Q']:.6f}, Q/μP {r['Q/muP']:.4f} "
                     f"(Carter {r['Q_carter'] / (MU * r['P']):.4f}), ξ_Carter {r['creep_carter']:.6f} "
                     f"({error:+.2%}), {_steady_note(r)}, {r['wall']:.0f} s")
        trend = f"; from {previous[creep]:+.2%}" if creep in previous else ""
        previous[creep] = error
        rows.append({
            "case": case, "quantity": f"creep ξ from Carter's law for the measured steady Q, P (prescribed ξ = "
            f"{creep:g})", "level": f"{level}: h = {r['h']:g} = a/{r['a_hertz'] / r['h']:.3g}, step "
            f"{r['step']:g}, H = {CARTER_LEVELS[level]['H']:g}, plane-strain slice, hex", "reference": f"{creep:g}",
            "source": SOURCE, "value": f"{r['creep_carter']:.6f}", "error": error, "bound": 5e-2,
            "unknowns": r["unknowns"], "ranks": comm.size, "wall": r["wall"], "agree": agree,
            "note": f"Q/μP = {r['Q/muP']:.4f} (Carter's for ξ: {r['Q_carter'] / (MU * r['P']):.4f}), P = "
                    f"{r['P']:.5f}, a = {r['a_nodes']:.4f} (closed nodes) vs {r['a_hertz']:.4f} (Hertz); stick "
                    f"zone [{r['stick_from']:+.4f}, {r['stick_to']:+.4f}] − centre {r['centre']:+.4f}: 2a' = "
                    f"{r['stick_width']:.4f} vs 2a√(1 − Q/μP) = {r['stick_width_ref']:.4f}; "
                    + _steady_note(r) + ("; 1 vs 2 ranks: P and Q at every solve of the two rolls (the same "
                                         f"{len(r['history'])} solves)" if agree != "—" else "") + trend})
    if not second_start:
        return rows
    creep, level = compared
    first = done[creep, level]
    second = roll(comm, creep, level, preload=SECOND_START)
    if comm.rank == 0:
        LOG.info(f"Carter: two starts at level {level}, ξ = {creep}: Q {first['Q']:.6f} (pre-load 1) and "
                 f"{second['Q']:.6f} (pre-load {SECOND_START})")
    rows.append({"case": case, "quantity": f"steady Q from a second start (pre-load {SECOND_START:g} × Carter's Q), "
                 f"ξ = {creep:g}", "level": f"{level}: h = {first['h']:g}, plane-strain slice, hex",
                 "reference": f"{first['Q']:.6f}", "source": "the steady state is the attractor: the same Q from "
                 "either start (docs/verification §8)", "value": f"{second['Q']:.6f}",
                 "error": second["Q"] / first["Q"] - 1.0, "bound": STEADY_TOL, "unknowns": second["unknowns"],
                 "ranks": comm.size, "wall": second["wall"], "agree": "—",
                 "note": "reference: pre-load 1 × Carter's Q; " + _steady_note(second)})
    return rows
