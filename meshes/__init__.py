"""Mesh generators of the non-box bodies (gmsh scripts, two disjoint DOLFINx blocks, STL surfaces).

Each module is imported (``from meshes.two_blocks import two_blocks``, ``from meshes import roller``) or run as a
script inside the environment (``container/run python3 meshes/roller.py --size 0.05 --out meshes/roller.msh``);
the generated files (``*.msh``, ``*.stl``) that the scenes read sit beside them.
"""
