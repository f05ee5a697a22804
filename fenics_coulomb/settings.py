"""Settings of the SCD semismooth* Newton solver: one dataclass, the single place every knob is defined.

The ``[solver]`` section of a scene file, the command-line flags and :class:`fenics_coulomb.ContactProblem`
all fill this one dataclass (the TOML keys are its field names).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from fenics_coulomb.errors import InputError

__all__ = ["COMMAND_PREFIX", "PRECONDITIONERS", "VARIANTS", "START_RULES", "ERROR_PER_RTOL", "INTEGER_BOUNDS",
           "INTEGER_REASONS", "GAMMA_SCALE_RANGE", "check_fixed_gamma", "rtol_and_accuracy", "rtol_for_accuracy",
           "SolverSettings", "setting_kinds"]

PRECONDITIONERS = ("auto", "ilu", "gamg", "hypre", "lu", "jacobi", "none")
VARIANTS = ("4a", "4b")
#: The starts of a solve given no start that continues no load path (:attr:`SolverSettings.start`).
START_RULES = ("auto", "zero", "undeformed")

#: Bound on the measured ratio (relative displacement error)/rtol over docs/tradeoff (all pc, tol, forcing
#: rules and levels, 2026-11-25, with the start-independent stopping rule): about twice the largest seen, 3.9
#: (ILU, tol 0.5, lev 4 and 6). (Relative to the paper's start the ratio was up to 189.)
ERROR_PER_RTOL = 8.0


#: Upper bounds of the integer settings: beyond them a run only burns time or memory (a user's typo, e.g. 1e8).
INTEGER_BOUNDS = {"max_it": 10_000, "power_iterations": 1_000, "gmres_restart": 1_000, "ksp_max_it": 1_000_000,
                  "line_search_steps": 60}
INTEGER_REASONS = {
    "max_it": "the method converges in 5-83 steps on every measured case (83: the paper's gamma at lev 6)",
    "power_iterations": "the estimate of λ_max(A) settles within a few dozen; each costs a product with A",
    "gmres_restart": "each restart vector is a vector of the mesh's size in memory",
    "ksp_max_it": "a linear solve that needs more has stagnated",
    "line_search_steps": "the 60th step length is 1e-56: below every floating-point step",
}


#: The range of gamma_scale (γ = gamma_scale · λ_max(A)), of gamma_node_scale (γᵢ = κ·λ_max(Aᵢᵢ)) and of a fixed
#: gamma relative to λ_max(A) (:func:`check_fixed_gamma`): beyond it γ dwarfs or vanishes against the stiffness.
GAMMA_SCALE_RANGE = (1e-6, 1e6)


def check_fixed_gamma(gamma: float, lambda_max: float) -> None:
    """InputError unless a fixed ``gamma`` lies within GAMMA_SCALE_RANGE × λ_max(A) (``lambda_max``, the power
    method's estimate: the same on every rank). γ has the stiffness' units, so its range is the stiffness': γ = 1e300
    overflowed the residual's norm, γ = 1e-300 broke the line search down."""
    low, high = (bound * lambda_max for bound in GAMMA_SCALE_RANGE)
    if not low <= gamma <= high:
        raise InputError(f"gamma = {gamma:g}: must lie in [{GAMMA_SCALE_RANGE[0]:g}, {GAMMA_SCALE_RANGE[1]:g}] x "
                         f"lambda_max(A) = [{low:.6g}, {high:.6g}] (the stiffness' largest eigenvalue "
                         f"{lambda_max:.6g}; or leave gamma unset and give gamma_scale)")


def rtol_and_accuracy(rtol: float, accuracy: float) -> str:
    """The message refusing both ``rtol`` and ``accuracy`` (the API's and the scene's)."""
    return (f"rtol = {rtol!r} and accuracy = {accuracy!r}: give one (accuracy sets the residual reduction itself, "
            f"rtol = accuracy/{ERROR_PER_RTOL:g})")


def rtol_for_accuracy(accuracy: float) -> float:
    """The residual reduction of a solve asked for a relative displacement error <= ``accuracy`` (the solver's
    error, not the discretization's): enough for the paper's cuboid in the measured speed–accuracy table
    docs/tradeoff; a pair's residual may leave more (docs/tradeoff/pairs.md), which the Newton correction then
    checks (:mod:`fenics_coulomb.scd.stopping`)."""
    return max(accuracy / ERROR_PER_RTOL, 1e-15)


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{name} = {value!r}: must be a finite number")
    return float(value)


def _setting(default: Any, kind: str, **rule: Any) -> Any:
    """A SolverSettings field whose metadata holds its rule: ``kind`` ("str", "number", "int", "bool"; "?" for
    None allowed), and ``choices`` (with the ``label`` the message names), or ``low``/``high`` with ``bounds`` (the
    interval's brackets, "(" alone for > low) and the message ``text``; the integers' bounds are
    :data:`INTEGER_BOUNDS`."""
    return field(default=default, metadata={"kind": kind, **rule})


def _inside(value: float, low: float | None, high: float | None, bounds: str) -> bool:
    above = low is None or (value > low if bounds[0] == "(" else value >= low)
    below = high is None or len(bounds) < 2 or (value < high if bounds[1] == ")" else value <= high)
    return above and below


def _check(name: str, value: Any, rule: Mapping[str, Any]) -> None:
    """Raise InputError unless ``value`` meets its field's ``rule`` (:func:`_setting`)."""
    kind = rule["kind"]
    if kind.endswith("?") and value is None:
        return
    kind = kind.rstrip("?")
    if "choices" in rule:
        if value not in rule["choices"]:
            raise InputError(f"{rule.get('label', name)} {value!r}: choose one of {list(rule['choices'])}")
    elif kind == "bool":
        if not isinstance(value, bool):
            raise InputError(f"{name} = {value!r}: must be true or false")
    elif kind == "int":
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise InputError(f"{name} = {value!r}: must be an integer >= 1")
        if value > INTEGER_BOUNDS[name]:
            raise InputError(f"{name} = {value!r}: must be at most {INTEGER_BOUNDS[name]} ({INTEGER_REASONS[name]})")
    elif kind == "number":
        number = _number(name, value)
        if not _inside(number, rule.get("low"), rule.get("high"), rule.get("bounds", "[]")):
            raise InputError(f"{name} = {value!r}: {rule['text']}")


#: The options prefix of the command line's solver: every ``-coulomb_*`` PETSc option on the command line and the
#: default ``petsc_options_prefix`` of the scenes' problems (the Python API requires its own).
COMMAND_PREFIX = "coulomb_"
#: The default residual reduction (``accuracy`` may be given only with it).
_RTOL_DEFAULT = 1e-7


@dataclass(frozen=True)
class SolverSettings:
    """Settings of the SCD semismooth* Newton solver and of the problem's solve policy.

    Attributes:
        variant: Newton step "4a" (S*Q, system (5.4)) or "4b" (SQ).
        tol: Relative unpreconditioned GMRES residual that ends each linear solve (paper: 0.1). A
            ``ksp_rtol`` among the problem's PETSc options (or ``-<prefix>ksp_rtol``) replaces it.
        rtol: Stop when ‖ŷ‖ <= rtol·‖ŷ(ũ = 0)‖, the residual of the undeformed body under the solve's loads
            (:mod:`fenics_coulomb.scd.stopping`: the same for every start; the paper divides by ‖ŷ⁽⁰⁾‖ of its start,
            with rtol = 1e-12). The default 1e-7 keeps the Newton steps of the earlier default (1e-8 relative to
            the paper's start) on the cuboid at lev 8 and 10, where that asked for 5e-7 and 1e-6 relative to
            ‖ŷ(ũ = 0)‖, and is stricter than it at every coarser level and far below the discretization error
            (docs/tradeoff).
        accuracy: A relative displacement error (2-norm, the solver's error) to reach instead of ``rtol``: the
            residual rule at :func:`rtol_for_accuracy`, and the last Newton correction — the error of the iterate
            it corrects — at most ``accuracy``·‖u‖ (:mod:`fenics_coulomb.scd.stopping`); None uses ``rtol``.
        max_it: Newton iterations before giving up.
        pc: Preconditioner: auto (ilu below :data:`~fenics_coulomb.scd.preconditioner.AUTO_GAMG_UNKNOWNS`
            unknowns, gamg from there on), ilu (block-Jacobi/ILU(0) in parallel, the paper's), gamg (aggregation
            AMG on the stiffness matrix A with the rigid-body near-nullspace, unsmoothed on hexahedral meshes, set up
            once and reused by every Newton step), hypre, lu, jacobi, none.
        power_iterations: Power-method iterations on A for γ (paper: 5).
        gamma: Fixed γ instead of the power-method estimate.
        gamma_scale: Factor on the power-method estimate of λ_max(A). The paper uses γ ≈ λ_max(A)
            (factor 1); the default 0.01 is measured to need far fewer Newton iterations and to keep them
            nearly level-independent (docs/table2: 14–18 iterations for lev 4–7 against 20–82), while 0.001
            is too small (some cases stall).
        gamma_node_scale: κ of the per-node γᵢ = min(γ, κ·λ_max(Aᵢᵢ)) of the contact nodes (Aᵢᵢ the node's 3×3
            diagonal block of A; :mod:`fenics_coulomb.scd.node_gamma`): on a graded or distorted mesh γ
            from λ_max(A) far exceeds the stiffness at the contact and GMRES stagnates; None (API) keeps γ on every
            node. A fixed ``gamma`` is used on every node as given.
        gmres_restart: GMRES restart length.
        ksp_max_it: Maximal Krylov iterations per Newton step.
        line_search_steps: Number of step lengths tried before the line search fails.
        adaptive_tol: Safeguarded Eisenstat–Walker forcing terms η_k <= tol instead of the fixed tol.
        predictor: First solve the linear problem; if it does not reach the obstacle it is the solution.
        no_contact_shortcut: Without contact nodes, solve the linear problem once instead of Newton.
        matrix_free: Apply the Newton matrix as D(A x) + C x (a PETSc shell, no second copy of A) when the
            preconditioner does not read it (gamg, none); false stores the explicit copy always.
        start: The start ũ⁽⁰⁾ of a solve given none that is not a later step of a load path (which starts from the
            previous step's solution): "zero" (the paper's u⁽⁰⁾ = 0 of the shifted unknown, ũ = −d: every contact
            node on its obstacle), "undeformed" (ũ = 0), or "auto" (the default): "zero" when the residual
            ŷ(ũ = 0) of the undeformed body lies mostly in the free rows (loads or prescribed displacements drive
            the body onto its obstacles), "undeformed" when it lies mostly in the contact rows (obstacles overlap
            the body at rest); the rule and its measurements:
            :meth:`fenics_coulomb.problem.ContactProblem.start_rule`.
        poisson_ratio: The body's largest Poisson ratio, when known (scenes set it from their materials; the
            solver never sees a material otherwise): from 0.48 on (nearly incompressible) ``auto`` takes GAMG with
            smoothed aggregation on every mesh
            (:data:`~fenics_coulomb.scd.preconditioner.NEARLY_INCOMPRESSIBLE_POISSON`).
    """

    variant: str = _setting("4a", "str", choices=VARIANTS)
    tol: float = _setting(0.1, "number", low=0.0, high=1.0, bounds="()",
                          text="the linear-solve tolerance must lie in (0, 1)")
    rtol: float = _setting(_RTOL_DEFAULT, "number", low=0.0, high=1.0, bounds="()",
                           text="the residual reduction must lie in (0, 1)")
    accuracy: float | None = _setting(None, "number?", low=1e-13, high=1.0, bounds="[)",
                                      text="a relative displacement error in [1e-13, 1)")
    max_it: int = _setting(100, "int")
    pc: str = _setting("auto", "str", choices=PRECONDITIONERS, label="preconditioner")
    power_iterations: int = _setting(5, "int")
    gamma: float | None = _setting(None, "number?", low=0.0, bounds="(", text="must be finite and > 0")
    gamma_scale: float = _setting(0.01, "number", low=GAMMA_SCALE_RANGE[0], high=GAMMA_SCALE_RANGE[1], bounds="[]",
                                  text=f"must lie in [{GAMMA_SCALE_RANGE[0]:g}, {GAMMA_SCALE_RANGE[1]:g}]")
    gamma_node_scale: float | None = _setting(0.5, "number?", low=GAMMA_SCALE_RANGE[0], high=GAMMA_SCALE_RANGE[1],
                                              bounds="[]", text=f"must lie in [{GAMMA_SCALE_RANGE[0]:g}, "
                                              f"{GAMMA_SCALE_RANGE[1]:g}] (or none)")
    gmres_restart: int = _setting(100, "int")
    ksp_max_it: int = _setting(2000, "int")
    line_search_steps: int = _setting(20, "int")
    adaptive_tol: bool = _setting(False, "bool")
    predictor: bool = _setting(False, "bool")
    no_contact_shortcut: bool = _setting(True, "bool")
    matrix_free: bool = _setting(True, "bool")
    start: str = _setting("auto", "str", choices=START_RULES, label="start")
    poisson_ratio: float | None = _setting(None, "number?", low=-1.0, high=0.5, bounds="()",
                                           text="must lie in (-1, 0.5)")

    def __post_init__(self) -> None:
        for f in fields(self):  # NumPy scalars as the Python values they stand for (np.int64(5) is an integer)
            value = getattr(self, f.name)
            if isinstance(value, np.generic):
                object.__setattr__(self, f.name, value.item())
        self.validate()

    @property
    def reduction(self) -> float:
        """The residual reduction in force: ``rtol``, or the one that meets ``accuracy``."""
        return self.rtol if self.accuracy is None else rtol_for_accuracy(self.accuracy)

    def validate(self) -> None:
        """Raise InputError naming the first bad value (pure: the same on every rank). Each field's rule is its
        metadata (:func:`_setting`); run on construction, so that a SolverSettings is valid wherever it is made
        (the API's, a scene's ``[solver]`` and the flags')."""
        for f in fields(self):
            _check(f.name, getattr(self, f.name), f.metadata)
        if self.accuracy is not None and self.rtol != _RTOL_DEFAULT:
            raise InputError(rtol_and_accuracy(self.rtol, self.accuracy))
        if self.variant == "4b" and self.pc == "hypre":
            raise InputError("preconditioner 'hypre' cannot apply its transpose, which variant 4b needs")


def setting_kinds() -> dict[str, str]:
    """The TOML kind of every ``[solver]`` key, from the fields of :class:`SolverSettings` (the scene's table)."""
    return {f.name: f.metadata["kind"].rstrip("?") for f in fields(SolverSettings)}
