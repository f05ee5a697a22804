r"""Rigid obstacles of any placement and shape — planes, spheres, cylinders — and per-node contact frames.

Geometry (issue 13)
-------------------
Each obstacle is placed at its scene position translated by its ``displacement`` δ (default 0):

* :class:`Plane` (``point`` p, unit ``normal`` ν pointing from the obstacle toward the body): the obstacle
  is {x : (x − p − δ)·ν ≤ 0}; g = (x − p − δ)·ν, n = ν.
* :class:`Sphere` (``center`` c, ``radius`` R, the solid ball): g = ‖x − c − δ‖ − R,
  n = (x − c − δ)/‖x − c − δ‖.
* :class:`Cylinder` (``point`` p, unit ``axis`` a, ``radius`` R, the infinite solid cylinder): with
  d = x − p − δ and its radial part ρ = d − (d·a)a, g = ‖ρ‖ − R, n = ρ/‖ρ‖.

g is the signed distance from a contact node's REFERENCE position x to the placed surface (> 0 outside)
and n the outward unit normal at the closest point x − g·n. With several obstacles a node belongs to the one
with the smallest g (ties: the first). Given normals and axes are normalized; zero or non-finite vectors and
radii R <= 0 are rejected (:class:`~fenics_coulomb.errors.InputError`).

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
Notation. The contact mapping Q̃ of :mod:`fenics_coulomb.resolvent` acts on local blocks v = (v₁₂, v₃) —
tangential first, normal last (the paper's block order; today's frame is the identity: v₁₂ = (u₁, u₂),
v₃ = u₃ + α). For contact node i with frame Rᵢ = (t₁, t₂, n), gap gᵢ and tangential offset oᵢ (a Cartesian
vector) the local kinematics are

    vⁱ = Rᵢᵀ ũⁱ + sⁱ,   sⁱ = (−t₁·oᵢ, −t₂·oᵢ, gᵢ)            (:func:`local_shift`)

so v₃ = g + n·ũ (the linearized gap) and v₁₂ = T(ũ − oᵢ) with T = (t₁; t₂). Static obstacle problem: oᵢ = δ
(the slip s = T(u − δ) of a body dragged by a moving obstacle); load path step k (issue 14): oᵢ = ũ_{k−1} +
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
:mod:`fenics_coulomb.model`. The residuals are r̂ = Â û − l̂ = 𝓡ᵀ(A u − l) = 𝓡ᵀ r, and since 𝓡 is
orthogonal, norms (‖ŷ‖, the line search, the stopping rule, γ's power method) are frame independent.

Approximation step (6.17). d̂ = (γI + Q̃)⁻¹(γ û − r̂) node-wise, i.e. on contact node i

    (vⁱ, zⁱ) = resolvent(Rᵢᵀ(γ uⁱ − rⁱ)),   eⁱ = uⁱ − Rᵢ vⁱ (Cartesian), êⁱ = Rᵢᵀ eⁱ = ûⁱ − vⁱ (local),

and e = r/γ elsewhere (:func:`frame_approximation`). The resolvent, the sets (6.9) and the S*Q̃/SQ̃ blocks
are evaluated unchanged at the LOCAL graph point (vⁱ, zⁱ). Equivalently, the Cartesian contact map
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

In the solver (:mod:`fenics_coulomb.newton`) the contact rows are in addition multiplied from the left by
Rᵢ — an orthogonal change of the node's three equations, so Δu and every residual norm stay the same — so the
blocks become Rᵢ Bⁱ Rᵢᵀ and Rᵢ Cⁱ Rᵢᵀ (:func:`conjugate`): the Cartesian blocks of the rotated SCD
subspaces (rge(Rᵢ X, Rᵢ Y) = rge(Rᵢ X Rᵢᵀ, Rᵢ Y Rᵢᵀ)). Then the steps of :mod:`fenics_coulomb.steps` run
unchanged on the Cartesian e (4a: right-hand side −(B γe + C e) with the conjugated blocks = Rᵢ times the one
above; 4b: Mᵀ with M = 𝓡 M̂ 𝓡ᵀ is solved for the Cartesian q = 𝓡 q̂, and Δuⁱ = (Rᵢ Bⁱ Rᵢᵀ)ᵀ pⁱ − eⁱ). Row
rotation alone (Bⁱ Rᵢᵀ) would be as correct but leaves zero diagonal entries where the frame permutes the
axes (a cylinder's t₁ = a = e₂), on which ILU(0) breaks down.

Outputs: the contact force on the body is −Rᵢ zⁱ (Cartesian), its normal part λ = −z₃ ≥ 0, the tangential
force −Rᵢ (z₁, z₂, 0) (a true 3-vector), the gap v₃ = g + n·ũ ≥ 0, the slip v₁₂.

``tests/test_obstacles.py`` checks this numerically: the Cartesian formulas above against the paper's
iteration on the explicitly rotated problem (Â, l̂) for random frames and shifts (the Newton directions of
4a and 4b), the rotated S*Q/SQ blocks against finite differences of the Cartesian resolvent, and the whole
iteration against an independent Alart–Curnier solver (``tests/brute_force.py``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.resolvent import resolvent

Array = npt.NDArray[np.float64]
Vector = tuple[float, float, float]

#: |n·e| above this switches the reference axis of the tangent (and of a degenerate cylinder normal).
_SWITCH = 1.0 / math.sqrt(2.0)
_E = np.eye(3)
#: A distance to a sphere's centre or a cylinder's axis below this × the coordinates' size is round-off:
#: its direction is noise, and the node gets the degenerate normal.
_NOISE = 16.0 * np.finfo(np.float64).eps


# -- validation helpers --------------------------------------------------------------------------------
def _label(name: str | None, kind: str) -> str:
    return f"{kind} {name!r}" if name else kind


def _vector(value: Any, key: str, owner: str) -> Vector:
    """Three finite numbers as a tuple of floats (bool is not a number)."""
    ok = isinstance(value, (list, tuple, np.ndarray)) and len(value) == 3
    if ok:
        ok = all(isinstance(c, (int, float, np.integer, np.floating)) and not isinstance(c, (bool, np.bool_))
                 for c in value)
    if ok:
        vec = tuple(float(c) for c in value)
        if all(math.isfinite(c) for c in vec):
            return vec  # type: ignore[return-value]
    raise InputError(f"{owner}: {key} = {_show(value)}: must be 3 finite numbers")


def _unit(value: Any, key: str, owner: str) -> Vector:
    """A finite non-zero 3-vector, normalized (scaled first, so tiny vectors do not underflow)."""
    given = _vector(value, key, owner)
    vec = np.asarray(given)
    if abs(float(np.linalg.norm(vec)) - 1.0) <= 4.0 * np.finfo(np.float64).eps:
        return given  # already a unit vector: keep it bit for bit (normalizing is idempotent)
    big = float(np.max(np.abs(vec)))
    if big == 0.0:
        raise InputError(f"{owner}: {key} = {_show(value)}: a zero vector has no direction")
    vec = vec / big
    vec = vec / np.linalg.norm(vec)
    return tuple(float(c) for c in vec)  # type: ignore[return-value]


def _radius(value: Any, owner: str) -> float:
    if (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
            and math.isfinite(float(value)) and float(value) > 0.0):
        return float(value)
    raise InputError(f"{owner}: radius = {_show(value)}: must be a finite number > 0")


def _show(value: Any) -> str:
    """A value as the user wrote it, on one line."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    text = repr(value).replace("\n", " ")
    return text if len(text) <= 80 else text[:77] + "..."


def _points(x: npt.ArrayLike) -> Array:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"node positions must have shape (m, 3), got {x.shape}")
    return x


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


def frame_approximation(
    u: Array, r: Array, R: Array, gamma: float, friction: float | Array
) -> tuple[Array, Array, Array]:
    """The approximation step (6.17) on contact nodes in their frames (see the module docstring).

    Args:
        u: Shifted Cartesian unknowns uⁱ = ũⁱ + Rᵢsⁱ of the contact nodes, shape (m, 3).
        r: Cartesian residual blocks rⁱ = (A u − l)ⁱ, shape (m, 3).
        R: Frames, shape (m, 3, 3).
        gamma: γ > 0.
        friction: Coulomb coefficient F (a scalar, or per node, shape (m,)).

    Returns:
        (e, v, z): the Cartesian eⁱ = uⁱ − Rᵢvⁱ and the local graph point (vⁱ, zⁱ) ∈ gph Q̃.
    """
    w = to_local(R, gamma * u - r)
    F = np.asarray(friction, dtype=np.float64)
    if F.ndim == 0:
        v, z = resolvent(w, gamma, float(F))
    else:  # per-node friction: the resolvent is node-wise, so group the nodes by their coefficient
        v, z = np.empty_like(w), np.empty_like(w)
        for value in np.unique(F):
            sel = F == value
            v[sel], z[sel] = resolvent(w[sel], gamma, float(value))
    return u - to_global(R, v), v, z


# -- obstacles ------------------------------------------------------------------------------------------
#: How each geometry key is checked (and normalized).
_CHECKS = {
    "point": lambda value, owner: _vector(value, "point", owner),
    "center": lambda value, owner: _vector(value, "center", owner),
    "normal": lambda value, owner: _unit(value, "normal", owner),
    "axis": lambda value, owner: _unit(value, "axis", owner),
    "radius": lambda value, owner: _radius(value, owner),
    "displacement": lambda value, owner: _vector(value, "displacement", owner),
}


@dataclass(frozen=True)
class Obstacle:
    """Base of the rigid obstacles: the geometry of the subclass, a rigid translation δ and a name.

    Subclasses are frozen dataclasses whose fields are checked (and normals/axes normalized) on creation.
    """

    kind: ClassVar[str] = ""
    #: The geometry keys (fields and scene-table keys) besides ``displacement`` and ``name``.
    keys: ClassVar[tuple[str, ...]] = ()
    #: The key of the scene position that δ translates.
    position_key: ClassVar[str] = "point"

    def __post_init__(self) -> None:
        name = getattr(self, "name", None)
        owner = _label(name, self.kind)
        _check_name(name, owner)
        for key in (*self.keys, "displacement"):
            object.__setattr__(self, key, _CHECKS[key](getattr(self, key), owner))

    @property
    def label(self) -> str:
        """How messages name the obstacle, e.g. "sphere 'indenter'" or "plane"."""
        return _label(getattr(self, "name", None), self.kind)

    @property
    def placed(self) -> Vector:
        """The placed position (plane/cylinder point, sphere centre) = scene position + δ."""
        fields = vars(self)
        position, displacement = fields[self.position_key], fields["displacement"]
        return tuple(float(a + b) for a, b in zip(position, displacement, strict=True))  # type: ignore[return-value]

    def at_scene_position(self) -> Obstacle:
        """The same obstacle with δ = 0."""
        return dataclasses.replace(self, displacement=(0.0, 0.0, 0.0))  # type: ignore[call-arg]

    def moved(self, displacement: npt.ArrayLike) -> Obstacle:
        """The same obstacle with its displacement δ replaced."""
        value = np.asarray(displacement, dtype=np.float64).tolist()
        return dataclasses.replace(self, displacement=value)  # type: ignore[call-arg]

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        raise NotImplementedError

    def _tangent(self, n: Array) -> Array:
        return _perpendicular(n, 0, 1)

    def signed_distance(self, x: npt.ArrayLike) -> Array:
        """g of each REFERENCE position x (m, 3), shape (m,): signed distance to the placed surface, > 0 outside."""
        return self._gap_normal(_points(x))[0]

    def normals(self, x: npt.ArrayLike) -> Array:
        """n of each position, shape (m, 3): the outward unit normal at the closest surface point."""
        return self._gap_normal(_points(x))[1]

    def frames(self, x: npt.ArrayLike) -> Array:
        """The frames R = (t₁, t₂, n) (columns) of each position, shape (m, 3, 3)."""
        return self.evaluate(x)[2]

    def evaluate(self, x: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """(g, n, R) of each position: shapes (m,), (m, 3), (m, 3, 3); R = (t₁, t₂, n) as columns."""
        g, n = self._gap_normal(_points(x))
        return g, n, frames_from_normals(n, self._tangent(n))

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        """Points deep inside the placed obstacle that must never lie inside the body, shape (k, 3): the sphere's
        centre, the cylinder's axis across the box [lo, hi] (``samples`` points); none for a plane (a half-space
        has no core a body could swallow). An obstacle whose core is inside the body is buried in it, or has been
        moved through it (:func:`core_path`)."""
        return np.zeros((0, 3))

    def closest_point(self, x: npt.ArrayLike) -> Array:
        """The closest point x − g·n on the placed surface, shape (m, 3)."""
        x = _points(x)
        g, n = self._gap_normal(x)
        return x - g[:, None] * n


@dataclass(frozen=True)
class Plane(Obstacle):
    """The half-space {x : (x − p − δ)·ν <= 0}; ν (normalized) points from the obstacle toward the body.

    The defaults are the paper's obstacle, the half-space x3 <= 0 (p = 0, ν = e3)."""

    point: Vector = (0.0, 0.0, 0.0)
    normal: Vector = (0.0, 0.0, 1.0)
    displacement: Vector = (0.0, 0.0, 0.0)
    name: str | None = None

    kind: ClassVar[str] = "plane"
    keys: ClassVar[tuple[str, ...]] = ("point", "normal")

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        nu = np.asarray(self.normal)
        g = (x - np.asarray(self.placed)) @ nu
        return g, np.broadcast_to(nu, x.shape).copy()


@dataclass(frozen=True)
class Sphere(Obstacle):
    """The solid ball ‖x − c − δ‖ <= R."""

    center: Vector
    radius: float
    displacement: Vector = (0.0, 0.0, 0.0)
    name: str | None = None

    kind: ClassVar[str] = "sphere"
    keys: ClassVar[tuple[str, ...]] = ("center", "radius")
    position_key: ClassVar[str] = "center"

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        return np.asarray(self.placed, dtype=np.float64)[None, :]

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        c = np.asarray(self.placed)
        d = x - c
        dist = np.linalg.norm(d, axis=1)
        n = np.empty_like(d)
        centre = dist <= _NOISE * (np.linalg.norm(x, axis=1) + np.linalg.norm(c))
        n[~centre] = d[~centre] / dist[~centre, None]
        n[centre] = _E[2]
        return dist - self.radius, n


@dataclass(frozen=True)
class Cylinder(Obstacle):
    """The infinite solid cylinder of radius R around the line p + δ + s·a (a normalized)."""

    point: Vector
    axis: Vector
    radius: float
    displacement: Vector = (0.0, 0.0, 0.0)
    name: str | None = None

    kind: ClassVar[str] = "cylinder"
    keys: ClassVar[tuple[str, ...]] = ("point", "axis", "radius")

    def _gap_normal(self, x: Array) -> tuple[Array, Array]:
        a = np.asarray(self.axis)
        d = x - np.asarray(self.placed)
        radial = d - (d @ a)[:, None] * a
        dist = np.linalg.norm(radial, axis=1)
        n = np.empty_like(d)
        on_axis = dist <= _NOISE * (np.linalg.norm(x, axis=1) + np.linalg.norm(np.asarray(self.placed)))
        n[~on_axis] = radial[~on_axis] / dist[~on_axis, None]
        n[on_axis] = _perpendicular(a[None, :], 2, 0)[0]
        return dist - self.radius, n

    def _tangent(self, n: Array) -> Array:
        return np.broadcast_to(np.asarray(self.axis), n.shape).copy()

    def core(self, lo: Array, hi: Array, samples: int) -> Array:
        p, a = np.asarray(self.placed, dtype=np.float64), np.asarray(self.axis)
        centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
        s0 = float((centre - p) @ a)  # the axis parameter nearest the box's centre
        return p + (s0 + np.linspace(-radius, radius, max(samples, 2)))[:, None] * a


def _check_name(name: Any, owner: str) -> None:
    if name is not None and (not isinstance(name, str) or not name):
        raise InputError(f"{owner}: name = {_show(name)}: must be a non-empty string")


#: The paper's obstacle, used when a scene gives none: the plane x3 = 0 with normal e₃ (frame = identity).
DEFAULT_PLANE = Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))

OBSTACLE_TYPES: dict[str, type[Obstacle]] = {"plane": Plane, "sphere": Sphere, "cylinder": Cylinder}


# -- several obstacles ---------------------------------------------------------------------------------
def closest_obstacle(obstacles: Sequence[Obstacle], x: npt.ArrayLike) -> tuple[npt.NDArray[np.intp], Array,
                                                                               Array, Array]:
    """Assign each node to the obstacle with the smallest g (ties: the first in ``obstacles``).

    Args:
        obstacles: At least one obstacle (placed at their displacements).
        x: REFERENCE node positions, shape (m, 3).

    Returns:
        (index, g, n, R): the obstacle index per node and that obstacle's g, n and frame R.
    """
    if not obstacles:
        raise ValueError("closest_obstacle needs at least one obstacle (DEFAULT_PLANE for the paper's)")
    x = _points(x)
    results = [o.evaluate(x) for o in obstacles]
    gaps = np.stack([r[0] for r in results])  # (k, m)
    index = np.argmin(gaps, axis=0)  # first minimum on ties
    nodes = np.arange(x.shape[0])
    g = gaps[index, nodes]
    n = np.stack([r[1] for r in results])[index, nodes]
    R = np.stack([r[2] for r in results])[index, nodes]
    return index, g, n, R


def find_overlap(obstacles: Sequence[Obstacle], x: npt.ArrayLike, tol: float) -> tuple[float, str] | None:
    """The deepest overlap of the body's nodes x with the obstacles at their SCENE positions (δ = 0).

    Returns None, or (depth, message) for the deepest node with g < −tol over all obstacles (the first
    obstacle on ties), the message naming the obstacle, the node's coordinates and its depth.
    """
    x = _points(x)
    worst: tuple[float, str] | None = None
    for k, obstacle in enumerate(obstacles):
        g = obstacle.at_scene_position().signed_distance(x)
        if g.size == 0:
            continue
        i = int(np.argmin(g))
        depth = -float(g[i])
        if depth > tol and (worst is None or depth > worst[0]):
            where = ", ".join(f"{c:.6g}" for c in x[i])
            worst = (depth, f"obstacle {k + 1} ({obstacle.label}) overlaps the body at its scene position: "
                            f"node ({where}) lies {depth:.6g} inside it (move the body or the obstacle; "
                            "only its displacement may push into the body)")
    return worst


def check_not_overlapping(obstacles: Sequence[Obstacle], x: npt.ArrayLike, tol: float | None = None,
                          comm: Any = None) -> None:
    """Raise InputError if an obstacle at its scene position (δ = 0) overlaps the body (g < −tol).

    The obstacles' displacements are ignored (an overlap caused by δ is an indentation, valid input).

    Args:
        obstacles: The scene's obstacles.
        x: This rank's contact-node REFERENCE positions, shape (m, 3).
        tol: Tolerated depth (round-off of mesh generators); default 1e-12 × the largest |coordinate|
            (global when ``comm`` is given).
        comm: An MPI communicator: then collective, and every rank raises the same message, that of the
            deepest node over all ranks.
    """
    x = _points(x)
    if tol is None:
        size = float(np.abs(x).max(initial=0.0))
        if comm is not None:
            size = comm.allreduce(size, op=_mpi_max())
        tol = 1e-12 * size
    worst = find_overlap(obstacles, x, tol)
    if comm is not None:
        everyone = [w for w in comm.allgather(worst) if w is not None]
        worst = max(everyone, key=lambda w: w[0]) if everyone else None
    if worst is not None:
        raise InputError(worst[1])


def core_path(obstacle: Obstacle, start: npt.ArrayLike, end: npt.ArrayLike, lo: Array, hi: Array,
              spacing: float, limit: int = 20_000) -> Array:
    """The cores (:meth:`Obstacle.core`) of ``obstacle`` along its straight motion from displacement ``start`` to
    ``end``, sampled every ``spacing`` (at most about ``limit`` points), shape (k, 3)."""
    start, end = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    axis_samples = max(2, min(int(np.ceil(np.linalg.norm(hi - lo) / spacing)) + 1, 200))
    steps = max(1, min(int(np.ceil(np.linalg.norm(end - start) / spacing)), max(1, limit // axis_samples)))
    points = [obstacle.moved(start + t * (end - start)).core(lo, hi, axis_samples)
              for t in np.linspace(0.0, 1.0, steps + 1)]
    return np.concatenate(points) if points else np.zeros((0, 3))


def _mpi_max() -> Any:
    from mpi4py import MPI

    return MPI.MAX


# -- scenes ---------------------------------------------------------------------------------------------
def obstacle_from_dict(table: Mapping[str, Any], index: int | None = None) -> Obstacle:
    """An obstacle from a scene's ``[[obstacle]]`` table (TOML), every key type-checked.

    Keys: ``type`` (plane | sphere | cylinder), ``name`` (optional), ``displacement`` (optional, default
    [0, 0, 0]) and the type's own: plane ``point``, ``normal``; sphere ``center``, ``radius``; cylinder
    ``point``, ``axis``, ``radius``.

    Args:
        table: The parsed table.
        index: 1-based position in the scene, used in messages.

    Raises:
        InputError: One line naming the obstacle and the bad key or value.
    """
    where = "[[obstacle]]" if index is None else f"[[obstacle]] {index}"
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: must be a table, got {_show(table)}")
    name = table.get("name")
    if name is not None and (not isinstance(name, str) or not name):
        raise InputError(f"{where}: name = {_show(name)}: must be a non-empty string")
    if name:
        where = f"{where} ({name!r})"
    if "type" not in table:
        raise InputError(f"{where}: missing type (choose one of {sorted(OBSTACLE_TYPES)})")
    kind = table["type"]
    if not isinstance(kind, str) or kind not in OBSTACLE_TYPES:
        raise InputError(f"{where}: type = {_show(kind)}: choose one of {sorted(OBSTACLE_TYPES)}")
    cls = OBSTACLE_TYPES[kind]
    allowed = ("type", "name", "displacement", *cls.keys)
    for key in table:
        if key not in allowed:
            raise InputError(f"{where}: unknown key {key!r} for a {kind} (allowed: {', '.join(allowed)})")
    for key in cls.keys:
        if key not in table:
            raise InputError(f"{where}: a {kind} needs {key}")
    args = {key: _CHECKS[key](table[key], where) for key in cls.keys}
    displacement = _CHECKS["displacement"](table.get("displacement", [0.0, 0.0, 0.0]), where)
    return cls(**args, displacement=displacement, name=name)


def obstacles_from_list(tables: Iterable[Mapping[str, Any]]) -> list[Obstacle]:
    """The obstacles of a scene's ``[[obstacle]]`` array; names must be unique (load paths move them by name)."""
    if isinstance(tables, Mapping) or isinstance(tables, (str, bytes)):
        raise InputError(f"obstacle = {_show(tables)}: must be an array of tables ([[obstacle]])")
    obstacles = [obstacle_from_dict(t, i + 1) for i, t in enumerate(tables)]
    seen: set[str] = set()
    for i, o in enumerate(obstacles):
        name = getattr(o, "name", None)
        if name is not None:
            if name in seen:
                raise InputError(f"[[obstacle]] {i + 1}: name {name!r} is used by an earlier obstacle")
            seen.add(name)
    return obstacles
