"""An independent reference solver for small contact problems, on dense matrices (tests only)."""

from __future__ import annotations

import numpy as np


def tresca_fixed_point(A, load, cdofs, gap, F, tol=1e-13):
    """Independent reference: Coulomb contact as the fixed point λ ↦ λ(Tresca(F·λ)) [Haslinger et al.].

    Each Tresca problem min ½ũᵀAũ − l̃ᵀũ + Σ sᵢ‖ũ₁₂ⁱ‖ s.t. ũ₃ⁱ ≥ −αᵢ is solved by FISTA with restarts
    (small problem); λᵢ is the normal component of A ũ − l̃ at node i. ``A`` may be dense: its products are taken
    in CSR form (the same iteration; a dense product cost 100 times more on the 4131 DOFs of the wavy Signorini
    scene) and the step 1/L from its largest eigenvalue by Lanczos (scipy's eigsh; the dense eigvalsh, 30 s
    there, gave the same L to 5e-15).
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import eigsh

    A = sp.csr_matrix(A)
    L = float(eigsh(A, k=1, which="LA", return_eigenvectors=False)[0])
    u = np.zeros(A.shape[0])
    lam = np.zeros(len(gap))

    def prox(y, s):
        x = y.copy()
        x[cdofs[:, 2]] = np.maximum(y[cdofs[:, 2]], -gap)
        t = y[cdofs[:, :2]]
        nt = np.linalg.norm(t, axis=1)
        factor = np.where(nt > s / L, 1 - s / (L * np.maximum(nt, 1e-300)), 0.0)
        x[cdofs[:, :2]] = factor[:, None] * t
        return x

    for _outer in range(500):
        s = F * lam
        y = u.copy()
        tk = 1.0
        for _ in range(200000):
            u_new = prox(y - (A @ y - load) / L, s)
            if np.linalg.norm(u_new - u) <= tol * max(np.linalg.norm(u_new), 1e-300):
                u = u_new
                break
            t_new = 0.5 * (1 + np.sqrt(1 + 4 * tk * tk))
            if (u_new - u) @ (y - u_new) > 0:  # adaptive restart
                t_new, y = 1.0, u_new.copy()
            else:
                y = u_new + (tk - 1) / t_new * (u_new - u)
            u, tk = u_new, t_new
        lam_new = np.maximum((A @ u - load)[cdofs[:, 2]], 0.0)
        if np.linalg.norm(lam_new - lam) <= 1e-11 * np.linalg.norm(lam_new):
            return u
        lam = lam_new
    raise AssertionError("the Tresca fixed point did not converge")
