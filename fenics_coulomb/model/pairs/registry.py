"""The registry of pair methods: each discretization of a contact pair is a module with one function
``stencils(PairInput) -> Stencils`` (:mod:`fenics_coulomb.model.pairs.stencils`), registered here by name.

A new method is its module and one :func:`register_pair_method` line; :class:`~fenics_coulomb.model.pairs.pair.
ContactPair` and the scene's ``[[contact_pair]] method`` accept exactly the registered names::

    register_pair_method("node-to-surface", node_to_surface.stencils)
"""

from __future__ import annotations

from collections.abc import Callable

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs import mortar, node_to_surface
from fenics_coulomb.model.pairs.stencils import PairInput, Stencils

__all__ = ["PairMethod", "register_pair_method", "unregister_pair_method", "pair_method", "pair_methods",
           "check_method"]

#: A pair method: the stencils of one pair's candidate slave nodes.
PairMethod = Callable[[PairInput], Stencils]

_METHODS: dict[str, PairMethod] = {}


def register_pair_method(name: str, method: PairMethod) -> None:
    """Register ``method`` under ``name`` (InputError for a name taken or not a non-empty string, or a method that
    is not callable)."""
    if not isinstance(name, str) or not name:
        raise InputError(f"pair method name {name!r}: must be a non-empty string")
    if not callable(method):
        raise InputError(f"pair method {name!r}: {method!r} is not callable (a function of PairInput -> Stencils)")
    if name in _METHODS:
        raise InputError(f"pair method {name!r}: already registered")
    _METHODS[name] = method


def unregister_pair_method(name: str) -> None:
    """Remove the method ``name`` from the registry (InputError if it is not registered)."""
    check_method(name, "pair methods")
    del _METHODS[name]


def pair_methods() -> tuple[str, ...]:
    """The registered method names, in the order of registration."""
    return tuple(_METHODS)


def check_method(method: object, owner: str) -> None:
    """InputError naming ``method`` unless it is a registered name (``owner`` names the pair or the section)."""
    if not isinstance(method, str) or method not in _METHODS:
        raise InputError(f"{owner}: method = {method!r}: must be one of {', '.join(map(repr, _METHODS))}")


def pair_method(name: str) -> PairMethod:
    """The function registered under ``name``."""
    check_method(name, "contact pair")
    return _METHODS[name]


register_pair_method("mortar", mortar.stencils)
register_pair_method("node-to-surface", node_to_surface.stencils)
