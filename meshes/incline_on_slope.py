"""Generate the two-body incline: the block of meshes/incline.py resting on an elastic slope (non-matching meshes).

Both bodies are boxes rotated about x2 by α (R of :func:`meshes.incline.rotation`): the block [0, 1] × [0, 1] × [0, 0.5]
and, below it, the slope [−0.5, 1.5] × [0, 1] × [−0.5, 0] (box frame), so that the slope's top is the plane of slope
tan α through the origin and the block's bottom lies on it, inside it. Hexahedra, transfinite: ``cells`` per
direction in the block and ``slope_cells`` in the slope; the two volumes are meshed apart (their nodes on the
shared plane are distinct), so they are two bodies coupled by a contact pair. Physical groups::

    cells   1 "block"   2 "slope"
    facets  1 "bottom"  2 "lower_end"  3 "front"  4 "back"  5 "top"  6 "upper_end"   (the block, as meshes/incline.py)
            7 "slope_top"  8 "slope_bottom"  9 "slope_sides"

docs/verification/incline_two_bodies.toml pushes the block up the slope. Run inside the environment:
``container/run python3 meshes/incline_on_slope.py --cells 4 4 2 --slope-cells 6 3 2 \\
--out meshes/incline_on_slope.msh``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gmsh
import numpy as np
from meshes.gmsh_session import gmsh_session, write_volume_mesh
from meshes.incline import SIZE, TAGS, TAN_ALPHA, rotation

__all__ = ["SLOPE", "SLOPE_TAGS", "build"]

#: The slope in the box frame: (origin, size).
SLOPE = ((-0.5, 0.0, -0.5), (2.0, 1.0, 0.5))
SLOPE_TAGS = {"slope_top": 7, "slope_bottom": 8, "slope_sides": 9}


def _transfinite(volume: int, cells: tuple[int, int, int], R: np.ndarray) -> None:
    """Structured hexahedra with ``cells`` per box direction in ``volume`` (edges keep their box directions)."""
    surfaces = gmsh.model.getAdjacencies(3, volume)[1]
    edges = sorted({int(c) for s in surfaces for c in gmsh.model.getAdjacencies(2, s)[1]})
    for curve in edges:
        lo = np.array(gmsh.model.getBoundingBox(1, curve))
        axis = int(np.argmax(np.abs(R.T @ (lo[3:] - lo[:3]))))
        gmsh.model.mesh.setTransfiniteCurve(curve, cells[axis] + 1)
    for surface in surfaces:
        gmsh.model.mesh.setTransfiniteSurface(int(surface))
        gmsh.model.mesh.setRecombine(2, int(surface))
    gmsh.model.mesh.setTransfiniteVolume(volume)


def build(path: Path, cells: tuple[int, int, int] = (4, 4, 2), slope_cells: tuple[int, int, int] = (6, 3, 2),
          tan_alpha: float = TAN_ALPHA) -> None:
    """Mesh the block and the slope and write ``path`` (gmsh 4.1)."""
    R = rotation(tan_alpha)
    angle = -math.atan(tan_alpha)
    with gmsh_session("incline_on_slope"):
        occ = gmsh.model.occ
        block = occ.addBox(0.0, 0.0, 0.0, *SIZE)
        slope = occ.addBox(*SLOPE[0], *SLOPE[1])
        occ.rotate([(3, block), (3, slope)], 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, angle)
        occ.synchronize()
        _transfinite(block, cells, R)
        _transfinite(slope, slope_cells, R)
        gmsh.model.addPhysicalGroup(3, [block], 1, name="block")
        gmsh.model.addPhysicalGroup(3, [slope], 2, name="slope")
        faces: dict[str, list[int]] = {name: [] for name in (*TAGS, *SLOPE_TAGS)}
        L, B, H = SIZE
        for surface in gmsh.model.getAdjacencies(3, block)[1]:
            x = R.T @ np.array(occ.getCenterOfMass(2, int(surface)))
            name = ("bottom" if abs(x[2]) < 1e-9 else "top" if abs(x[2] - H) < 1e-9 else
                    "lower_end" if abs(x[0]) < 1e-9 else "upper_end" if abs(x[0] - L) < 1e-9 else
                    "front" if abs(x[1]) < 1e-9 else "back")
            faces[name].append(int(surface))
        for surface in gmsh.model.getAdjacencies(3, slope)[1]:
            x = R.T @ np.array(occ.getCenterOfMass(2, int(surface)))
            name = ("slope_top" if abs(x[2]) < 1e-9 else "slope_bottom" if abs(x[2] - SLOPE[0][2]) < 1e-9
                    else "slope_sides")
            faces[name].append(int(surface))
        for name, tags in faces.items():
            gmsh.model.addPhysicalGroup(2, tags, {**TAGS, **SLOPE_TAGS}[name], name=name)
        write_volume_mesh(path)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs=3, default=(4, 4, 2), help="block hexahedra along L, B, H")
    parser.add_argument("--slope-cells", type=int, nargs=3, default=(6, 3, 2), help="slope hexahedra along its sides")
    parser.add_argument("--out", default="incline_on_slope.msh")
    args = parser.parse_args()
    build(Path(args.out), tuple(args.cells), tuple(args.slope_cells))
