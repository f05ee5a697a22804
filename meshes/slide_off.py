"""Generate two elastic blocks, one resting 0.002 above the other: two volumes of ONE gmsh mesh (tetrahedra).

The lower block is [0, 2] × [0, 1] × [0, 0.5], the upper one [0.5, 1.5] × [0.25, 0.75] × [0.502, 1.002]; the two
volumes are meshed apart (no boolean fragment: they share no node) with the element sizes ``lower`` and ``upper``
(non-matching). demos/scenes/slide_off.toml presses the upper block and slides it 0.8 along x1, off the lower
block's edge (finite sliding, docs/sliding). Physical groups::

    cells   1 "lower"           2 "upper"
    facets  1 "lower_top"       (the master surface)
            2 "upper_bottom"    (the slave surface)
            3 "lower_bottom"    (clamped)
            4 "upper_top"       (prescribed: pressed, then moved)
            5 "lower_sides"     6 "upper_sides"

Run inside the environment:
``container/run python3 meshes/slide_off.py --lower 0.2 --upper 0.125 --out meshes/slide_off.msh``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gmsh
from meshes.gmsh_session import gmsh_session, write_volume_mesh

BODIES = {"lower": 1, "upper": 2}
TAGS = {"lower_top": 1, "upper_bottom": 2, "lower_bottom": 3, "upper_top": 4, "lower_sides": 5, "upper_sides": 6}


def build(path: Path, lower: float = 0.2, upper: float = 0.125, layer: float = 0.0) -> None:
    """Mesh both blocks and write ``path`` (gmsh 4.1); ``layer`` > 0: the lower block with a top layer that thick
    (two volumes sharing their interface, one body: cells as thin as the layer under the lower block's top)."""
    if not 0.0 <= layer < 0.5:
        raise ValueError(f"layer = {layer!r}: the top layer's thickness must lie in [0, 0.5) (the lower block is 0.5 "
                         "high; 0: no layer)")
    with gmsh_session("slide_off"):
        occ = gmsh.model.occ
        if layer > 0.0:
            pieces, _ = occ.fragment([(3, occ.addBox(0.0, 0.0, 0.0, 2.0, 1.0, 0.5 - layer))],
                                     [(3, occ.addBox(0.0, 0.0, 0.5 - layer, 2.0, 1.0, layer))])
            bulk = [tag for _, tag in pieces]
        else:
            bulk = [occ.addBox(0.0, 0.0, 0.0, 2.0, 1.0, 0.5)]
        boxes = {"lower": (bulk, 0.0, 0.5, lower),
                 "upper": ([occ.addBox(0.5, 0.25, 0.502, 1.0, 0.5, 0.5)], 0.502, 1.002, upper)}
        occ.synchronize()
        for name, (volumes, bottom, top, size) in boxes.items():
            gmsh.model.addPhysicalGroup(3, volumes, BODIES[name], name=name)
            faces: dict[str, list[int]] = {f"{name}_top": [], f"{name}_bottom": [], f"{name}_sides": []}
            for _, tag in gmsh.model.getBoundary([(3, v) for v in volumes], oriented=False):
                _, _, z = occ.getCenterOfMass(2, tag)
                key = "top" if abs(z - top) < 1e-9 else "bottom" if abs(z - bottom) < 1e-9 else "sides"
                faces[f"{name}_{key}"].append(tag)
            for face, tags in faces.items():
                gmsh.model.addPhysicalGroup(2, tags, TAGS[face], name=face)
            points = gmsh.model.getBoundary([(3, v) for v in volumes], combined=False, oriented=False, recursive=True)
            gmsh.model.mesh.setSize(points, size)
        write_volume_mesh(path)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lower", type=float, default=0.2, help="element size of the lower block")
    parser.add_argument("--upper", type=float, default=0.125, help="element size of the upper block")
    parser.add_argument("--layer", type=float, default=0.0, help="a top layer of the lower block this thick")
    parser.add_argument("--out", default="slide_off.msh")
    args = parser.parse_args()
    try:
        build(Path(args.out), args.lower, args.upper, args.layer)
    except ValueError as err:
        parser.error(str(err))  # one line, exit 2
