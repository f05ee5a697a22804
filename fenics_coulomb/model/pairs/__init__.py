"""Two elastic bodies in contact: contact pairs, their discretizations and the coupling u = (I + Φ) z.

Modules (each one concept):

* :mod:`~fenics_coulomb.model.pairs.pair` — :class:`ContactPair` (slave and master surfaces, friction, search
  distance, method) and :class:`Pairing` (the stencils, gaps and frames of the owned contact nodes);
* :mod:`~fenics_coulomb.model.pairs.projection` — the closest point of a P1/Q1 surface, its normal and normal cone;
* :mod:`~fenics_coulomb.model.pairs.stencils` and :mod:`~fenics_coulomb.model.pairs.registry` — the interface of a
  pair method and the registry of the methods by name;
* :mod:`~fenics_coulomb.model.pairs.node_to_surface` and :mod:`~fenics_coulomb.model.pairs.mortar` — the two
  methods (dual mortar's segmentation and integration: :mod:`~fenics_coulomb.model.pairs.segmentation`, its
  polygons :mod:`~fenics_coulomb.model.pairs.polygons`);
* :mod:`~fenics_coulomb.model.pairs.pairing` — :func:`pair_surfaces`: every pair by its method, several pairs,
  the checks;
* :mod:`~fenics_coulomb.model.pairs.two_body` — the change of variables (derivation), the bodies, M, the
  near-nullspace.
"""

from fenics_coulomb.model.pairs.pair import ContactPair, Pairing
from fenics_coulomb.model.pairs.pairing import pair_surfaces
from fenics_coulomb.model.pairs.registry import (pair_method, pair_methods, register_pair_method,
                                                 unregister_pair_method)
from fenics_coulomb.model.pairs.stencils import PairInput, Stencils

__all__ = ["ContactPair", "Pairing", "pair_surfaces", "PairInput", "Stencils", "pair_method", "pair_methods",
           "register_pair_method", "unregister_pair_method"]
