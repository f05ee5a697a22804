"""Generate a hemisphere body (linear tetrahedra) whose curved face rests on the obstacle plane x3 = 0.

The body is the lower half of the ball of radius R (default 1) centred at (0, 0, R): its flat face is the
disc x3 = R, its lowest point (the apex) touches the plane at the origin. A small disc of the curved face
around the apex (radius ``apex`` R, default 0.05 R) is its own boundary: clamping it holds the body against
rigid motions (today's scenes prescribe only zero displacements), as a Hertz set-up with these features
does (notes of issue 13). Pressing the flat face down then makes a Hertz-like contact area grow around the
apex. Physical groups (facet tags):

    1 "top"     the flat face x3 = R (pressed)
    2 "bottom"  the curved face without the apex disc (the contact boundary; gap = node height)
    3 "apex"    the curved face within ``apex`` of the axis (clamped in the scenes)

Run inside the environment:  container/run python3 meshes/hemisphere.py --size 0.1 --out out/hemisphere.msh
(``--size`` is the largest element edge; the smallest is half of it; ``--grading`` refines the mesh
toward the apex: the size at the apex is ``size/grading``). Sizes 0.18, 0.11, 0.08, 0.06 give 3 531,
10 683, 21 834, 41 913 unknowns (benchmarks/pc_auto.py, docs/pc-auto); the apex disc is tested at its
default 0.05 R.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gmsh
from meshes.gmsh_session import gmsh_session, write_volume_mesh

TAGS = {"top": 1, "bottom": 2, "apex": 3}


def build(size: float, path: Path, radius: float = 1.0, apex: float = 0.05, grading: float = 1.0) -> None:
    """Write the hemisphere mesh to ``path`` (gmsh 4.1 format).

    Args:
        size: Largest element edge length.
        path: Output .msh file.
        radius: Radius R of the hemisphere.
        apex: Radius of the clamped apex disc relative to R.
        grading: Ratio of the element size far from the apex to the size at the apex (1: uniform).
    """
    R = radius
    with gmsh_session("hemisphere"):
        occ = gmsh.model.occ
        ball = occ.addSphere(0.0, 0.0, R, R)
        # gmsh's sphere has its poles on the x3 axis and its seam in the x1-x3 plane: tilt them by 60 degrees
        # so that no pole sits at the apex and the seam crosses the cutting plane x3 = R transversally
        occ.rotate([(3, ball)], 0.0, 0.0, R, 1.0, 0.0, 0.0, math.pi / 3)
        box = occ.addBox(-2 * R, -2 * R, -R, 4 * R, 4 * R, 2 * R)  # the half space x3 <= R
        body, _ = occ.intersect([(3, ball)], [(3, box)])
        # split off the apex cap so that its part of the curved face is a surface of its own
        cap_height = R - math.sqrt(R * R - (apex * R) ** 2)
        cut = occ.addBox(-R, -R, -R, 2 * R, 2 * R, R + cap_height)  # x3 <= cap height
        occ.fragment(body, [(3, cut)])
        occ.synchronize()
        volumes = [tag for dim, tag in gmsh.model.getEntities(3)]
        # fragment keeps the part of the box outside the ball: drop volumes whose centre is outside
        outside = []
        for tag in volumes:
            x, y, z = occ.getCenterOfMass(3, tag)
            if x * x + y * y + (z - R) ** 2 > R * R or z > R:
                outside.append(tag)
        if outside:
            occ.remove([(3, t) for t in outside], recursive=True)
            occ.synchronize()
            volumes = [tag for dim, tag in gmsh.model.getEntities(3)]
        volume = sum(occ.getMass(3, tag) for tag in volumes)
        if abs(volume - 2 * math.pi * R**3 / 3) > 1e-6 * R**3:
            raise RuntimeError(f"the boolean operations gave a body of volume {volume}, not a hemisphere")
        gmsh.model.addPhysicalGroup(3, volumes, 1, name="body")
        groups: dict[str, list[int]] = {name: [] for name in TAGS}
        for dim, tag in gmsh.model.getBoundary([(3, v) for v in volumes], oriented=False):
            x, y, z = occ.getCenterOfMass(dim, tag)
            if abs(z - R) < 1e-8 * R:
                groups["top"].append(tag)
            elif x * x + y * y < (apex * R) ** 2 and z < cap_height:
                groups["apex"].append(tag)
            else:
                groups["bottom"].append(tag)
        for name, tags in groups.items():
            if not tags:
                raise RuntimeError(f"no surface found for {name}")
            gmsh.model.addPhysicalGroup(2, tags, TAGS[name], name=name)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", size)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", min(size / (2 * grading), 0.5 * apex * R))
        # resolve the small apex circle: its points get an edge of half the disc's radius at most
        apex_points = gmsh.model.getBoundary([(2, t) for t in groups["apex"]], combined=False, recursive=True)
        gmsh.model.mesh.setSize([(0, t) for d, t in apex_points if d == 0], min(size, 0.5 * apex * R))
        for tag in groups["apex"]:
            gmsh.model.mesh.setAlgorithm(2, tag, 1)  # MeshAdapt copes with the small, curved cap
        if grading > 1.0:
            # size/grading at the apex, growing linearly with the distance from it to size at distance R
            field = gmsh.model.mesh.field.add("MathEval")
            small = size / grading
            gmsh.model.mesh.field.setString(
                field, "F", f"Min({size}, {small} + {size - small}*Sqrt(x*x + y*y + z*z)/{R})")
            gmsh.model.mesh.field.setAsBackgroundMesh(field)
        write_volume_mesh(path, optimize=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=0.1, help="largest element edge (default 0.1)")
    parser.add_argument("--radius", type=float, default=1.0, help="radius R (default 1)")
    parser.add_argument("--apex", type=float, default=0.05, help="clamped apex disc radius / R (default 0.05)")
    parser.add_argument("--grading", type=float, default=1.0, help="size far away / size at the apex (default 1)")
    parser.add_argument("--out", default=str(Path(__file__).with_name("hemisphere.msh")))
    args = parser.parse_args()
    build(args.size, Path(args.out), args.radius, args.apex, args.grading)
