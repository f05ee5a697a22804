"""The names :mod:`fenics_coulomb.model.surface` imports from the projection of the pair package
(:mod:`fenics_coulomb.model.pairs.projection`); the pairs themselves are :mod:`fenics_coulomb.model.pairs`."""

from fenics_coulomb.model.pairs.projection import Surface as _Surface
from fenics_coulomb.model.pairs.projection import norm as _norm
from fenics_coulomb.model.pairs.projection import project as _pair_nodes

__all__ = ["_Surface", "_norm", "_pair_nodes"]
