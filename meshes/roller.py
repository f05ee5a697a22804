"""Generate meshes/roller.msh: a half-cylinder beam lying on its curved side (a non-box body).

The body is the lower half of the cylinder of radius R = 0.5 whose axis runs along x1 from (0, 0.5, zc) to
(2, 0.5, zc), zc = R + 0.01, so its lowest line hangs 0.01 above the obstacle plane x3 = 0. Linear
tetrahedra. Physical groups (facet tags):

    1 "left"    x1 = 0 end face (clamped in the scenes)
    2 "right"   x1 = 2 end face
    3 "top"     the flat face x3 = zc
    4 "bottom"  the curved face (the contact boundary; gap = node height)

Run inside the environment:  container/run python3 meshes/roller.py [--size 0.07]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gmsh

R, LENGTH, CLEARANCE = 0.5, 2.0, 0.01
TAGS = {"left": 1, "right": 2, "top": 3, "bottom": 4}


def build(size: float, path: Path) -> None:
    zc = R + CLEARANCE
    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("roller")
    occ = gmsh.model.occ
    cyl = occ.addCylinder(0.0, 0.5, zc, LENGTH, 0.0, 0.0, R)
    box = occ.addBox(-1.0, -1.0, zc - 2.0, LENGTH + 2.0, 3.0, 2.0)
    body, _ = occ.intersect([(3, cyl)], [(3, box)])
    occ.synchronize()
    volumes = [tag for dim, tag in body if dim == 3]
    gmsh.model.addPhysicalGroup(3, volumes, 1, name="body")
    groups: dict[str, list[int]] = {name: [] for name in TAGS}
    for dim, tag in gmsh.model.getBoundary(body, oriented=False):
        x, _, z = occ.getCenterOfMass(dim, tag)
        if abs(x) < 1e-8:
            groups["left"].append(tag)
        elif abs(x - LENGTH) < 1e-8:
            groups["right"].append(tag)
        elif abs(z - zc) < 1e-8:
            groups["top"].append(tag)
        else:
            groups["bottom"].append(tag)
    for name, tags in groups.items():
        assert tags, f"no surface found for {name}"
        gmsh.model.addPhysicalGroup(2, tags, TAGS[name], name=name)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMax", size)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMin", size / 2)
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.optimize()
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.finalize()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=0.07, help="mesh size (default 0.07)")
    parser.add_argument("--out", default=str(Path(__file__).with_name("roller.msh")))
    args = parser.parse_args()
    build(args.size, Path(args.out))
