"""The SCD semismooth* Newton method of the reference paper (Sections 4–6), on an assembled contact model.

The paper's kernels, each independently tested: :mod:`.resolvent` (the contact mapping's resolvent, the
contact states), :mod:`.derivatives` (its SC derivatives), :mod:`.steps` (the Newton directions of variants
4a/4b), :mod:`.stopping` (the stopping rule), :mod:`.forcing` (the linear solves' tolerances),
:mod:`.contact_rows` (A's rows at the contact DOFs), :mod:`.newton_operator` (the Newton matrix, explicit or a
shell), :mod:`.power_method` (λ_max(A) for γ), :mod:`.preconditioner` (the KSP's preconditioners and pc auto's
ladder), :mod:`.physical_preconditioner` (GAMG for pairs in the physical displacement); the driver
:mod:`.newton` (:class:`~fenics_coulomb.scd.newton.SCDNewtonSolver`) and its result :mod:`.records`.
"""
