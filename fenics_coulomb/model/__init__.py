"""The contact model: what is solved, independent of how.

:mod:`.contact_model` (:class:`~fenics_coulomb.model.contact_model.ContactModel`: the assembled operator
and load with the Dirichlet rows, the contact map and the coupling of two bodies), :mod:`.contact_map`
(contact nodes, their gaps and frames), :mod:`.frames` (per-node frames and the SCD method written in them),
:mod:`.obstacles` (rigid planes, spheres, cylinders), :mod:`.pairing` and :mod:`.two_body` (two elastic
bodies: the node-to-surface pairing and the change of variables u = M z), :mod:`.nullspace` (rigid-body
modes), :mod:`.materials`, :mod:`.mesh_checks` (degenerate cells) and :mod:`.checks` (the physics checks
of a solution: equilibrium, Signorini, Coulomb, balance, reactions).
"""
