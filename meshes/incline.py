"""Generate the block of the incline verification case: a hexahedral box rotated onto a plane of slope tan α.

The box [0, L] × [0, B] × [0, H] (transfinite, ``cells`` hexahedra per direction) is rotated about x2 by α (x ↦ R x
with R e1 = (cos α, 0, sin α), R e3 = n = (−sin α, 0, cos α)), so that its bottom lies on the plane through the
origin with the normal n, rising along +x1. docs/verification/incline.toml pushes it up the plane. Physical
groups::

    cells   1 "block"
    facets  1 "bottom"      (the contact face)
            2 "lower_end"   (the face that was x1 = 0: pushed)
            3 "front"       4 "back"   (the faces x2 = 0 and x2 = B: rollers)
            5 "top"         6 "upper_end"

Run inside the environment:
``container/run python3 meshes/incline.py --cells 4 4 2 --out meshes/incline.msh``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gmsh
import numpy as np
from meshes.gmsh_session import gmsh_session, write_volume_mesh

__all__ = ["TAGS", "TAN_ALPHA", "SIZE", "rotation", "build"]

TAGS = {"bottom": 1, "lower_end": 2, "front": 3, "back": 4, "top": 5, "upper_end": 6}
TAN_ALPHA = 0.1
SIZE = (1.0, 1.0, 0.5)


def rotation(tan_alpha: float = TAN_ALPHA) -> np.ndarray:
    """R with R e1 = (cos α, 0, sin α) (up the slope), R e2 = e2, R e3 = (−sin α, 0, cos α) (the plane's normal)."""
    alpha = math.atan(tan_alpha)
    s, c = math.sin(alpha), math.cos(alpha)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def build(path: Path, cells: tuple[int, int, int] = (4, 4, 2), tan_alpha: float = TAN_ALPHA) -> None:
    """Mesh the rotated block with ``cells`` hexahedra along (L, B, H) and write ``path`` (gmsh 4.1)."""
    R = rotation(tan_alpha)
    with gmsh_session("incline"):
        occ = gmsh.model.occ
        volume = occ.addBox(0.0, 0.0, 0.0, *SIZE)
        occ.rotate([(3, volume)], 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -math.atan(tan_alpha))
        occ.synchronize()
        for _, curve in gmsh.model.getEntities(1):
            lo = np.array(gmsh.model.getBoundingBox(1, curve))
            extent = R.T @ (lo[3:] - lo[:3])  # the box frame (the rotation keeps the edges' directions)
            axis = int(np.argmax(np.abs(extent)))
            gmsh.model.mesh.setTransfiniteCurve(curve, cells[axis] + 1)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            gmsh.model.mesh.setRecombine(2, surface)
        gmsh.model.mesh.setTransfiniteVolume(volume)
        gmsh.model.addPhysicalGroup(3, [volume], 1, name="block")
        faces: dict[str, list[int]] = {name: [] for name in TAGS}
        L, B, H = SIZE
        for _, surface in gmsh.model.getEntities(2):
            x = R.T @ np.array(occ.getCenterOfMass(2, surface))
            name = ("bottom" if abs(x[2]) < 1e-9 else "top" if abs(x[2] - H) < 1e-9 else
                    "lower_end" if abs(x[0]) < 1e-9 else "upper_end" if abs(x[0] - L) < 1e-9 else
                    "front" if abs(x[1]) < 1e-9 else "back")
            faces[name].append(surface)
        for name, tags in faces.items():
            gmsh.model.addPhysicalGroup(2, tags, TAGS[name], name=name)
        write_volume_mesh(path)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs=3, default=(4, 4, 2), help="hexahedra along L, B, H")
    parser.add_argument("--out", default="incline.msh")
    args = parser.parse_args()
    build(Path(args.out), tuple(args.cells))
