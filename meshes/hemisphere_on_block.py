"""Generate an elastic hemisphere resting on an elastic block: two volumes of ONE gmsh mesh (linear tetrahedra).

The hemisphere is the lower half of the ball of radius R (default 1) centred at (0, 0, R): its flat face is
the disc x3 = R, its apex touches the block's top x3 = 0 at the origin. The block is [−B, B]² × [−H, 0]
(default B = H = 2R). The two volumes are meshed apart (no boolean fragment), so they share no node even at
the apex: they are disconnected parts of one mesh, as the two-body contact of issue 18 needs. The element size
is ``contact`` within ``radius`` of the origin and grows linearly with the distance to ``size`` (both bodies
are refined toward the contact point). Physical groups::

    cells   1 "block"          2 "hemisphere"
    facets  1 "block_top"      (the master surface)
            2 "block_bottom"   (clamped)
            3 "block_sides"
            4 "curved"         (the hemisphere's curved face: the slave surface)
            5 "flat"           (the hemisphere's flat face x3 = R: pressed)

Run inside the environment:
``container/run python3 meshes/hemisphere_on_block.py --contact 0.03 --out out/hemisphere_on_block.msh``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gmsh

BODIES = {"block": 1, "hemisphere": 2}
TAGS = {"block_top": 1, "block_bottom": 2, "block_sides": 3, "curved": 4, "flat": 5}


def build(contact: float, path: Path | None = None, size: float = 0.3, radius: float = 1.0, half_width: float = 2.0,
          depth: float = 2.0, refined: float = 0.4, growth: float | None = None) -> None:
    """Mesh the hemisphere on the block; write ``path`` (gmsh 4.1) or leave the model in gmsh when None.

    Args:
        contact: Element size within ``refined`` of the origin (the contact point).
        path: Output .msh file, or None to keep the model open (``gmsh.finalize()`` is then the caller's).
        size: Largest element size.
        radius: Radius R of the hemisphere.
        half_width: Half width B of the block.
        depth: Depth H of the block.
        refined: Radius of the ball around the origin meshed at ``contact`` (relative to R).
        growth: Growth of the element size per unit distance beyond that ball (None: (size − contact)/R).
    """
    R = radius
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("hemisphere_on_block")
        occ = gmsh.model.occ
        block = occ.addBox(-half_width, -half_width, -depth, 2 * half_width, 2 * half_width, depth)
        ball = occ.addSphere(0.0, 0.0, R, R)
        # gmsh's sphere has its poles on the x3 axis and its seam in the x1-x3 plane: tilt them by 60 degrees so
        # that no pole sits at the apex and the seam crosses the cutting plane x3 = R transversally
        occ.rotate([(3, ball)], 0.0, 0.0, R, 1.0, 0.0, 0.0, math.pi / 3)
        lower = occ.addBox(-2 * R, -2 * R, -R, 4 * R, 4 * R, 2 * R)  # x3 <= R
        (hemisphere,), _ = occ.intersect([(3, ball)], [(3, lower)])
        occ.synchronize()
        volume = occ.getMass(3, hemisphere[1])
        if abs(volume - 2 * math.pi * R**3 / 3) > 1e-6 * R**3:
            raise RuntimeError(f"the boolean operations gave a body of volume {volume}, not a hemisphere")
        gmsh.model.addPhysicalGroup(3, [block], BODIES["block"], name="block")
        gmsh.model.addPhysicalGroup(3, [hemisphere[1]], BODIES["hemisphere"], name="hemisphere")
        groups: dict[str, list[int]] = {name: [] for name in TAGS}
        for _, tag in gmsh.model.getBoundary([(3, block)], oriented=False):
            _, _, z = occ.getCenterOfMass(2, tag)
            groups["block_top" if abs(z) < 1e-9 else "block_bottom" if abs(z + depth) < 1e-9 else "block_sides"].append(
                tag)
        for _, tag in gmsh.model.getBoundary([hemisphere], oriented=False):
            _, _, z = occ.getCenterOfMass(2, tag)
            groups["flat" if abs(z - R) < 1e-8 * R else "curved"].append(tag)
        for name, tags in groups.items():
            if not tags:
                raise RuntimeError(f"no surface found for {name}")
            gmsh.model.addPhysicalGroup(2, tags, TAGS[name], name=name)
        field = gmsh.model.mesh.field.add("MathEval")
        r0 = refined * R
        slope = (size - contact) / R if growth is None else growth
        gmsh.model.mesh.field.setString(
            field, "F", f"Min({size}, {contact} + Max(0, Sqrt(x*x + y*y + z*z) - {r0}) * {slope})")
        gmsh.model.mesh.field.setAsBackgroundMesh(field)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", size)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.optimize()
        if path is not None:
            gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
            gmsh.write(str(path))
    except BaseException:
        gmsh.finalize()
        raise
    if path is not None:
        gmsh.finalize()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--contact", type=float, default=0.04, help="element size at the contact point")
    parser.add_argument("--size", type=float, default=0.3, help="largest element size (default 0.3)")
    parser.add_argument("--radius", type=float, default=1.0, help="radius R (default 1)")
    parser.add_argument("--refined", type=float, default=0.4,
                        help="radius (relative to R) of the ball around the contact point meshed at --contact")
    parser.add_argument("--out", default="hemisphere_on_block.msh")
    args = parser.parse_args()
    build(args.contact, Path(args.out), args.size, args.radius, refined=args.refined)
