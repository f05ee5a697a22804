r"""Per-node γ of the SCD approximation step: γᵢ = min(γ, κ·λ_max(Aᵢᵢ)) on contact node i, and why the method stays
the paper's.

The paper takes one γ ≈ λ_max(A) (we scale it by ``gamma_scale`` = 0.01, docs/table2). On a graded or distorted
mesh λ_max(A) comes from elements far from the contact (or from one sliver), far above the stiffness of the small
elements at the contact: the stick rows γ I of the Newton matrix then dwarf the rows of A that GAMG (built on A)
approximates, and GMRES stagnates (the Hertz block of benchmarks/hertz.py, 19 542 unknowns: γ = 53.6
against λ_max(Aᵢᵢ) = 14–28 at the contact: 2000 GMRES iterations per step; with γ ≤ 0.5·λ_max(Aᵢᵢ): 20 Newton /
112 Krylov). So every contact node i gets its own

    γᵢ = min(γ, κ·λ_max(Aᵢᵢ)),   κ = ``gamma_node_scale`` (0.5),  Aᵢᵢ the node's 3×3 diagonal block of A,

(:func:`node_gamma`) and γ stays on the other DOFs. On the Section 7 cuboid γ/λ_max(Aᵢᵢ) <= 0.123 at every contact
node (lev 1-7, d1-d3), so γᵢ = γ there and the paper's formulas run bit for bit.

Why this is still the paper's method. Let Γ = diag(γ_j) over all DOFs (γᵢ on the three of contact node i, γ on
the rest) and D = Γ^{1/2}. In u' = D u the GE 0 ∈ A u − l + Q(u) reads 0 ∈ A' u' − l' + Q'(u') with
A' = D⁻¹AD⁻¹ (SPD), l' = D⁻¹l and Q'(u') = D⁻¹Q(D⁻¹u'). On contact node i, Q'ᵢ(v') = γᵢ^{−1/2} Rᵢ Q̃(Rᵢᵀv'/γᵢ^{1/2})
= Rᵢ Q̃(Rᵢᵀv'), because Q̃ is invariant under positive scalings of its argument and of its values
(N_{R+}(c w₃) = N_{R+}(w₃), ∂‖c w₁₂‖ = ∂‖w₁₂‖, and c·Q̃(w) = Q̃(w): ϑ ranges over a cone and the tangential
part is linear in ϑ) — Q' is a contact map of the same kind, and everything the paper proves holds for the
scaled problem with the scalar γ' = 1. Its approximation step maps back to d̂ = D⁻¹(I + Q')⁻¹(u' − r') =
(Γ + Q)⁻¹(Γ u − r) (v' = (I + Q')⁻¹(w') ⇔ D w' ∈ Γ D⁻¹v' + Q(D⁻¹v')), i.e. the closed-form resolvent with γᵢ on
node i and e = r/γ elsewhere; ŷ = (Γ e, e). Its Newton step (5.4) is the step of :mod:`fenics_coulomb.scd.steps`
with every node's blocks and rows taken with its own γᵢ and ŷ₁ = Γ e (checked against the paper's step on the
scaled problem in tests/scd/test_node_gamma.py). Under exact solves the direction depends on γᵢ only through the
approximation step and ŷ₁ (in (5.4) a sliding row's γ·b/a = t/s and a sticking row's γ cancel); the rows' γᵢ
set the scale of the contact rows against A's, which is what the preconditioner built on A sees. ‖ŷ‖ is
‖(Γe, e)‖ = (Σ_j (1 + γ_j²) e_j²)^{1/2}, the paper's √(1 + γ²)‖e‖ when all γᵢ = γ; the local convergence does
not depend on the norm, the line search and the stopping rule use this one.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["node_gamma"]

Array = npt.NDArray[np.float64]


def node_gamma(gamma: float, blocks: Array, scale: float | None) -> Array:
    """γᵢ = min(γ, scale·λ_max(Aᵢᵢ)) of each contact node from A's 3×3 diagonal blocks Aᵢᵢ (shape (m, 3, 3));
    γ everywhere when ``scale`` is None (see the module docstring)."""
    m = blocks.shape[0]
    if scale is None or m == 0:
        return np.full(m, gamma)
    local = np.linalg.eigvalsh(0.5 * (blocks + np.swapaxes(blocks, 1, 2)))[:, -1]
    return np.minimum(gamma, scale * local)
