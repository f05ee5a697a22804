"""Case 6 of the verification table: Cattaneo–Mindlin with β = 0 on the structured-core half model.

The sphere cap (R = 100) on the block of meshes/sphere_on_block_half.py (x2 ≥ 0, rollers u2 = 0 on x2 = 0 in both
bodies, W = 200 a, a = 0.5), both bodies E 70 ν 0.3 (Dundurs' β = 0: the normal and tangential problems
uncouple), μ = 0.3, dual mortar with the block's flat top as the slave (benchmarks/verification_two_body.py
``_CoreModel``). Pressed δ = a²/R, then the flat face moved along x1 (a small probe, then loads aimed at
Q/μP ∈ {0.2, 0.5, 0.8}), then back (Mindlin–Deresiewicz unloading). Every force and displacement is measured
RELATIVE TO THE PRESSED STATE (the press leaves a tangential force of its own, −0.17 % of μP at h₀ = a/8, as large
as the probe's). Per step (docs/verification/README.md §6 derives the references):

* the stick radius c twice: the radius best separating stick from slip slave nodes (resolved to about ±h/2), and
  the least-squares fit of Cattaneo's traction q(r) = μp₀[√(1 − r²/a²) − (c/a)√(1 − r²/c²)] (r < c; μp₀√(1 − r²/a²)
  beyond) to the nodal tractions (force per area: the change of the x1 contact force since the press over the
  node's mortar area D_j), a and p₀ Hertz's for the measured P;
* the slip part of the displacement s = δ − Q δ'(0) against Mindlin's, δ'(0) the stuck compliance of
  :func:`stuck_compliance` (the small probe's secant beside it);
* the side force F₂/Q (0: Mindlin's traction is along x1) and the stick zone's centroid x̄₁/a (0: a disc centred
  on the axis).
"""

from __future__ import annotations

import os
import time
from typing import Any

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from benchmarks.verification_two_body import (A_CORE, CORE_DELTA, MINDLIN_FRICTION, MINDLIN_MATERIAL, R_CORE,
                                              _CoreModel, core_mesh, effective_modulus, mindlin_compliance,
                                              mindlin_slip, unloading_slip)

__all__ = ["MINDLIN_CORE_LEVELS", "MINDLIN_LOADS", "MINDLIN_UNLOADS", "PROBE_LOAD", "STUCK_FRICTION", "STUCK_LOAD",
           "cattaneo_traction", "fit_stick_radius", "mindlin_core", "stuck_compliance"]

#: Levels of the half model for case 6: h₀/a, the edge's growth per unit distance beyond the cores, L/a.
MINDLIN_CORE_LEVELS: dict[int, tuple[float, float, float]] = {
    0: (1 / 4, 0.5, 1.2), 1: (1 / 6, 0.25, 1.2), 2: (1 / 8, 0.2, 1.2)}
#: Cattaneo–Mindlin's loading Q/μP aimed at, then its unloading (from the last) to these Q/μP.
MINDLIN_LOADS = (0.2, 0.5, 0.8)
MINDLIN_UNLOADS = (0.3, -0.4)
#: The probe, Q/μP ≈ 0.002, measures the finite bodies' compliance δ'(0) = δ/Q: the stick zone is the whole
#: contact but its outermost 0.07 % of a (c/a = 0.998^{1/3}); Mindlin's secant there exceeds his slope at 0 by
#: x/6 = 3e-4 (s ≈ x²/9 against 2x/3).
PROBE_LOAD = 0.002
#: Aimed displacements: Mindlin's compliance × this (the finite bodies' bulk adds ≈ 5 %); Q is measured.
BULK = 1.05
#: The stuck probe: the friction that holds every closed node of the pressed state in stick, and the load aimed at
#: (Q/μP of Mindlin's compliance × 1.05; the stuck contact is stiffer: Q comes out ≈ 0.033 μP). Aimed at 0.3, no
#: node slipped but δ'(0) came out 2 % lower and P changed by −0.25 % (h₀ = a/4, growth 0.5): not the bonded slope.
STUCK_FRICTION, STUCK_LOAD = 10.0, 0.03
#: The solver of case 6's models: GAMG, residual reduction MINDLIN_RTOL (the environment variable, for studies).
#: 1e-13: at 1e-12 the one- and two-rank runs differed by 8.8e-8 at h₀ = a/6 (the stuck probe's δ'(0) and the slip
#: parts), at 1e-13 by 4.3e-9 (docs/verification §6).
MINDLIN_SETTINGS = {"pc": "gamg", "rtol": float(os.environ.get("MINDLIN_RTOL", "1e-13"))}


def cattaneo_traction(r: npt.ArrayLike, c: float, a: float, p0: float, friction: float = MINDLIN_FRICTION
                      ) -> npt.NDArray[np.float64]:
    """Cattaneo's tangential traction at the radii ``r``: μp₀[√(1 − r²/a²) − (c/a)√(1 − r²/c²)] for r < c,
    μp₀√(1 − r²/a²) (= μp) for c ≤ r < a, 0 beyond."""
    r = np.asarray(r, dtype=np.float64)
    outer = np.sqrt(np.clip(1 - (r / a) ** 2, 0.0, None))
    inner = (c / a) * np.sqrt(np.clip(1 - (r / c) ** 2, 0.0, None)) if c > 0 else np.zeros_like(r)
    return friction * p0 * (outer - inner)


def fit_stick_radius(r: npt.ArrayLike, q: npt.ArrayLike, weight: npt.ArrayLike, a: float, p0: float,
                     friction: float = MINDLIN_FRICTION) -> float:
    """The c minimising Σ wᵢ (qᵢ − q_C(rᵢ; c))² over the nodes given (``weight``: their areas), q_C Cattaneo's
    traction (:func:`cattaneo_traction`): a grid of 2001 radii in [0, a], then golden-section refinement within the
    best grid cell (the objective is smooth in c)."""
    r, q, w = (np.asarray(v, dtype=np.float64) for v in (r, q, weight))

    def cost(c: float) -> float:
        return float(np.sum(w * (q - cattaneo_traction(r, c, a, p0, friction)) ** 2))

    grid = np.linspace(0.0, a, 2001)
    k = int(np.argmin([cost(c) for c in grid]))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    golden = (np.sqrt(5) - 1) / 2
    x1, x2 = hi - golden * (hi - lo), lo + golden * (hi - lo)
    f1, f2 = cost(x1), cost(x2)
    for _ in range(60):
        if f1 < f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - golden * (hi - lo)
            f1 = cost(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + golden * (hi - lo)
            f2 = cost(x2)
    return float(0.5 * (lo + hi))


def _on_nodes(pressed: dict[str, Any], x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The pressed state's x1 contact force at the contact nodes of reference coordinates ``x`` (0 at a node that
    was no contact node then: the contact map of finite sliding changes with the configuration)."""
    key = dict(zip(_node_keys(pressed["x"]), pressed["force"][:, 0], strict=True))
    return np.array([key.get(k, 0.0) for k in _node_keys(x)])


def _node_keys(x: npt.NDArray[np.float64]) -> list[tuple[float, ...]]:
    return [tuple(np.round(row / A_CORE, 9)) for row in x]


def stuck_compliance(comm: MPI.Comm, mesh: tuple[Any, Any, Any], pressed_u: Any, pressed: dict[str, Any],
                     shift: float) -> dict[str, Any]:
    """The finite bodies' initial tangential compliance δ'(0) measured without a small load: a second model of the
    same mesh with friction ``STUCK_FRICTION``, its history set to the pressed state (``pressed_u``, the pressed
    displacement, and ``pressed``, its measurements), its flat face moved by ``shift`` along x1 at the press's
    depth. Every closed node sticks, so the step is the bonded (Mindlin's Q → 0+) problem, linear in the shift:
    δ'(0) = shift / (Q − Q_press) with Q of order μP, not 0.002 μP (the small probe divides the solver's last
    digits by its Q). Returns δ'(0), Q/μP, the closed nodes not stuck and the nodes whose contact state (closed or
    open) differs from the pressed state's (both 0 for the bonded problem; global counts), P's change (collective)."""
    materials = (MINDLIN_MATERIAL, MINDLIN_MATERIAL)
    model = _CoreModel(comm, mesh, False, materials, STUCK_FRICTION, "mindlin6s_", MINDLIN_SETTINGS)
    try:
        model.problem.reset(pressed_u, step=1)
        s = model.solve((shift, 0.0, -CORE_DELTA))
    finally:
        model.destroy()
    closed = s["state"] != 0
    before = dict(zip(_node_keys(pressed["x"]), pressed["state"] != 0, strict=True))
    after = dict(zip(_node_keys(s["x"]), closed, strict=True))  # a node no longer paired is open
    changed = sum(bool(before.get(k, False)) != bool(after.get(k, False)) for k in set(before) | set(after))
    Q = s["Q"] - pressed["Q"]
    return {"compliance0": shift / Q, "load": Q / (MINDLIN_FRICTION * s["P"]), "Q": Q, "shift": shift,
            "slipping": int(np.sum(closed & (s["state"] != 1))), "changed": int(changed), "closed": int(closed.sum()),
            "P_change": s["P"] / pressed["P"] - 1, "converged": s["converged"], "iterations": s["iterations"]}


def _step(s: dict[str, Any], pressed: dict[str, Any], kind: str, shift: float, compliance0: float,
          x_star: float | None, P: float, a_ref: float) -> dict[str, Any]:
    """One tangential step's measurements, relative to the pressed state ``pressed``."""
    Q = s["Q"] - pressed["Q"]
    x = Q / (MINDLIN_FRICTION * s["P"])
    slip = shift - compliance0 * Q
    if kind == "load":
        slip_ref = float(mindlin_slip(x, P, a_ref))
        total_ref = float(mindlin_compliance(x, P, a_ref))
        c_ref = (1 - x) ** (1 / 3) if x < 1 else 0.0
    else:
        assert x_star is not None
        slip_ref = unloading_slip(x_star, x, P, a_ref)
        total_ref = float(mindlin_compliance(x_star, P, a_ref) - 2 * mindlin_compliance((x_star - x) / 2, P, a_ref))
        c_ref = float("nan")
    # nodal tractions since the press: the x1 contact force on the slave (the block: +x1 under the load) / D_j
    closed = s["state"] != 0
    area = s["area"]
    q = np.divide(s["force"][:, 0] - _on_nodes(pressed, s["x"]), area, out=np.zeros_like(area), where=area > 0)
    p0_ref = 3 * s["P"] / (2 * np.pi * a_ref**2)
    inside = closed & (s["r"] < a_ref)
    c_fit = fit_stick_radius(s["r"][inside], q[inside], area[inside], a_ref, p0_ref) if kind == "load" else np.nan
    stick = s["state"] == 1
    centroid = float(np.sum(area[stick] * s["x"][stick, 0]) / np.sum(area[stick]) / a_ref) if stick.any() else 0.0
    return {"kind": kind, "shift": shift, "load": x, "Q": Q, "c_over_a": s["c"] / s["a"], "c_sep": s["c"],
            "c_fit": c_fit, "c_fit_over_a": c_fit / a_ref, "reference": c_ref,
            "error": (s["c"] / s["a"]) / c_ref - 1 if kind == "load" and c_ref > 0 else float("nan"),
            "error_fit": (c_fit / a_ref) / c_ref - 1 if kind == "load" and c_ref > 0 else float("nan"),
            "slip": slip, "slip_ref": slip_ref, "err_slip": slip / slip_ref - 1, "total_ref": total_ref,
            "err_total": (slip - slip_ref) / abs(total_ref), "P_change": s["P"] / P - 1,
            "side": (s["Q_side"] - pressed["Q_side"]) / Q, "centroid": centroid, "a": s["a"],
            "closed": s["closed"], "stick": s["stick"], "converged": s["converged"],
            "iterations": s["iterations"]}


def mindlin_core(comm: MPI.Comm, level: int | tuple[float, float, float],
                 loads: tuple[float, ...] = MINDLIN_LOADS, unloads: tuple[float, ...] = MINDLIN_UNLOADS,
                 secant_probe: bool = False) -> dict[str, Any]:
    """Case 6 on the half model at ``level`` (:data:`MINDLIN_CORE_LEVELS` or (h₀/a, growth, L/a)): pressed
    δ = a²/R, δ'(0) from the stuck probe (:func:`stuck_compliance`, a second model), loaded to the displacements
    aimed at Q/μP = ``loads`` (Mindlin's compliance × 1.05), then unloaded to those aimed at ``unloads``
    (Mindlin–Deresiewicz from the last load); per step the measurements of :func:`_step`. ``secant_probe``: first
    the former small probe Q/μP ≈ ``PROBE_LOAD`` on the path (its secant shift/Q in ``compliance0_probe``, its
    slipping nodes in ``probe_slipping``; NaN and −1 without) (collective)."""
    t0 = time.perf_counter()
    spec = MINDLIN_CORE_LEVELS[level] if isinstance(level, int) else level
    materials = (MINDLIN_MATERIAL, MINDLIN_MATERIAL)
    mesh = core_mesh(comm, spec, False)
    model = _CoreModel(comm, mesh, False, materials, MINDLIN_FRICTION, "mindlin6_", MINDLIN_SETTINGS)
    steps: list[dict[str, Any]] = []
    compliance0_probe, probe_load, probe_slipping, probe_converged = float("nan"), float("nan"), -1, True
    try:
        pressed = model.solve((0.0, 0.0, -CORE_DELTA))
        P = pressed["P"]
        a_ref = (3 * P * R_CORE / (4 * effective_modulus(materials))) ** (1 / 3)
        stuck = stuck_compliance(comm, mesh, model.problem.u, pressed,
                                 BULK * float(mindlin_compliance(STUCK_LOAD, P, a_ref)))
        compliance0 = stuck["compliance0"]
        if secant_probe:
            probe_shift = BULK * float(mindlin_compliance(PROBE_LOAD, P, a_ref))
            probe = model.solve((probe_shift, 0.0, -CORE_DELTA))
            compliance0_probe = probe_shift / (probe["Q"] - pressed["Q"])
            probe_load = (probe["Q"] - pressed["Q"]) / (MINDLIN_FRICTION * P)
            probe_slipping, probe_converged = int(np.sum(probe["state"] == 2)), probe["converged"]
        shifts = [("load", x, BULK * float(mindlin_compliance(x, P, a_ref))) for x in loads]
        top, x_top = shifts[-1][2], loads[-1]
        shifts += [("unload", x, top - 2 * BULK * float(mindlin_compliance((x_top - x) / 2, P, a_ref)))
                   for x in unloads]
        x_star = None
        for kind, aim, shift in shifts:
            s = model.solve((shift, 0.0, -CORE_DELTA))
            steps.append({"aim": aim, **_step(s, pressed, kind, shift, compliance0, x_star, P, a_ref)})
            if kind == "load":
                x_star = steps[-1]["load"]
    finally:
        model.destroy()
    G = MINDLIN_MATERIAL[0] / (2 * (1 + MINDLIN_MATERIAL[1]))
    return {"steps": steps, "P": P, "a": pressed["a"], "a_ref": a_ref, "err_radius": pressed["a"] / a_ref - 1,
            "compliance0": compliance0, "compliance0_probe": compliance0_probe, "stuck": stuck,
            "compliance0_halfspace": (2 - MINDLIN_MATERIAL[1]) / (4 * G * a_ref),
            "press_Q": pressed["Q"] / (MINDLIN_FRICTION * P), "press_side": pressed["Q_side"] / (MINDLIN_FRICTION * P),
            "press_stick": pressed["stick"], "press_slipping": int(np.sum(pressed["state"] == 2)),
            "h_over_a": spec[0], "growth": spec[1], "unknowns": pressed["unknowns"],
            "closed": pressed["closed"], "probe": probe_load, "probe_slipping": probe_slipping,
            "converged": pressed["converged"] and probe_converged and stuck["converged"]
            and all(s["converged"] for s in steps),
            "a_core": A_CORE, "wall": time.perf_counter() - t0}
