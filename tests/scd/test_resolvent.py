"""Oracle and property tests of the resolvent (γI + Q̃)⁻¹ (Proposition 6.4) and of the sets (6.9)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize, minimize_scalar

from fenics_coulomb.scd.resolvent import (
    SET_L,
    SET_M1,
    SET_M2,
    SET_M3M,
    SET_M3P,
    SET_M4,
    classify,
    contact_states,
    resolvent,
)

pytestmark = pytest.mark.serial  # pure NumPy: no MPI involved (runs on every rank identically)

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(finite, finite, finite)
gammas = st.floats(1e-3, 1e4)
frictions = st.floats(0.0, 10.0)


def brute_force(w, gamma, F):
    """(γI + Q̃)⁻¹(w) by direct minimization, using only the definition (6.6)–(6.7).

    Normal part: v3 minimizes γ/2·x² − w3·x over x ≥ 0 and ϑ = w3 − γ v3. Tangential part: v12
    minimizes γ/2·‖x‖² − ⟨w12, x⟩ + τ‖x‖ with τ = −F·ϑ (optimality of this strongly convex problem is (6.7)).
    """
    w = np.asarray(w, dtype=float)
    hi = abs(w[2]) / gamma + 1.0
    v3 = minimize_scalar(lambda x: 0.5 * gamma * x * x - w[2] * x, bounds=(0.0, hi), method="bounded",
                         options={"xatol": 1e-14}).x
    if v3 < 1e-10 * hi:
        v3 = 0.0 if w[2] <= 0 else v3
    theta = w[2] - gamma * v3
    tau = -F * theta

    def obj(x):
        return 0.5 * gamma * x @ x - w[:2] @ x + tau * np.linalg.norm(x)

    # a coarse polar grid (with the origin, where the objective is not smooth), refined by Nelder-Mead
    scale = np.linalg.norm(w[:2]) / gamma + 1e-3
    r, phi = np.meshgrid(np.linspace(0, 2 * scale, 41), np.linspace(0, 2 * np.pi, 72, endpoint=False))
    grid = np.stack([(r * np.cos(phi)).ravel(), (r * np.sin(phi)).ravel()], axis=1)
    x0 = grid[np.argmin([obj(x) for x in grid])]
    best = minimize(obj, x0, method="Nelder-Mead",
                    options={"xatol": 1e-11 * scale, "fatol": 1e-16 * (1 + scale), "maxiter": 4000})
    if obj(np.zeros(2)) <= best.fun:
        best.x = np.zeros(2)
    return np.array([best.x[0], best.x[1], v3])


def in_graph(v, z, F, tol):
    """Check z ∈ Q̃(v) straight from (6.5): ϑ ∈ N_{R+}(v3), g ∈ −F·ϑ·∂‖v12‖."""
    g, theta = z[:2], z[2]
    if not (v[2] >= -tol and theta <= tol and abs(v[2] * theta) <= tol * (1 + abs(theta))):
        return False
    s = np.linalg.norm(v[:2])
    if s > tol:
        return np.allclose(g, -F * theta * v[:2] / s, atol=tol * (1 + abs(theta)))
    return np.linalg.norm(g) <= -F * theta + tol * (1 + abs(theta))


@pytest.mark.parametrize("F", [0.0, 0.23, 1.0, 5.0])
@pytest.mark.parametrize("gamma", [0.5, 80.0])
def test_resolvent_matches_brute_force(F, gamma):
    rng = np.random.default_rng(42)
    w = rng.standard_normal((12, 3)) * gamma
    w[:3, 2] = np.abs(w[:3, 2])  # open
    w[3:6, :2] *= 1e-3  # sticking
    v, _ = resolvent(w, gamma, F)
    for i in range(w.shape[0]):
        ref = brute_force(w[i], gamma, F)
        assert np.allclose(v[i], ref, rtol=1e-6, atol=1e-7 * (1 + np.abs(ref).max())), (w[i], v[i], ref)


@settings(max_examples=300, deadline=None)
@given(w=vec3, gamma=gammas, F=frictions)
def test_resolvent_in_graph(w, gamma, F):
    """w − γ v ∈ Q̃(v): the output lies in the graph (Proposition 6.4)."""
    w = np.array([w])
    v, z = resolvent(w, gamma, F)
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(z))
    assert np.allclose(z, w - gamma * v, rtol=1e-12, atol=1e-12 * (1 + np.abs(w).max()))
    assert in_graph(v[0], z[0], F, 1e-9 * (1 + np.abs(w).max()))


@settings(max_examples=300, deadline=None)
@given(w1=vec3, w2=vec3, gamma=gammas, F=frictions)
def test_resolvent_lipschitz(w1, w2, gamma, F):
    """γ‖v¹ − v²‖ ≤ √(2(1 + F²))·‖w¹ − w²‖ (proof of Proposition 6.4)."""
    w = np.array([w1, w2])
    v, _ = resolvent(w, gamma, F)
    lhs = gamma * np.linalg.norm(v[0] - v[1])
    rhs = np.sqrt(2 * (1 + F * F)) * np.linalg.norm(w[0] - w[1])
    assert lhs <= rhs * (1 + 1e-12) + 1e-12 * (1 + np.abs(w).max())


def test_classification_of_each_set():
    """One hand-made graph point per set of (6.9), including the boundary cases."""
    F = 0.5
    gamma = 2.0
    w = np.array([
        [1.0, 2.0, 3.0],   # w3 > 0: L
        [3.0, 0.0, -2.0],  # ‖w12‖ = 3 > τ = 1: M1 (slides)
        [1.0, 1.0, 0.0],   # w3 = 0, w12 ≠ 0: M2
        [0.5, 0.0, -2.0],  # ‖w12‖ = 0.5 < τ = 1: M3+
        [0.6, 0.8, -2.0],  # ‖w12‖ = 1 = τ: M3− (on the cone boundary)
        [0.0, 0.0, 0.0],   # M4
    ])
    v, z = resolvent(w, gamma, F)
    sets = classify(v, z, F)
    assert list(sets) == [SET_L, SET_M1, SET_M2, SET_M3P, SET_M3M, SET_M4]
    assert list(contact_states(sets, F)) == [0, 2, 0, 1, 1, 0]
    # without friction a pressed node at rest is frictionless contact, not sticking
    v0, z0 = resolvent(np.array([[0.0, 0.0, -1.0]]), gamma, 0.0)
    assert list(contact_states(classify(v0, z0, 0.0), 0.0)) == [2]
    # sliding: v12 along w12, friction force magnitude F·λ
    assert np.allclose(v[1], [(1 - 1 / 3) * 3.0 / gamma, 0, 0])
    assert np.isclose(np.linalg.norm(z[1, :2]), F * 2.0)
