"""What a contact model reads once, at construction, and must not change afterwards.

The stiffness A is assembled once (small strain: a load path changes loads, prescribed values and obstacles, never
the bodies), and a friction field is evaluated at the contact nodes once. A user who changes a ``Constant`` or a
``Function`` of the bilinear form (a Young's modulus) or the friction field between solves, as one would with
``dolfinx.fem.petsc.LinearProblem``, which assembles A at every solve, would get the old model's answer without a
word. :class:`FrozenInputs` keeps a digest of their values and refuses the next solve instead.
"""

from __future__ import annotations

import hashlib
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import numpy as np
import ufl

from fenics_coulomb.errors import check_all

__all__ = ["FrozenInputs"]


def _values(item: Any) -> bytes:
    """The bytes of a Constant's value or of a Function's owned DOF values (not the ghosts: a scatter may refresh
    them without a change)."""
    if isinstance(item, dolfinx.fem.Function):
        owned = item.function_space.dofmap.index_map.size_local * item.function_space.dofmap.index_map_bs
        return np.ascontiguousarray(item.x.array[:owned] + 0.0).tobytes()  # + 0.0: −0.0 is 0.0
    return np.ascontiguousarray(np.asarray(item.value) + 0.0).tobytes()


class FrozenInputs:
    """The Constants and Functions of the bilinear form ``a`` and the friction field, with a digest of their values.

    Args:
        a: The bilinear form.
        friction: The friction coefficient: a number (nothing to keep) or a field.
    """

    def __init__(self, a: ufl.Form, friction: object) -> None:
        items: list[tuple[str, Any]] = []
        for k, c in enumerate(a.constants()):
            items.append((f"the bilinear form's Constant {getattr(c, 'name', '') or k + 1}", c))
        for k, f in enumerate(a.coefficients()):
            items.append((f"the bilinear form's Function {getattr(f, 'name', '') or k + 1!r}", f))
        if isinstance(friction, dolfinx.fem.Function | dolfinx.fem.Constant):
            items.append(("the friction field", friction))
        self._items = [(name, item) for name, item in items
                       if isinstance(item, dolfinx.fem.Function | dolfinx.fem.Constant)]
        self._digests = [hashlib.sha256(_values(item)).digest() for _, item in self._items]

    def check(self, comm: MPI.Comm) -> None:
        """InputError on every rank when a kept value changed on some rank since construction (collective)."""
        changed = next((name for (name, item), digest in zip(self._items, self._digests, strict=True)
                        if hashlib.sha256(_values(item)).digest() != digest), "")
        check_all(comm, not changed, f"{changed} changed after the problem was built: the stiffness and the friction "
                  "are read once, at construction (only the loads, the prescribed values and the obstacles change "
                  "between solves); build a new problem for the changed model")
