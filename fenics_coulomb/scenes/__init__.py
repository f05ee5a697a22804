"""Scenes: a contact problem described as data and made concrete.

:mod:`.scene` (the TOML scene file and its validation), :mod:`.cuboid` (the paper's cuboid with a deformed
bottom), :mod:`.partition` (its box partition), :mod:`.expression` (load expressions), :mod:`.builder` (a scene
→ body, forms, boundary conditions and :class:`~fenics_coulomb.problem.ContactProblem`), :mod:`.path` (load
paths) and :mod:`.nested` (nested iteration over cuboid levels).
"""
