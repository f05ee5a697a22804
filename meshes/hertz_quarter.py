"""Generate the quarter of a large block for the Hertz indentation (linear tetrahedra, strongly graded).

The block is [0, W] × [0, W] × [−D, 0] (W = ``width``·a, D = ``depth``·a, a the Hertz contact radius): a rigid
sphere touching its top x3 = 0 at the origin indents it about the x3 axis, which is the box's edge x1 = x2 = 0,
and the planes x1 = 0 and x2 = 0 are planes of symmetry (rollers). The mesh is fine only where the solution
varies on the scale of a: under the contact a structured core, the cube [0, L]² × [−L, 0] (L = ``fine``·a)
as a grid of edge ``h0`` with each grid cube cut into six tetrahedra (regular nodes share the contact surface
evenly, so the nodal pressures do not scatter with the shapes of unstructured cells); beyond it unstructured
tetrahedra whose edge grows linearly with the distance from the origin, by ``growth`` per unit distance (a
geometric coarsening: the same number of elements across each doubling of the distance), up to
``largest``·W. The volume is therefore mostly far field at a cost logarithmic in W/a: a domain ≫ a, whose
support removes little of the half-space's compliance, at few unknowns. Physical groups (facet tags):

    1 "contact"   the core's top [0, L]² at x3 = 0 (the contact boundary: the sphere touches only there; the
                  whole top face when there is no core)
    2 "bottom"    x3 = −D (clamped in the benchmarks)
    3 "sides"     x1 = W and x2 = W (free)
    4 "sym_x"     x1 = 0 (roller: u1 = 0)
    5 "sym_y"     x2 = 0 (roller: u2 = 0)
    6 "top"       the rest of x3 = 0 (free)

Only where contact can occur is the contact boundary, as an engineer would set it: the solver's round-off
floor of the residual grows with the gaps of all contact nodes, and the far top's gaps (≈ r²/2R, up to 10⁵ δ
at W = 1000 a) would set it 10⁶ times above the contact's own scale (1 vs 2 ranks then differ by 10⁻⁶).

The x3 axis is an edge of the geometry, so the mesh has vertices on it (the points under the contact's
centre, where Hertz's sub-surface stresses are tabulated), and the origin is a vertex.

Run inside the environment::

    container/run python3 meshes/hertz_quarter.py --a 0.5 --h0 0.0294 --out out/hertz_quarter.msh

Sizes (W = D = 1000 a, growth 0.1, L = 1.5 a; benchmarks/hertz_quarter.py's levels): h0 = a/12: 53 661
unknowns, a/17: 97 275, a/24: about 200 k; with L = 1.2 a and growth 0.15, h0 = a/16: 37 407.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gmsh
from meshes.gmsh_session import add_physical_surfaces, gmsh_session, radial_size_field, write_volume_mesh

__all__ = ["TAGS", "build"]

TAGS = {"contact": 1, "bottom": 2, "sides": 3, "sym_x": 4, "sym_y": 5, "top": 6}


def build(path: Path | str, a: float, h0: float, width: float = 1000.0, depth: float | None = None,
          fine: float = 1.5, growth: float = 0.1, largest: float = 0.25, structured: bool = True) -> None:
    """Write the quarter block to ``path`` (gmsh 4.1 format).

    Args:
        path: Output .msh file.
        a: The length scale of the contact (the Hertz contact radius).
        h0: The element edge within ``fine``·a of the origin.
        width: W/a, the block's half width (the quarter spans [0, W] in x1 and x2).
        depth: D/a, the block's depth (default: ``width``).
        fine: L/a, the size of the fine core (structured) or the radius of the fine region (unstructured).
        growth: The edge's growth per unit distance beyond the fine region (0.1: about 7 elements across
            each doubling of the distance).
        largest: The largest edge relative to W.
        structured: The structured core (else unstructured tetrahedra of edge ``h0`` within the distance
            ``fine``·a of the origin).
    """
    W = width * a
    D = (width if depth is None else depth) * a
    with gmsh_session("hertz_quarter"):
        occ = gmsh.model.occ
        box = occ.addBox(0.0, 0.0, -D, W, W, D)
        L = fine * a
        if structured:
            core = occ.addBox(0.0, 0.0, -L, L, L, L)
            occ.fragment([(3, box)], [(3, core)])
        occ.synchronize()
        volumes = [tag for _, tag in gmsh.model.getEntities(3)]
        gmsh.model.addPhysicalGroup(3, volumes, 1, name="block")
        if structured:
            inner = [v for v in volumes if occ.getMass(3, v) < 1.5 * L**3]
            n = max(1, round(L / h0))
            faces = gmsh.model.getBoundary([(3, v) for v in inner], combined=False, oriented=False)
            curves = {c for _, c in gmsh.model.getBoundary(faces, combined=False, oriented=False)}
            for curve in curves:
                gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
            for _, surface in gmsh.model.getBoundary([(3, v) for v in inner], combined=False, oriented=False):
                gmsh.model.mesh.setTransfiniteSurface(surface)
            for v in inner:
                gmsh.model.mesh.setTransfiniteVolume(v)
        groups: dict[str, list[int]] = {name: [] for name in TAGS}
        boundary = gmsh.model.getBoundary([(3, v) for v in volumes], combined=True, oriented=False)
        for _, surface in boundary:
            x, y, z = occ.getCenterOfMass(2, surface)
            tol = 1e-9 * W
            top = "contact" if not structured or max(x, y) < L else "top"
            name = (top if abs(z) < tol else "bottom" if abs(z + D) < tol else "sym_x" if abs(x) < tol
                    else "sym_y" if abs(y) < tol else "sides")
            groups[name].append(surface)
        add_physical_surfaces(groups, TAGS)
        radial_size_field(h0, growth, fine * a, largest * W)
        write_volume_mesh(path, optimize=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--a", type=float, default=0.5, help="the contact radius a (default 0.5)")
    parser.add_argument("--h0", type=float, default=0.5 / 8, help="the edge near the contact (default a/8)")
    parser.add_argument("--width", type=float, default=1000.0, help="W/a (default 1000)")
    parser.add_argument("--depth", type=float, default=None, help="D/a (default W/a)")
    parser.add_argument("--fine", type=float, default=1.5, help="size of the fine core / a (default 1.5)")
    parser.add_argument("--growth", type=float, default=0.1, help="edge growth per unit distance (default 0.1)")
    parser.add_argument("--unstructured", action="store_true", help="no structured core")
    parser.add_argument("--out", default="hertz_quarter.msh")
    args = parser.parse_args()
    build(Path(args.out), args.a, args.h0, args.width, args.depth, args.fine, args.growth,
          structured=not args.unstructured)
