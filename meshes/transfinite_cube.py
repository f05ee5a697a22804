"""A unit cube of tetrahedra (2 cells per edge) with every face a physical surface, one face triangulated against
its volume's tetrahedra on request: the defect ``read_gmsh_tags`` refuses (a physical surface whose elements are
not faces of the volume elements, which DOLFINx's reader would leave untagged without a word).

    container/run python3 meshes/transfinite_cube.py out/cube.msh --arrangement Right
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["write_cube"]


def write_cube(path: str | Path, arrangement: str = "Left") -> Path:
    """Write the transfinite unit cube to ``path`` (gmsh 4.1): physical surface i = face i of gmsh's box (1: x1 = 0,
    2: x1 = 1, 3: x2 = 0, 4: x2 = 1, 5: x3 = 0, 6: x3 = 1) named "face{i}", physical volume 1; face 1 triangulated
    with the transfinite ``arrangement`` ("Left", as the volume: consistent; "Right": its triangles are not the
    tetrahedra's faces)."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        box = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        for _, curve in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(curve, 3)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface, arrangement if surface == 1 else "Left")
            gmsh.model.addPhysicalGroup(2, [surface], surface, name=f"face{surface}")
        gmsh.model.mesh.setTransfiniteVolume(box)
        gmsh.model.addPhysicalGroup(3, [box], 1)
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return Path(path)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--arrangement", choices=("Left", "Right"), default="Left")
    args = parser.parse_args()
    write_cube(args.out, args.arrangement)
