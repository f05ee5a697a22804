"""Generate a large elastic sphere cap on a large elastic block, as a half (x2 ≥ 0) or quarter (x1, x2 ≥ 0) model,
with structured fine cores under the contact in BOTH bodies (linear tetrahedra, strongly graded).

meshes/hertz_quarter.py's technique for two elastic bodies. The upper body is the ball of radius R centred at
(0, 0, R) cut at the height x3 = H (its flat face, pressed) and by the symmetry plane(s); its lowest point touches
the block's top x3 = 0 at the origin. The block is [−W, W] × [0, W] × [−D, 0] (half) or [0, W]² × [−D, 0]
(quarter). x2 = 0 (and x1 = 0 for the quarter) are planes of symmetry (rollers). Under the contact both bodies
have a structured core of edge ``h0``: in the block the box [−L, L] × [0, L] × [−L, 0] (x1 from 0 for the
quarter), in the upper body the part of the ball within [−L, L] × [0, L] × [·, L] (its bottom is the sphere's
cap, a hexahedron with one curved face, meshed transfinite): each grid cell is cut into six tetrahedra, so the
nodes share the contact surface evenly and the nodal pressures do not scatter with the shapes of unstructured
cells. Beyond the cores unstructured tetrahedra whose edge grows linearly with the distance from the origin by
``growth`` per unit distance, up to ``largest``·W. The two bodies are meshed apart (they share no node: two
disconnected volumes of one mesh, the two-body contact's input); the block's core grid is ``master``·h0 (0.85:
finer), so that the two grids do not coincide (a node on an edge of the other surface would be a partner tie).

Use the block's top as the pair's SLAVE surface: it is flat, so the normals of its nodes on a symmetry plane are
exactly orthogonal to the held component. With the curved cap as the slave, mortar dropped the slave nodes on
x2 = 0 and the next row (their facets' projection onto the block reached past the master's border x2 = 0 by
round-off: "not fully covered") and 18 of them penetrated.

The ball is rotated so that its poles lie on the x2 axis and its seam in the plane x3 = R: with H < R neither
is in the model (gmsh's sphere parametrisation is singular at the poles).

Physical groups::

    cells   1 "upper"  2 "block"
    facets  1 "cap"       the upper core's bottom (the spherical cap |x1|, x2 ≤ L): the master surface
            2 "top"       the block core's top (the slave surface)
            3 "bottom"    x3 = −D (clamped)
            4 "flat"      the upper body's flat face x3 = H (pressed)
            5 "sym_y"     x2 = 0, both bodies (roller u2 = 0)
            6 "sym_x"     x1 = 0, both bodies (quarter only; roller u1 = 0)
            7 "free"      the rest

Run inside the environment::

    container/run python3 meshes/sphere_on_block_half.py --h0 0.05 --out out/sphere_on_block_half.msh

Sizes (a = 0.5, R = 100, W = 200 a, L = 1.2 a; benchmarks/verification_two_body.py's CORE_LEVELS), in unknowns
(3 per node): the quarter at h0 = a/8 (growth 0.2) 19 266, a/12 (0.15) 49 962, a/16 91 824, a/20 150 096; the
half at a/6 (growth 0.25) 17 034, a/8 (0.2) 35 043.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gmsh
from fenics_coulomb.scenes.meshes import surface_elements_off_volume
from meshes.gmsh_session import add_physical_surfaces, gmsh_session, radial_size_field

__all__ = ["BODIES", "TAGS", "build"]

BODIES = {"upper": 1, "block": 2}
TAGS = {"cap": 1, "top": 2, "bottom": 3, "flat": 4, "sym_y": 5, "sym_x": 6, "free": 7}


def _transfinite(volumes: list[int], h0: float) -> list[int]:
    """Transfinite curves (round(length/h0) cells), surfaces and volumes for the hexahedral ``volumes``; returns
    the surfaces."""
    faces = gmsh.model.getBoundary([(3, v) for v in volumes], combined=False, oriented=False)
    curves = {c for _, c in gmsh.model.getBoundary(faces, combined=False, oriented=False)}
    for curve in curves:
        length = gmsh.model.occ.getMass(1, curve)
        gmsh.model.mesh.setTransfiniteCurve(curve, max(1, round(length / h0)) + 1)
    for _, surface in faces:
        gmsh.model.mesh.setTransfiniteSurface(surface)
    for v in volumes:
        gmsh.model.mesh.setTransfiniteVolume(v)
    return [surface for _, surface in faces]


def _mesh_consistently(path: Path | str, surfaces: list[int]) -> None:
    """Mesh, optimize and write (as meshes/gmsh_session.py's ``write_volume_mesh``) so that the transfinite
    ``surfaces``' triangles are faces of the cores' tetrahedra. gmsh splits a transfinite volume's hexahedra into
    tetrahedra whose diagonals on a face need not be that face's transfinite triangles' (the upper core's symmetry
    face x2 = 0 of the half model came out with the other diagonal on every cell: DOLFINx then tagged none of its
    380 facets at h0 = a/8 and the roller left them free); such a surface is triangulated the other way ("Right")
    and the model meshed again. Raises RuntimeError if one still differs."""
    gmsh.model.mesh.generate(3)
    off = surface_elements_off_volume(gmsh, surfaces)
    if off:
        for surface in off:
            gmsh.model.mesh.setTransfiniteSurface(surface, "Right")
        gmsh.model.mesh.clear()
        gmsh.model.mesh.generate(3)
    gmsh.model.mesh.optimize()
    off = surface_elements_off_volume(gmsh, surfaces)
    if off:
        raise RuntimeError(f"sphere_on_block_half: the triangles of the surfaces {sorted(off)} are not faces of the "
                           "cores' tetrahedra")
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))


def build(path: Path | str, a: float, h0: float, radius: float, width: float = 200.0, fine: float = 1.2,
          growth: float = 0.15, largest: float = 0.25, height: float = 0.5, quarter: bool = False,
          master: float = 0.85) -> None:
    """Write the sphere cap on the block to ``path`` (gmsh 4.1 format).

    Args:
        path: Output .msh file.
        a: The length scale of the contact (the Hertz contact radius).
        h0: The edge of the structured cores.
        radius: R, the sphere's radius.
        width: W/a: the block's half width and depth.
        fine: L/a, the cores' size.
        growth: The edge's growth per unit distance beyond the cores.
        largest: The largest edge relative to W.
        height: H/R, the height of the upper body's flat face (< 1: the sphere's seam is at x3 = R).
        quarter: x1 ≥ 0 too (else x1 spans [−W, W]).
        master: The block core's edge / ``h0`` (its grid differs from the cap's, so that no slave node sits on a
            master edge in the reference configuration, where its partner facet would be a tie).
    """
    W = width * a
    L = fine * a
    H = height * radius
    x0 = 0.0 if quarter else -1.0
    with gmsh_session("sphere_on_block_half"):
        occ = gmsh.model.occ
        block = occ.addBox(x0 * W, 0.0, -W, (1 - x0) * W, W, W)
        block_core = occ.addBox(x0 * L, 0.0, -L, (1 - x0) * L, L, L)
        block_parts, _ = occ.fragment([(3, block)], [(3, block_core)])
        ball = occ.addSphere(0.0, 0.0, radius, radius)
        occ.rotate([(3, ball)], 0.0, 0.0, radius, 1.0, 0.0, 0.0, math.pi / 2)
        span = 1.1 * radius
        cut = occ.addBox(x0 * span, 0.0, -0.1 * radius, (1 - x0) * span, span, H + 0.1 * radius)
        upper, _ = occ.intersect([(3, ball)], [(3, cut)])
        cut2 = occ.addBox(x0 * span, 0.0, H, (1 - x0) * span, span, radius)
        upper, _ = occ.cut(upper, [(3, cut2)])
        core_box = occ.addBox(x0 * L, 0.0, -0.1 * radius, (1 - x0) * L, L, 0.1 * radius + L)
        ball2 = occ.addSphere(0.0, 0.0, radius, radius)
        occ.rotate([(3, ball2)], 0.0, 0.0, radius, 1.0, 0.0, 0.0, math.pi / 2)
        upper_core, _ = occ.intersect([(3, core_box)], [(3, ball2)])
        upper_parts, _ = occ.fragment(upper, upper_core)
        occ.synchronize()

        def small(tags: list[tuple[int, int]], size: float) -> list[int]:
            return [t for d, t in tags if d == 3 and occ.getMass(3, t) < size]

        core_volume = (1 - x0) * L * L * L * 1.5
        block_volumes = [t for d, t in block_parts if d == 3]
        upper_volumes = [t for d, t in upper_parts if d == 3]
        gmsh.model.addPhysicalGroup(3, upper_volumes, BODIES["upper"], name="upper")
        gmsh.model.addPhysicalGroup(3, block_volumes, BODIES["block"], name="block")
        structured = _transfinite(small(block_parts, core_volume), master * h0)
        structured += _transfinite(small(upper_parts, core_volume), h0)
        groups: dict[str, list[int]] = {name: [] for name in TAGS}
        tol = 1e-9 * W
        for body, volumes in (("upper", upper_volumes), ("block", block_volumes)):
            for _, surface in gmsh.model.getBoundary([(3, v) for v in volumes], combined=True, oriented=False):
                x, y, z = occ.getCenterOfMass(2, surface)
                if abs(y) < tol:
                    name = "sym_y"
                elif quarter and abs(x) < tol:
                    name = "sym_x"
                elif body == "block":
                    name = ("top" if abs(z) < tol and max(abs(x), y) < L else "bottom" if abs(z + W) < tol
                            else "free")
                else:
                    name = "flat" if abs(z - H) < tol else "cap" if max(abs(x), y, z) < L else "free"
                groups[name].append(surface)
        add_physical_surfaces(groups, TAGS)
        radial_size_field(h0, growth, fine * a, largest * W)
        _mesh_consistently(path, structured)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--a", type=float, default=0.5, help="the contact radius a (default 0.5)")
    parser.add_argument("--h0", type=float, default=0.5 / 10, help="the cores' edge (default a/10)")
    parser.add_argument("--radius", type=float, default=100.0, help="the sphere's radius R (default 100)")
    parser.add_argument("--width", type=float, default=200.0, help="W/a (default 200)")
    parser.add_argument("--fine", type=float, default=1.2, help="the cores' size / a (default 1.2)")
    parser.add_argument("--growth", type=float, default=0.15, help="edge growth per unit distance (default 0.15)")
    parser.add_argument("--quarter", action="store_true", help="a quarter model (else the half x2 ≥ 0)")
    parser.add_argument("--out", default="sphere_on_block_half.msh")
    args = parser.parse_args()
    build(Path(args.out), args.a, args.h0, args.radius, args.width, args.fine, args.growth, quarter=args.quarter)
