"""The rigid obstacle a body may touch.

Today one obstacle: the half-space x3 ≤ 0 (:class:`Plane` with its defaults), whose outer normal is e3, so
a contact node's normal component is u3, its tangential components are (u1, u2) and its initial gap is its
height. The contact map asks the obstacle only for the gaps of the contact nodes; per-node frames (other
normals, spheres, cylinders) are the next step and would add a frame per node here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError


@dataclass(frozen=True)
class Plane:
    """The rigid half-space {x : (x − point)·normal ≤ 0}; only normal = e3 is supported so far.

    Attributes:
        point: A point of the plane.
        normal: Unit normal pointing from the obstacle toward the body.
    """

    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def validate(self) -> None:
        """Raise InputError for an obstacle the contact model cannot represent."""
        p = np.asarray(self.point, dtype=np.float64)
        n = np.asarray(self.normal, dtype=np.float64)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InputError(f"obstacle point {self.point!r}: must be 3 finite numbers")
        if n.shape != (3,) or not np.allclose(n / max(np.linalg.norm(n), 1e-300), (0.0, 0.0, 1.0), atol=1e-14):
            raise InputError(f"obstacle normal {self.normal!r}: only the plane's normal (0, 0, 1) is supported")

    def gap(self, x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Signed distance of the points ``x`` (shape (m, 3)) from the plane (> 0 outside the obstacle)."""
        return np.ascontiguousarray(x[:, 2] - self.point[2])
