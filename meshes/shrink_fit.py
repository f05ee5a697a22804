"""Generate a quarter of a shrink fit: a shaft (radius b) and a ring (bore b − δ, outer radius c), a slice of
thickness t, as two volumes of ONE gmsh mesh (tetrahedra), meshed apart with their own sizes (non-matching curved
surfaces that overlap by the radial interference δ).

The quarter x1 >= 0, x2 >= 0, 0 <= x3 <= t of both. benchmarks/verification.py (case 7) holds the cut faces on
rollers (u1 = 0 on x1 = 0, u2 = 0 on x2 = 0, u3 = 0 on x3 = 0, t: plane strain) and solves the interference.
Physical groups::

    cells   1 "shaft"          2 "ring"
    facets  1 "shaft_surface"  (r = b: the master surface)
            2 "ring_bore"      (r = b − δ: the slave surface)
            3 "x_cut"          (x1 = 0, both bodies)     4 "y_cut"   (x2 = 0, both bodies)
            5 "faces"          (x3 = 0 and x3 = t, both bodies)
            6 "ring_outer"     (r = c)

Run inside the environment:
``container/run python3 meshes/shrink_fit.py --shaft 0.05 --ring 0.04 --out meshes/shrink_fit.msh``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gmsh
import numpy as np
from meshes.gmsh_session import gmsh_session, write_volume_mesh

__all__ = ["BODIES", "TAGS", "GEOMETRY", "build"]

BODIES = {"shaft": 1, "ring": 2}
TAGS = {"shaft_surface": 1, "ring_bore": 2, "x_cut": 3, "y_cut": 4, "faces": 5, "ring_outer": 6}
#: Shaft radius b, ring outer radius c, radial interference δ, slice thickness t.
GEOMETRY = {"b": 1.0, "c": 2.0, "delta": 0.005, "t": 0.1}


def build(path: Path, shaft: float = 0.05, ring: float = 0.04, geometry: dict[str, float] | None = None,
          layers: int = 1) -> None:
    """Mesh the quarter shaft and ring with element sizes ``shaft`` and ``ring`` (``layers`` element layers
    through the thickness) and write ``path`` (gmsh 4.1)."""
    g = {**GEOMETRY, **(geometry or {})}
    b, c, delta, t = g["b"], g["c"], g["delta"], g["t"]
    with gmsh_session("shrink_fit"):
        occ = gmsh.model.occ
        # the quarter cross-sections, extruded in x3 with ``layers`` layers (structured through the thickness)
        disc = occ.addDisk(0.0, 0.0, 0.0, b, b)
        quarter = occ.addRectangle(0.0, 0.0, 0.0, 2.0 * c, 2.0 * c)
        shaft_2d = occ.intersect([(2, disc)], [(2, quarter)])[0]
        outer = occ.addDisk(0.0, 0.0, 0.0, c, c)
        bore = occ.addDisk(0.0, 0.0, 0.0, b - delta, b - delta)
        quarter2 = occ.addRectangle(0.0, 0.0, 0.0, 2.0 * c, 2.0 * c)
        annulus = occ.cut([(2, outer)], [(2, bore)])[0]
        ring_2d = occ.intersect(annulus, [(2, quarter2)])[0]
        occ.synchronize()
        for dimtags, size in ((shaft_2d, shaft), (ring_2d, ring)):
            points = gmsh.model.getBoundary(dimtags, combined=False, oriented=False, recursive=True)
            gmsh.model.mesh.setSize(points, size)
        shaft_3d = occ.extrude(shaft_2d, 0.0, 0.0, t, numElements=[layers])
        ring_3d = occ.extrude(ring_2d, 0.0, 0.0, t, numElements=[layers])
        occ.synchronize()
        volumes = {"shaft": [d[1] for d in shaft_3d if d[0] == 3], "ring": [d[1] for d in ring_3d if d[0] == 3]}
        faces: dict[str, list[int]] = {name: [] for name in TAGS}
        for name, tags in volumes.items():
            gmsh.model.addPhysicalGroup(3, tags, BODIES[name], name=name)
            for _, surface in gmsh.model.getBoundary([(3, v) for v in tags], oriented=False):
                x = np.array(occ.getCenterOfMass(2, surface))  # planar cuts: their centroid lies on the plane
                if abs(x[2]) < 1e-9 * c or abs(x[2] - t) < 1e-9 * c:
                    key = "faces"
                elif abs(x[0]) < 1e-9 * c:
                    key = "x_cut"
                elif abs(x[1]) < 1e-9 * c:
                    key = "y_cut"
                else:
                    r = math.hypot(x[0], x[1])
                    key = "shaft_surface" if name == "shaft" else ("ring_outer" if r > 0.5 * (b + c) else "ring_bore")
                faces[key].append(surface)
        for name, tags in faces.items():
            gmsh.model.addPhysicalGroup(2, tags, TAGS[name], name=name)
        write_volume_mesh(path)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shaft", type=float, default=0.05, help="element size of the shaft")
    parser.add_argument("--ring", type=float, default=0.04, help="element size of the ring")
    parser.add_argument("--layers", type=int, default=1, help="element layers through the thickness")
    parser.add_argument("--out", default="shrink_fit.msh")
    args = parser.parse_args()
    build(Path(args.out), args.shaft, args.ring, layers=args.layers)
