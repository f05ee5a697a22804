"""The SCD semismooth* Newton method in per-node frames, on scipy matrices (tests only).

A transcription of fenics_coulomb.scd.newton's approximation and Newton steps (variants 4a and 4b), once for the
paper's identity frames and once in Cartesian variables with per-node frames by the formulas derived in
fenics_coulomb.model.obstacles, and a small driver with the paper's line search. Used to check the derivation:
the frame step against the paper's step on the explicitly rotated problem, and the frame iteration's
solution against the independent Alart–Curnier solver of brute_force.py.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fenics_coulomb.scd.derivatives import s_blocks, sstar_blocks
from fenics_coulomb.scd.newton import line_search_steps
from fenics_coulomb.model.frames import rotate_rows, to_local
from fenics_coulomb.scd.resolvent import frame_approximation
from fenics_coulomb.scd.resolvent import classify, resolvent


def block_diagonal(blocks):
    m = blocks.shape[0]
    return sp.bsr_matrix((blocks, np.arange(m), np.arange(m + 1)), shape=(3 * m, 3 * m)).tocsr()


def newton_matrix(A, nodes, contact, left, right):
    """A with the contact rows replaced by Bⁱ Aⁱ + Cⁱ (the in-place update of newton.ContactRows)."""
    Bfull = np.broadcast_to(np.eye(3), (nodes, 3, 3)).copy()
    Cfull = np.zeros((nodes, 3, 3))
    Bfull[contact], Cfull[contact] = left, right
    return (block_diagonal(Bfull) @ A + block_diagonal(Cfull)).tocsc()


def paper_direction(A, rhs, u, contact, gamma, F, variant):
    """One approximation and Newton step of newton.py transcribed for identity frames (the paper's)."""
    nodes = A.shape[0] // 3
    cd = 3 * contact[:, None] + np.arange(3)
    r = A @ u - rhs
    e = r / gamma
    v, z = resolvent(gamma * u[cd] - r[cd], gamma, F)
    e[cd] = u[cd] - v
    sets = classify(v, z, F)
    if variant == "4a":
        W, U = sstar_blocks(v, z / gamma, sets, F)
        left, right = np.swapaxes(W, 1, 2), gamma * np.swapaxes(U, 1, 2)
        b = -gamma * e
        b[cd] = -gamma * (np.einsum("iab,ib->ia", left, e[cd]) + np.einsum("iab,ib->ia", right, e[cd]) / gamma)
        return spla.spsolve(newton_matrix(A, nodes, contact, left, right), b), e, v, z, sets
    X, Y = s_blocks(v, z / gamma, sets, F)
    left, right = np.swapaxes(X, 1, 2), gamma * np.swapaxes(Y, 1, 2)
    M = newton_matrix(A, nodes, contact, left, right)
    b = A @ e - gamma * e - M.T @ e
    p = spla.spsolve(M.T.tocsc(), b) + e
    du = p - e
    du[cd] = np.einsum("iba,ib->ia", left, p[cd]) - e[cd]
    return du, e, v, z, sets


def frame_direction(A, rhs, u, contact, R, gamma, F, variant):
    """The same step in Cartesian variables with per-node frames, by the module docstring's formulas."""
    nodes = A.shape[0] // 3
    cd = 3 * contact[:, None] + np.arange(3)
    r = A @ u - rhs
    e = r / gamma
    e[cd], v, z = frame_approximation(u[cd], r[cd], R, gamma, F)
    e_local = e.copy()
    e_local[cd] = to_local(R, e[cd])
    sets = classify(v, z, F)
    if variant == "4a":
        W, U = sstar_blocks(v, z / gamma, sets, F)
        Wt, Ut = np.swapaxes(W, 1, 2), np.swapaxes(U, 1, 2)
        left, right = rotate_rows(R, Wt), rotate_rows(R, gamma * Ut)
        b = -gamma * e
        b[cd] = -gamma * (np.einsum("iab,ib->ia", Wt, e_local[cd]) + np.einsum("iab,ib->ia", Ut, e_local[cd]))
        return spla.spsolve(newton_matrix(A, nodes, contact, left, right), b), e, v, z, sets
    X, Y = s_blocks(v, z / gamma, sets, F)
    left = rotate_rows(R, np.swapaxes(X, 1, 2))
    right = rotate_rows(R, gamma * np.swapaxes(Y, 1, 2))
    M = newton_matrix(A, nodes, contact, left, right)
    b = A @ e - gamma * e - M.T @ e_local
    p = spla.spsolve(M.T.tocsc(), b) + e_local
    du = p - e_local
    du[cd] = np.einsum("iba,ib->ia", left, p[cd]) - e[cd]
    return du, e, v, z, sets


def solve_in_frames(A, load, contact, R, s, F, variant="4a", rtol=1e-12, gamma_scale=0.01, max_iterations=100):
    """The SCD iteration in Cartesian variables with frames R and local shifts s on the contact nodes.

    Args:
        A: Stiffness (scipy sparse, blocked by node: DOF 3·node + component).
        load: Physical load l̃.
        contact: Node indices of the contact nodes, shape (m,).
        R: Frames (t₁, t₂, n) as columns, shape (m, 3, 3).
        s: Local shifts sⁱ = (−T o, g), shape (m, 3).
        F: Friction coefficient.

    Returns:
        (ũ, v, z, iterations): the physical displacement and the local graph point at the solution.
    """
    A = sp.csr_matrix(A)
    cd = 3 * contact[:, None] + np.arange(3)
    d = np.zeros(A.shape[0])
    d[cd] = np.einsum("iab,ib->ia", R, s)  # d = 𝓡 s
    rhs = load + A @ d
    gamma = gamma_scale * float(spla.eigsh(A, k=1, which="LA", return_eigenvectors=False)[0])
    u = d.copy()  # ũ = 0

    def norm_of(u):
        r = A @ u - rhs
        e = r / gamma
        e[cd], v, z = frame_approximation(u[cd], r[cd], R, gamma, F)
        return math.sqrt(1.0 + gamma**2) * np.linalg.norm(e), v, z

    res, v, z = norm_of(u)
    res0 = res
    for k in range(max_iterations):
        if res <= rtol * res0:
            return u - d, v, z, k
        du, *_ = frame_direction(A, rhs, u, contact, R, gamma, F, variant)
        bound = 1.0 + 0.1 / (k + 1)
        for alpha in line_search_steps(20):
            rest, vt, zt = norm_of(u + alpha * du)
            if rest <= (bound - 0.1 * alpha) * res:
                break
        else:
            raise AssertionError("the line search failed")
        u, res, v, z = u + alpha * du, rest, vt, zt
    raise AssertionError(f"no convergence in {max_iterations} iterations ({res / res0:.2e})")
