r"""An independent brute-force solver of the discrete frictional contact problem (tests only; NumPy/SciPy).

Nothing of the SCD code is used. The problem, for an assembled stiffness K (scipy sparse, Dirichlet rows
already identity-like with zero load, or given through ``dirichlet``), a load f and contact nodes i with DOF
triples cdofs[i], frames Rᵢ = (t₁, t₂, n) (columns), gaps gᵢ, tangential shifts σᵢ and friction Fᵢ:

    K u = f + Σᵢ Eᵢ Rᵢ pᵢ,            pᵢ = (p_t, λ) the contact force on the body in the local frame,
                                      (Eᵢ: the node's DOF triple; a general coupling G replaces Eᵢᵀ u by
                                      (G u)ᵢ, e.g. the relative displacement of two bodies, issue 18)
    gₙ = gᵢ + n·uᵢ ≥ 0,  λ ≥ 0,  λ·gₙ = 0,
    s = T uᵢ + σᵢ (T = (t₁; t₂)),  ‖p_t‖ ≤ Fᵢ λ,  p_t = −Fᵢ λ s/‖s‖ where s ≠ 0.

(σᵢ = −T δ for an obstacle moved by δ; −T(u_{k−1} + δ_k − δ_{k−1}) for step k of a load path.)

It is solved by the Alart–Curnier semismooth Newton method on (u, p) with r > 0:

    Φ_eq = K u − f − B p,                         B = [Eᵢ Rᵢ] (n × 3m),
    Φ_n  = λ − max(0, λ − r gₙ),
    Φ_t  = p_t − proj_{B(0, F·max(0, λ − r gₙ))}(p_t − r s),

Φ = 0 ⟺ the conditions above. Each step solves the (unsymmetric, sparse) generalized Jacobian system
with SuperLU, damped by a backtracking (Armijo) line search on ½‖Φ‖²; r defaults to the mean diagonal of K
on the contact DOFs, which balances the units of the three blocks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla

Array = npt.NDArray[np.float64]


@dataclass
class ContactSolution:
    """Solution of :func:`solve_contact`.

    Attributes:
        u: Displacement, shape (n,).
        force: Local contact force on the body per node (p_t1, p_t2, λ), shape (m, 3).
        gap: gₙ = g + n·u per node, shape (m,).
        slip: s = T u + σ per node, shape (m, 2).
        iterations: Newton iterations taken.
        residual: Final ‖Φ‖.
    """

    u: Array
    force: Array
    gap: Array
    slip: Array
    iterations: int
    residual: float


def _block_diagonal(blocks: Array) -> sp.csr_matrix:
    m = blocks.shape[0]
    return sp.bsr_matrix((blocks, np.arange(m), np.arange(m + 1)), shape=(3 * m, 3 * m)).tocsr()


def with_dirichlet(K: sp.spmatrix, f: Array, dofs: npt.ArrayLike, values: npt.ArrayLike) -> tuple[sp.csr_matrix,
                                                                                                    Array]:
    """K, f with u[dofs] = values imposed symmetrically (identity rows/columns, lifted load)."""
    K = sp.csr_matrix(K, dtype=np.float64, copy=True)
    dofs = np.asarray(dofs, dtype=np.int64)
    ud = np.zeros(K.shape[0])
    ud[dofs] = values
    f = np.asarray(f, dtype=np.float64) - K @ ud
    keep = np.ones(K.shape[0])
    keep[dofs] = 0.0
    D = sp.diags(keep)
    K = (D @ K @ D + sp.diags(1.0 - keep)).tocsr()
    f[dofs] = ud[dofs]
    return K, f


def solve_contact(
    K: sp.spmatrix,
    f: npt.ArrayLike,
    cdofs: npt.ArrayLike,
    gaps: npt.ArrayLike,
    friction: float | npt.ArrayLike = 0.0,
    frames: npt.ArrayLike | None = None,
    shifts: npt.ArrayLike | None = None,
    dirichlet: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
    coupling: sp.spmatrix | None = None,
    r: float | None = None,
    tol: float = 1e-12,
    max_iterations: int = 300,
) -> ContactSolution:
    """Solve the frictional contact problem of the module docstring.

    Args:
        K: Stiffness (n × n, scipy sparse, SPD on the free DOFs).
        f: Load (n,).
        cdofs: DOF indices of the contact nodes, shape (m, 3), Cartesian components.
        gaps: Initial gaps g, shape (m,).
        friction: F (a scalar or per node, shape (m,)).
        frames: R = (t₁, t₂, n) as columns, shape (m, 3, 3); default the identity (obstacle x3 = 0).
        shifts: Tangential shifts σ, shape (m, 2); default 0.
        dirichlet: (dofs, values) to impose on top of K's own rows.
        coupling: A (3m × n) matrix G giving each contact node's Cartesian displacement (relative to its
            counterpart: rows uₛ − Σⱼ φⱼ uⱼ for two bodies) as G u; default the selection of ``cdofs``. The
            contact force then acts on the body as Gᵀ(Rᵢ pᵢ) (action and reaction). ``cdofs`` only gives m
            and the scale of r then.
        r: Alart–Curnier parameter; default the mean diagonal of K on the contact DOFs.
        tol: Stop when ‖Φ‖ <= tol·max(‖f‖, ‖B p‖) and the step is below tol·‖u‖.
        max_iterations: Newton iterations before giving up (AssertionError).
    """
    K = sp.csr_matrix(K, dtype=np.float64)
    f = np.asarray(f, dtype=np.float64).copy()
    if dirichlet is not None:
        K, f = with_dirichlet(K, f, *dirichlet)
    n = K.shape[0]
    cdofs = np.asarray(cdofs, dtype=np.int64).reshape(-1, 3)
    m = cdofs.shape[0]
    g = np.asarray(gaps, dtype=np.float64).reshape(m)
    F = np.broadcast_to(np.asarray(friction, dtype=np.float64), (m,)).copy()
    R = np.broadcast_to(np.eye(3), (m, 3, 3)).copy() if frames is None else np.asarray(frames, np.float64)
    sigma = np.zeros((m, 2)) if shifts is None else np.asarray(shifts, dtype=np.float64).reshape(m, 2)
    if r is None:
        r = float(np.mean(K.diagonal()[cdofs.ravel()])) if m else 1.0
    # B[cdofs[i, a], 3i + b] = R[i, a, b]: B p = Σ Eᵢ Rᵢ pᵢ, (Bᵀu)ᵢ = Rᵢᵀ uᵢ
    rows = np.repeat(cdofs, 3, axis=1).ravel()
    cols = np.tile(3 * np.arange(m)[:, None] + np.arange(3), (1, 3)).ravel()
    B = sp.csr_matrix((R.reshape(-1), (rows, cols)), shape=(n, 3 * m))
    if coupling is not None:
        G = sp.csr_matrix(coupling, dtype=np.float64)
        if G.shape != (3 * m, n):
            raise ValueError(f"coupling must have shape {(3 * m, n)}, got {G.shape}")
        B = (G.T @ _block_diagonal(R)).tocsr()  # B p = Gᵀ (Rᵢ pᵢ), Bᵀ u = Rᵢᵀ (G u)ᵢ
    if dirichlet is not None:  # a prescribed DOF's row is u_d = value: its support takes the contact force
        keep = np.ones(n)
        keep[np.asarray(dirichlet[0], dtype=np.int64)] = 0.0
        B = (sp.diags(keep) @ B).tocsr()
    Bt = B.T.tocsr()

    def residual(u: Array, p: Array) -> tuple[Array, dict]:
        w = (Bt @ u).reshape(m, 3)
        s = w[:, :2] + sigma
        gn = w[:, 2] + g
        P = p.reshape(m, 3)
        lam, pt = P[:, 2], P[:, :2]
        a = lam - r * gn
        active = a > 0.0
        rho = F * np.maximum(a, 0.0)
        q = pt - r * s
        nq = np.hypot(q[:, 0], q[:, 1])
        stick = (nq <= rho) & (rho > 0.0)
        proj = q.copy()
        out = ~stick
        scale = np.zeros(m)
        moving = out & (nq > 0.0)
        scale[moving] = rho[moving] / nq[moving]
        proj[out] = scale[out, None] * q[out]
        phi_loc = np.empty((m, 3))
        phi_loc[:, :2] = pt - proj
        phi_loc[:, 2] = lam - np.maximum(a, 0.0)
        phi = np.concatenate([K @ u - f - B @ p, phi_loc.ravel()])
        return phi, dict(active=active, rho=rho, q=q, nq=nq, stick=stick, moving=moving, s=s, gn=gn)

    def jacobian(state: dict) -> sp.csr_matrix:
        active, rho, q, nq, stick, moving = (state[k] for k in ("active", "rho", "q", "nq", "stick", "moving"))
        Ju = np.zeros((m, 3, 3))  # derivative w.r.t. the local kinematics (T u, n·u)
        Jp = np.zeros((m, 3, 3))  # derivative w.r.t. (p_t, λ)
        # normal row
        Ju[active, 2, 2] = r
        Jp[~active, 2, 2] = 1.0
        # tangential rows: sticking Φ_t = r s
        Ju[stick, 0, 0] = Ju[stick, 1, 1] = r
        # sliding (or free) Φ_t = p_t − ρ q/‖q‖
        free = ~stick & ~moving
        Jp[free, 0, 0] = Jp[free, 1, 1] = 1.0
        idx = np.flatnonzero(moving)
        qh = q[idx] / nq[idx, None]
        D = (np.eye(2) - qh[:, :, None] * qh[:, None, :]) / nq[idx, None, None]
        rD = rho[idx, None, None] * D
        Jp[idx, :2, :2] = np.eye(2) - rD
        Ju[idx, :2, :2] = r * rD
        act = active[idx].astype(float) * F[idx]
        Ju[idx, :2, 2] = r * act[:, None] * qh
        Jp[idx, :2, 2] = -act[:, None] * qh
        lower_u = _block_diagonal(Ju) @ Bt
        lower_p = _block_diagonal(Jp)
        return sp.bmat([[K, -B], [lower_u, lower_p]], format="csc")

    u = spla.spsolve(K.tocsc(), f) if n else np.zeros(0)
    p = np.zeros(3 * m)
    phi, state = residual(u, p)
    norm = np.linalg.norm(phi)
    for k in range(1, max_iterations + 1):
        step = spla.spsolve(jacobian(state), -phi)
        du, dp = step[:n], step[n:]
        alpha = 1.0
        accepted = False
        while alpha > 1e-10:
            phi_t, state_t = residual(u + alpha * du, p + alpha * dp)
            norm_t = np.linalg.norm(phi_t)
            if norm_t <= (1.0 - 1e-4 * alpha) * norm:
                accepted = True
                break
            alpha *= 0.5
        if not accepted:  # a non-monotone full step gets Newton out of a local stall of the merit function
            alpha = 1.0
            phi_t, state_t = residual(u + du, p + dp)
            norm_t = np.linalg.norm(phi_t)
        u, p, phi, state, norm = u + alpha * du, p + alpha * dp, phi_t, state_t, norm_t
        scale = max(np.linalg.norm(f), np.linalg.norm(B @ p), 1e-300)
        if norm <= tol * scale and alpha * np.linalg.norm(du) <= 1e3 * tol * max(np.linalg.norm(u), 1e-300):
            return ContactSolution(u=u, force=p.reshape(m, 3), gap=state["gn"], slip=state["s"], iterations=k,
                                   residual=float(norm))
    raise AssertionError(f"the Alart-Curnier Newton method did not converge in {max_iterations} iterations "
                         f"(|Phi| = {norm:.3e})")


def scipy_matrix(A):
    """A serial PETSc AIJ matrix as scipy CSR."""
    indptr, indices, values = A.getValuesCSR()
    return sp.csr_matrix((values, indices, indptr), shape=A.getSize())
