"""Oracle tests of the SCD derivative elements: S*Q̃ and SQ̃ (Proposition 6.6, Corollary 6.7, (6.16))."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fenics_coulomb.scd.derivatives import pressed_branch, s_blocks, sstar_blocks
from fenics_coulomb.scd.resolvent import SET_M1, SET_M2, SET_M4, classify, resolvent

pytestmark = pytest.mark.serial


def projector(basis):
    """Orthogonal projector onto the column range of a 6×3 matrix."""
    q, _ = np.linalg.qr(basis)
    return q @ q.T


def same_range(a, b, tol=1e-8):
    return np.linalg.norm(projector(a) - projector(b)) < tol


def graph_tangent(v12, theta, F, h=1e-6):
    """Tangent space of gph Q̃ at a sliding point, by central differences of the local chart
    (v12, ϑ) ↦ (v12, 0, −F·ϑ·v12/‖v12‖, ϑ) (proof of Proposition 6.6); returns a 6×3 basis."""
    def chart(p):
        x12, th = p[:2], p[2]
        return np.concatenate([x12, [0.0], -F * th * x12 / np.linalg.norm(x12), [th]])

    p0 = np.array([v12[0], v12[1], theta])
    cols = []
    for j in range(3):
        e = np.zeros(3)
        e[j] = h * max(1.0, abs(p0[j]))
        cols.append((chart(p0 + e) - chart(p0 - e)) / (2 * e[j]))
    return np.array(cols).T


def adjoint_space(basis):
    """L* = {(−v*, u*) | (u*, v*) ∈ L^⊥} of (3.1), for L = rge(basis) ⊂ R³ × R³."""
    _, _, vt = np.linalg.svd(basis.T)
    perp = vt[3:].T  # 6×3 basis of L^⊥
    return np.vstack([-perp[3:], perp[:3]])


def unscaled(v12, theta, F):
    """The paper's bases (6.12) and (6.13) (with −F·v12/‖v12‖ in (6.12), as (6.14) has it)."""
    s = np.linalg.norm(v12)
    n = v12 / s
    P = np.eye(2) - np.outer(n, n)
    X, Y, W, U = (np.zeros((3, 3)) for _ in range(4))
    X[:2, :2] = np.eye(2)
    Y[:2, :2] = -F * theta / s * P
    Y[:2, 2] = -F * n
    Y[2, 2] = 1.0
    W[:2, :2] = np.eye(2)
    W[2, :2] = F * n
    U[:2, :2] = -F * theta / s * P
    U[2, 2] = 1.0
    return (X, Y), (W, U)


sliding_points = st.tuples(
    st.floats(0.05, 5.0), st.floats(0.0, 2 * np.pi), st.floats(-5.0, -0.01), st.floats(0.01, 3.0)
)


@settings(max_examples=200, deadline=None)
@given(point=sliding_points)
def test_sliding_subspaces(point):
    s, phi, theta, F = point
    v = np.array([[s * np.cos(phi), s * np.sin(phi), 0.0]])
    z = np.array([[-F * theta * np.cos(phi), -F * theta * np.sin(phi), theta]])
    sets = classify(v, z, F)
    assert sets[0] == SET_M1
    X, Y = s_blocks(v, z, sets, F)
    W, U = sstar_blocks(v, z, sets, F)
    (X0, Y0), (W0, U0) = unscaled(v[0, :2], theta, F)
    ours_s = np.vstack([X[0], Y[0]])
    ours_star = np.vstack([W[0], U[0]])
    # the scaled bases span the paper's unscaled subspaces (6.12), (6.13)
    assert same_range(ours_s, np.vstack([X0, Y0]))
    assert same_range(ours_star, np.vstack([W0, U0]))
    # and, independently of the paper's formulas, the tangent space of the graph and its adjoint (3.1)
    T = graph_tangent(v[0, :2], theta, F)
    assert same_range(ours_s, T, tol=1e-6)
    assert same_range(ours_star, adjoint_space(T), tol=1e-6)
    # full column rank (elements of Z_3)
    assert np.linalg.matrix_rank(ours_s) == 3 and np.linalg.matrix_rank(ours_star) == 3


@pytest.mark.parametrize("s", [1e-300, 1e-12, 1e-6, 1.0])
def test_scaled_bases_stay_bounded(s):
    """Corollary 6.7: as the slip s → 0 the scaled bases stay bounded (the unscaled ones blow up as 1/s)."""
    F, theta = 0.23, -1.0
    v = np.array([[s, 0.0, 0.0]])
    z = np.array([[-F * theta, 0.0, theta]])
    sets = classify(v, z, F)
    for A, B in (s_blocks(v, z, sets, F), sstar_blocks(v, z, sets, F)):
        assert np.all(np.isfinite(A)) and np.all(np.isfinite(B))
        assert np.abs(A).max() <= max(1.0, F) + 1e-15 and np.abs(B).max() <= max(1.0, F) + 1e-15


def test_smooth_and_boundary_sets():
    """(6.10), (6.11), (6.16): open and grazing nodes rge(I, 0), sticking nodes rge(0, I) (the paper's free branch at
    the grazing, biactive points; the pressed one: the test below)."""
    F, gamma = 0.5, 2.0
    w = np.array([[1.0, 2.0, 3.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.5, 0.0, -2.0], [0.6, 0.8, -2.0]])
    v, z = resolvent(w, gamma, F)
    sets = classify(v, z, F)
    X, Y = s_blocks(v, z, sets, F)
    W, U = sstar_blocks(v, z, sets, F)
    for i in range(3):
        assert np.array_equal(X[i], np.eye(3)) and not Y[i].any()
        assert np.array_equal(W[i], np.eye(3)) and not U[i].any()
    for i in (3, 4):
        assert not X[i].any() and np.array_equal(Y[i], np.eye(3))
        assert not W[i].any() and np.array_equal(U[i], np.eye(3))


def test_frictionless_pressed_node_is_free_tangentially():
    """F = 0: the graph is smooth at pressed nodes; the element is rge(diag(1,1,0), diag(0,0,1))."""
    v, z = resolvent(np.array([[0.0, 0.0, -1.0], [2.0, 0.0, -1.0]]), 1.0, 0.0)
    sets = classify(v, z, 0.0)
    X, Y = s_blocks(v, z, sets, 0.0)
    W, U = sstar_blocks(v, z, sets, 0.0)
    for i in range(2):
        assert np.allclose(X[i], np.diag([1, 1, 0])) and np.allclose(Y[i], np.diag([0, 0, 1]))
        assert np.allclose(W[i], np.diag([1, 1, 0])) and np.allclose(U[i], np.diag([0, 0, 1]))


@pytest.mark.parametrize("F", [0.0, 0.4])
@pytest.mark.parametrize("adjoint", [True, False])
def test_the_pressed_branch_at_biactive_points_is_a_limit_of_pressed_points(F, adjoint):
    """Biactive points (v3 = 0, ϑ = 0): grazing while moving (M2: v12 ≠ 0) and grazing at rest (M4: v = 0). Their
    pressed branch (:func:`pressed_branch`: M2 → M1, M4 → M3+) gives the subspaces of the pressed points nearby,
    ϑ = −ε with the same v (sliding at M2's slip; sticking inside the cone at M4: z12 = 0), as ε → 0: an element of
    the SCD derivative at the biactive point, like the paper's free branch rge(I, 0), the limit from the open side."""
    blocks = sstar_blocks if adjoint else s_blocks
    v = np.array([[0.3, -0.4, 0.0], [0.0, 0.0, 0.0]])
    z = np.zeros((2, 3))
    sets = classify(v, z, F)
    assert list(sets) == [SET_M2, SET_M4]
    A, B = blocks(v, z, pressed_branch(sets), F)
    for eps in (1e-6, 1e-9, 1e-12):
        zp = np.array([[F * eps * 0.6, F * eps * -0.8, -eps], [0.0, 0.0, -eps]])  # z12 = −F·ϑ·v12/‖v12‖ on M2
        pressed = classify(v, zp, F)
        Ap, Bp = blocks(v, zp, pressed, F)
        for i in range(2):
            assert same_range(np.vstack([A[i], B[i]]), np.vstack([Ap[i], Bp[i]]), tol=1e-5), (i, eps)
    # the free branch (the paper's, rge(I, 0)) is what the sets themselves give
    A0, B0 = blocks(v, z, sets, F)
    assert np.array_equal(A0, np.broadcast_to(np.eye(3), (2, 3, 3))) and not B0.any()
