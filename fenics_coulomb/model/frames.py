r"""Per-node contact frames R = (t₁, t₂, n) and the SCD method written in them.

Tangents (a documented, deterministic choice)
---------------------------------------------
Each node gets the orthonormal, right-handed frame R = (t₁, t₂, n) — the COLUMNS of a 3×3 matrix, so the
local components of a Cartesian vector u are Rᵀu = (t₁·u, t₂·u, n·u) and det R = +1 (t₁ × t₂ = n):

* plane and sphere: t₁ = the normalized projection of e₁ onto n^⊥ when |n·e₁| <= 1/√2, otherwise that of e₂
  (always well conditioned: the projected vector has length >= 1/√2); t₂ = n × t₁. The frame is continuous
  except across the cone |n·e₁| = 1/√2 (a sphere has no continuous tangent field anyway), and for the
  default plane (ν = e₃) it is exactly the identity — the paper's frame (tangential x1, x2; normal x3).
* cylinder: t₁ = a (continuous everywhere), t₂ = n × a (the circumferential direction).
* Degenerate nodes, where the normal is undefined (they lie deep inside the obstacle, g = −R): a node at a
  sphere's centre gets n = e₃; a node on a cylinder's axis gets n = the normalized projection of e₃ onto a^⊥
  when |a·e₃| <= 1/√2, otherwise that of e₁. "At"/"on" means up to round-off: a distance below
  16·ε·(‖x‖ + ‖placed position‖), whose direction is noise. No NaN arises.

Isotropic Coulomb friction only sees ‖t‖, so the solution does not depend on the tangent choice (only the
t₁/t₂ components of the forces do, and outputs map them back to x, y, z).

The SCD method in per-node frames (the derivation)
--------------------------------------------------
Notation. The contact mapping Q̃ of :mod:`fenics_coulomb.scd.resolvent` acts on local blocks v = (v₁₂, v₃) —
tangential first, normal last (the paper's block order; today's frame is the identity: v₁₂ = (u₁, u₂),
v₃ = u₃ + α). For contact node i with frame Rᵢ = (t₁, t₂, n), gap gᵢ and tangential offset oᵢ (a Cartesian
vector) the local kinematics are

    vⁱ = Rᵢᵀ ũⁱ + sⁱ,   sⁱ = (−t₁·oᵢ, −t₂·oᵢ, gᵢ)            (:func:`local_shift`)

so v₃ = g + n·ũ (the linearized gap) and v₁₂ = T(ũ − oᵢ) with T = (t₁; t₂). Static obstacle problem: oᵢ = δ
(the slip s = T(u − δ) of a body dragged by a moving obstacle); load path step k: oᵢ = ũ_{k−1} +
δ_k − δ_{k−1}, so that v₁₂ = T(ũ_k − ũ_{k−1}) − T(δ_k − δ_{k−1}). The tangential shift enters exactly like
the gap: as a constant added to the local block.

Problem. The contact force on the body at node i is −Rᵢ zⁱ with zⁱ ∈ Q̃(vⁱ) (the virtual work of a
potential φ(Rᵢᵀũⁱ + sⁱ) has the gradient Rᵢ ∂φ), so the GE in the physical displacement ũ is

    0 ∈ A ũ − l̃ + 𝓡 Q̃(𝓡ᵀ ũ + s),

with 𝓡 the block-diagonal orthogonal matrix (Rᵢ on contact nodes, I elsewhere) and s zero off the contact
nodes. Put û := 𝓡ᵀ ũ + s and multiply by 𝓡ᵀ: û solves the paper's GE (6.3) in the rotated basis,

    0 ∈ Â û − l̂ + Q̃(û),   Â = 𝓡ᵀ A 𝓡 (SPD, same spectrum as A),   l̂ = 𝓡ᵀ(l̃ + A 𝓡 s),

so everything the paper proves and the code does holds verbatim in the hatted variables. Back in
Cartesian variables: the shift vector d := 𝓡 s (dⁱ = Rᵢ sⁱ = −TᵀT oᵢ + gᵢ n; today (0, 0, α)) gives the
shifted Cartesian unknown u = ũ + d = 𝓡 û and the load l = l̃ + A d, exactly as in
:mod:`fenics_coulomb.model.contact_model`. The residuals are r̂ = Â û − l̂ = 𝓡ᵀ(A u − l) = 𝓡ᵀ r, and since 𝓡 is
orthogonal, norms (‖ŷ‖, the line search, the stopping rule, γ's power method) are frame independent.

Approximation step (6.17). d̂ = (γI + Q̃)⁻¹(γ û − r̂) node-wise, i.e. on contact node i

    (vⁱ, zⁱ) = resolvent(Rᵢᵀ(γ uⁱ − rⁱ)),   eⁱ = uⁱ − Rᵢ vⁱ (Cartesian), êⁱ = Rᵢᵀ eⁱ = ûⁱ − vⁱ (local),

and e = r/γ elsewhere (:func:`~fenics_coulomb.scd.resolvent.frame_approximation`). The resolvent, the sets (6.9)
and the S*Q̃/SQ̃ blocks are evaluated unchanged at the LOCAL graph point (vⁱ, zⁱ). Equivalently, the Cartesian contact map
Qᵢ(ũ) = Rᵢ Q̃(Rᵢᵀũ + sⁱ) has the resolvent (γI + Qᵢ)⁻¹(w) = Rᵢ(J̃(Rᵢᵀw + γ sⁱ) − sⁱ), J̃ = (γI + Q̃)⁻¹, its
graph is the local graph rotated by Rᵢ in both components, and so are the SCD subspaces:
rge(X, Y) ∈ SQ̃ ⇒ rge(Rᵢ X, Rᵢ Y) ∈ SQᵢ, rge(W*, U*) ∈ S*Q̃ ⇒ rge(Rᵢ W*, Rᵢ U*) ∈ S*Qᵢ (the adjoint
(3.1) of a subspace rotated by diag(Rᵢ, Rᵢ) is the rotated adjoint, as the rotation is orthogonal).

Newton step 4a, system (5.4) in the hatted variables: (𝔜*ᵀ Â + 𝔛*ᵀ) Δû = −(𝔜*ᵀ γ ê + 𝔛*ᵀ ê), 𝔜* and 𝔛*
block diagonal (W*ⁱ, U*ⁱ on contact nodes, I and 0 elsewhere). With Δû = 𝓡ᵀ Δu and
Â = 𝓡ᵀ A 𝓡 the matrix acting on the CARTESIAN Δu is (𝔜*ᵀ Â + 𝔛*ᵀ) 𝓡ᵀ = 𝔜*ᵀ 𝓡ᵀ A + 𝔛*ᵀ 𝓡ᵀ: rows off the
contact nodes stay those of A, and a contact node's rows Bⁱ Aⁱ + Cⁱ (Aⁱ its 3 rows of A, Cⁱ on its own
columns) become

    Bⁱ → Bⁱ Rᵢᵀ,   Cⁱ → Cⁱ Rᵢᵀ     (B = W*ᵀ, C = γ U*ᵀ; :func:`rotate_rows`),

with the unchanged right-hand side −(Bⁱ γêⁱ + Cⁱ êⁱ) of the UNROTATED Bⁱ, Cⁱ and the local êⁱ. The solution is the
Cartesian Δu (no rotation back), and the line search works on Cartesian u, r = A u − l.

Newton step 4b: with M̂ = 𝔛ᵀ Â + 𝔜ᵀ (γ Yᵀ on contact rows) the code solves M̂ᵀ q̂ = Â ê − γ ê − M̂ᵀ ê and
sets p̂ = q̂ + ê, Δû = 𝔛 p̂ − ê. With M := M̂ 𝓡ᵀ (the same row rotation Bⁱ → Bⁱ Rᵢᵀ, Cⁱ → Cⁱ Rᵢᵀ as in 4a)
M̂ᵀ = 𝓡ᵀ Mᵀ, so q̂ solves Mᵀ q̂ = A e − γ e − Mᵀ ê (Cartesian e, local ê; q̂ lives in the LOCAL basis on
contact nodes), p̂ = q̂ + ê and Δu = 𝓡 Δû: Δuⁱ = Rᵢ Xⁱ p̂ⁱ − eⁱ = (Bⁱ)ᵀ p̂ⁱ − eⁱ on contact nodes, Δu = q̂
elsewhere.

In the solver (:mod:`fenics_coulomb.scd.newton`) the contact rows are in addition multiplied from the left by
Rᵢ — an orthogonal change of the node's three equations, so Δu and every residual norm stay the same — so the
blocks become Rᵢ Bⁱ Rᵢᵀ and Rᵢ Cⁱ Rᵢᵀ (:func:`conjugate`): the Cartesian blocks of the rotated SCD
subspaces (rge(Rᵢ X, Rᵢ Y) = rge(Rᵢ X Rᵢᵀ, Rᵢ Y Rᵢᵀ)). Then the steps of :mod:`fenics_coulomb.scd.steps` run
unchanged on the Cartesian e (4a: right-hand side −(B γe + C e) with the conjugated blocks = Rᵢ times the one
above; 4b: Mᵀ with M = 𝓡 M̂ 𝓡ᵀ is solved for the Cartesian q = 𝓡 q̂, and Δuⁱ = (Rᵢ Bⁱ Rᵢᵀ)ᵀ pⁱ − eⁱ). Row
rotation alone (Bⁱ Rᵢᵀ) would be as correct but leaves zero diagonal entries where the frame permutes the
axes (a cylinder's t₁ = a = e₂), on which ILU(0) breaks down.

Contact nodes with held components
----------------------------------
A Dirichlet condition may hold one or two Cartesian components e_h of a contact node (a symmetry plane or a
roller through the contact zone) when every held e_h is orthogonal to the node's normal (|n·e_h| <=
:data:`HELD_NORMAL_TOL`; the normal is then projected onto the held directions' complement and normalized,
exactly orthogonal) and the node does not slip along e_h (held at 0 against an obstacle that does not move
along e_h: the held slip g_h − o_h is 0). The frame puts the held directions first (:func:`held_frames`): t₁ = e_h
(the first held axis), t₂ = n × t₁ (= ±e_h' for a second held axis), so the held DOFs are local components of the
frame (:func:`local_held`). On such a node the contact law is the law on the remaining components: the Coulomb cone of
the free tangent (or Signorini alone with two held axes), nothing in the held ones, whose rows stay the Dirichlet
identity rows (the support's reaction takes whatever force acts there). In the algebra:

* the tangential offset has no held component (o_h = 0), so dⁱ = Rᵢ sⁱ has none either (d_D = 0: the
  Dirichlet rows of A u = l hold u_D = g with l_D = s g, as for every other Dirichlet row);
* the approximation step evaluates the resolvent on Rᵢᵀ(γ u − r) with its held local components set to 0:
  Q̃ is invariant under the reflection v₁ → −v₁ (its graph at w₁ = 0 has v₁ = z₁ = 0), so the result is the
  resolvent of the law on the free components (the 1D Coulomb interval in t₂, or Signorini alone); v and z
  are 0 in the held components and e = r/γᵢ there, as on a DOF without contact;
* the Newton blocks at such a point are block diagonal over {held} ⊕ {free} (the sliding formulas with
  n = v₁₂/‖v₁₂‖ ⊥ e₁: C = a I + b n nᵀ, b(I − n nᵀ), F n all decouple; stick and open are diagonal), and the
  held rows/columns are set to those of a DOF without contact, (B, C) = (1, 0): the conjugated row
  Rᵢ Bⁱ Rᵢᵀ Aⁱ + Rᵢ Cⁱ Rᵢᵀ of the held DOF is A's Dirichlet row, the free rows do not see the held column.

The SCD step is then that of the product law (free-component contact law) × (no contact in the held components)
with the held components Dirichlet DOFs. It is the Coulomb problem with those DOFs held because the held slip is
0: Q̃ at (0, v₂, v₃) contains the points with z₁ = 0 (sliding along t₂: z₁₂ = −Fλ (0, ±1), the only point;
sticking: z₁ = 0 is one point of the disc, and z₁ acts only on the Dirichlet row, whose reaction absorbs it).
A node driven along the contact by its support (a pushed face's edge: held slip ≠ 0) would need the friction
of the prescribed slip in the held direction, which this law does not model: such nodes are no contact nodes
(:class:`~fenics_coulomb.model.contact_map.ContactMap`), and a placement that makes a held slip non-zero is an
InputError.

Outputs: the contact force on the body is −Rᵢ zⁱ (Cartesian), its normal part λ = −z₃ ≥ 0, the tangential
force −Rᵢ (z₁, z₂, 0) (a true 3-vector), the gap v₃ = g + n·ũ ≥ 0, the slip v₁₂.

``tests/model/test_obstacles.py`` checks this numerically: the Cartesian formulas above against the paper's
iteration on the explicitly rotated problem (Â, l̂) for random frames and shifts (the Newton directions of
4a and 4b), the rotated S*Q/SQ blocks against finite differences of the Cartesian resolvent, and the whole
iteration against an independent Alart–Curnier solver (``tests/brute_force.py``).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["HELD_NORMAL_TOL", "PAIR_HELD_NORMAL_TOL", "frames_from_normals", "held_frames", "local_held", "to_local",
           "to_global",
           "rotate_rows", "conjugate", "local_shift"]

Array = npt.NDArray[np.float64]


def frames_from_normals(n: npt.ArrayLike, t1: npt.ArrayLike | None = None) -> Array:
    """Right-handed orthonormal frames R = (t₁, t₂, n) (columns), shape (m, 3, 3).

    Args:
        n: Unit normals, shape (m, 3).
        t1: Unit first tangents ⊥ n, shape (m, 3); default: the plane/sphere rule of the module docstring
            (projection of e₁, or of e₂ when |n·e₁| > 1/√2).
    """
    n = np.asarray(n, dtype=np.float64).reshape(-1, 3)
    t1 = _perpendicular(n, 0, 1) if t1 is None else np.asarray(t1, dtype=np.float64).reshape(-1, 3)
    t2 = np.cross(n, t1)
    return np.stack([t1, t2, n], axis=2)


def to_local(R: Array, x: npt.ArrayLike) -> Array:
    """Local components Rᵢᵀ xⁱ = (t₁·x, t₂·x, n·x) of Cartesian vectors x, shape (m, 3)."""
    return np.einsum("iab,ia->ib", R, np.asarray(x, dtype=np.float64))


def to_global(R: Array, v: npt.ArrayLike) -> Array:
    """Cartesian vectors Rᵢ vⁱ = v₁t₁ + v₂t₂ + v₃n of local components v, shape (m, 3)."""
    return np.einsum("iab,ib->ia", R, np.asarray(v, dtype=np.float64))


def rotate_rows(R: Array, B: npt.ArrayLike) -> Array:
    """Bᵢ Rᵢᵀ for 3×3 row blocks Bᵢ acting on local components: the same rows acting on Cartesian ones."""
    return np.einsum("iab,icb->iac", np.asarray(B, dtype=np.float64), R)


def conjugate(R: Array, B: npt.ArrayLike) -> Array:
    """Rᵢ Bᵢ Rᵢᵀ: a 3×3 block acting on local components as the block of the Cartesian map (see the module
    docstring, "In the solver")."""
    return np.einsum("iab,ibc,idc->iad", R, np.asarray(B, dtype=np.float64), R)


def local_shift(R: Array, g: npt.ArrayLike, offset: npt.ArrayLike | None = None) -> Array:
    """The constant part sⁱ = (−t₁·o, −t₂·o, g) of the local block vⁱ = Rᵢᵀũⁱ + sⁱ, shape (m, 3).

    Args:
        R: Frames, shape (m, 3, 3).
        g: Gaps, shape (m,).
        offset: Cartesian tangential offsets o, shape (m, 3) or (3,): δ for a static obstacle moved by δ,
            ũ_{k−1} + δ_k − δ_{k−1} for step k of a load path; default 0.
    """
    s = np.zeros((R.shape[0], 3))
    if offset is not None:
        o = np.broadcast_to(np.asarray(offset, dtype=np.float64), (R.shape[0], 3))
        s[:, :2] = -to_local(R, o)[:, :2]
    s[:, 2] = g
    return s


#: A held Cartesian direction e_h and a contact node's normal n are compatible when |n·e_h| <= this: the
#: round-off of the normals of a geometry symmetric about the held direction's plane (an obstacle centred on a
#: symmetry plane gives exactly 0). A normal tilted further (a tilted plane against a roller) is a conflict.
HELD_NORMAL_TOL = 1e-6
#: The same for the slave nodes of contact pairs, whose normals come from a faceted master surface (or, for
#: mortar, from the slave's facets): a curved surface meshed on one side of a symmetry plane tilts them by about
#: h/(8R) (1.2e-2 at h = R/10); the normal is projected onto the plane (a change of that order in the gap's
#: linearization, below the facetting error itself).
PAIR_HELD_NORMAL_TOL = 0.05


def held_frames(frames: Array, held: npt.ArrayLike, tol: float = HELD_NORMAL_TOL
                ) -> tuple[Array, npt.NDArray[np.bool_]]:
    """The frames of contact nodes with held Cartesian components (see "Contact nodes with held components").

    Args:
        frames: Frames R = (t₁, t₂, n) (columns) of the nodes, shape (m, 3, 3).
        held: Which Cartesian components a Dirichlet condition holds at each node, shape (m, 3) (at most two).
        tol: The largest |n·e_h| of a compatible node (:data:`HELD_NORMAL_TOL`; :data:`PAIR_HELD_NORMAL_TOL` for
            the faceted normals of contact pairs).

    Returns:
        (frames, conflict): the nodes with a held component get n projected onto the complement of the held
        directions and t₁ = the first held axis, t₂ = n × t₁; the others keep their frames bit for bit.
        ``conflict`` marks the nodes with a held direction not orthogonal to n (|n·e_h| > HELD_NORMAL_TOL),
        whose frames are left unchanged.
    """
    held = np.asarray(held, dtype=bool).reshape(-1, 3)
    out = np.array(frames, dtype=np.float64, copy=True)
    conflict = np.zeros(held.shape[0], dtype=bool)
    rows = np.flatnonzero(held.any(axis=1))
    if not rows.size:
        return out, conflict
    n = out[rows, :, 2]
    h = held[rows]
    conflict[rows] = np.any(h & (np.abs(n) > tol), axis=1)
    ok = ~conflict[rows]
    rows, n, h = rows[ok], n[ok], h[ok]
    n = np.where(h, 0.0, n)
    n /= np.linalg.norm(n, axis=1)[:, None]
    t1 = _E[np.argmax(h, axis=1)]  # the first held axis
    out[rows] = frames_from_normals(n, t1)
    return out, conflict


def local_held(held: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """The held LOCAL components (t₁, t₂, n) of nodes whose frames :func:`held_frames` made: the first one or two
    tangents, as many as Cartesian components are held, shape (m, 3)."""
    count = np.asarray(held, dtype=bool).reshape(-1, 3).sum(axis=1)
    return np.stack([count >= 1, count >= 2, np.zeros(count.size, dtype=bool)], axis=1)


# -- frames ---------------------------------------------------------------------------------------------
def _project_normalize(vectors: Array, reference: Array) -> Array:
    """Normalized projections of the rows of ``reference`` onto the planes ⊥ the unit rows of ``vectors``."""
    t = reference - np.einsum("ij,ij->i", reference, vectors)[:, None] * vectors
    return t / np.linalg.norm(t, axis=1)[:, None]


def _perpendicular(vectors: Array, first: int, second: int) -> Array:
    """Unit vectors ⊥ the unit rows of ``vectors``: the projection of e_first, or of e_second when
    |v·e_first| > 1/√2 (the projected vector then always has length >= 1/√2)."""
    use_second = np.abs(vectors[:, first]) > _SWITCH
    reference = np.where(use_second[:, None], _E[second], _E[first])
    return _project_normalize(vectors, reference)


#: |n·e| above this switches the reference axis of the tangent (and of a degenerate cylinder normal).
_SWITCH = 1.0 / math.sqrt(2.0)


_E = np.eye(3)


#: A distance to a sphere's centre or a cylinder's axis below this × the coordinates' size is round-off:
#: its direction is noise, and the node gets the degenerate normal.
_NOISE = 16.0 * np.finfo(np.float64).eps

