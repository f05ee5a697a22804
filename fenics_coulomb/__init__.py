"""fenics-coulomb: 3D static Coulomb-friction contact with a rigid obstacle, SCD semismooth* Newton method.

Modules, one concept each:

* :mod:`fenics_coulomb.scene` — the cuboid body Ω(d), gap profiles and load cases of the paper's Section 7;
* :mod:`fenics_coulomb.contact` — the contact-node extractor (per-node 3-blocks of DOFs);
* :mod:`fenics_coulomb.model` — UFL forms, stiffness A, load l̃, shift d and l = l̃ + A d;
* :mod:`fenics_coulomb.resolvent` — the contact mapping Q̃, its resolvent and the sets of (6.9);
* :mod:`fenics_coulomb.derivatives` — elements of S*Q̃ and SQ̃ with the scaling of Corollary 6.7;
* :mod:`fenics_coulomb.newton` — the SCD semismooth* Newton driver (PETSc Newton matrix and KSP);
* :mod:`fenics_coulomb.output` — XDMF fields and the JSON summary;
* :mod:`fenics_coulomb.cli` — the command line.
"""

__version__ = "0.1.0"
