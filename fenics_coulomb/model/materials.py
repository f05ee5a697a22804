"""Isotropic linear elasticity in UFL: the material the scenes and the command line use.

The solver does not depend on it: :class:`fenics_coulomb.ContactProblem` takes any bilinear form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl

from fenics_coulomb.errors import InputError

__all__ = ["Material", "epsilon", "sigma"]


@dataclass(frozen=True)
class Material:
    """Isotropic linear elasticity (units: GPa)."""

    young: float = 70.0
    poisson: float = 0.334

    def validate(self) -> None:
        """Raise InputError for non-physical values (E must be > 0 and finite, ν in (−1, 0.5))."""
        if not (np.isfinite(self.young) and self.young > 0.0):
            raise InputError(f"Young's modulus E = {self.young!r} GPa: must be finite and > 0")
        if not (np.isfinite(self.poisson) and -1.0 < self.poisson < 0.5):
            raise InputError(f"Poisson ratio nu = {self.poisson!r}: must lie in (-1, 0.5)")

    @property
    def lame(self) -> tuple[float, float]:
        """Lamé parameters (μ, λ)."""
        E, nu = self.young, self.poisson
        return E / (2.0 * (1.0 + nu)), E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))


def epsilon(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Small-strain tensor."""
    return ufl.sym(ufl.grad(u))


def sigma(
    u: ufl.core.expr.Expr, mu: float | ufl.core.expr.Expr, lmbda: float | ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """Cauchy stress of isotropic linear elasticity (the Lamé operator in weak form)."""
    return 2.0 * mu * epsilon(u) + lmbda * ufl.tr(epsilon(u)) * ufl.Identity(len(u))
