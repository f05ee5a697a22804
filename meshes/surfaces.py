"""Triangulated surfaces as STL files for rigid surface obstacles (``[[obstacle]] type = "surface"``).

``rectangle`` (a plane patch), ``icosphere`` (a sphere: the icosahedron subdivided ``level`` times, vertices on
the sphere) and ``cylinder`` (a closed prism around an axis), each with the triangles' normals pointing OUT of
the solid (``side = "outward"``), written as ASCII or binary STL::

    container/run python3 meshes/surfaces.py icosphere out/ball.stl --radius 0.5 --center 1 0.5 1.5 --level 4
    container/run python3 meshes/surfaces.py cylinder meshes/roller.stl --radius 0.5 --center 0.6 -0.25 1.5 \
        --length 1.5 --segments 360 --binary
"""

from __future__ import annotations

import argparse
import struct
from pathlib import Path

import numpy as np

__all__ = ["cylinder", "icosphere", "rectangle", "write_stl"]


def write_stl(path: Path, triangles: np.ndarray, binary: bool = False) -> Path:
    """Write triangles (k, 3, 3) as STL (normals from the vertex order, right-hand rule)."""
    X = np.asarray(triangles, dtype=np.float64)
    n = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    path = Path(path)
    if binary:
        with open(path, "wb") as f:
            f.write(b"fenics-coulomb surface".ljust(80, b" "))
            f.write(struct.pack("<I", X.shape[0]))
            for normal, tri in zip(n, X, strict=True):
                f.write(struct.pack("<12fH", *normal, *tri.ravel(), 0))
    else:
        lines = ["solid surface"]
        for normal, tri in zip(n, X, strict=True):
            lines.append(f"  facet normal {normal[0]:.17g} {normal[1]:.17g} {normal[2]:.17g}")
            lines.append("    outer loop")
            lines += [f"      vertex {v[0]:.17g} {v[1]:.17g} {v[2]:.17g}" for v in tri]
            lines += ["    endloop", "  endfacet"]
        lines.append("endsolid surface")
        path.write_text("\n".join(lines) + "\n")
    return path


def rectangle(lo: tuple[float, float], hi: tuple[float, float], z: float = 0.0, n: int = 1) -> np.ndarray:
    """The plane patch [lo, hi] at height z in 2 n² triangles, normals +e3 (the solid below)."""
    xs, ys = np.linspace(lo[0], hi[0], n + 1), np.linspace(lo[1], hi[1], n + 1)
    tris = []
    for i in range(n):
        for j in range(n):
            a, b = (xs[i], ys[j], z), (xs[i + 1], ys[j], z)
            c, d = (xs[i + 1], ys[j + 1], z), (xs[i], ys[j + 1], z)
            tris += [(a, b, c), (a, c, d)]
    return np.asarray(tris, dtype=np.float64)


def icosphere(radius: float = 1.0, center: tuple[float, float, float] = (0.0, 0.0, 0.0), level: int = 3
              ) -> np.ndarray:
    """The sphere as an icosahedron subdivided ``level`` times (20·4^level triangles), normals outward."""
    t = (1.0 + 5.0**0.5) / 2.0
    v = np.array([(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                  (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)], dtype=np.float64)
    v /= np.linalg.norm(v, axis=1)[:, None]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
             (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    tris = v[np.asarray(faces)]
    for _ in range(level):
        a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
        ab, bc, ca = ((a + b) / 2, (b + c) / 2, (c + a) / 2)
        ab, bc, ca = (m / np.linalg.norm(m, axis=1)[:, None] for m in (ab, bc, ca))
        tris = np.concatenate([np.stack(s, axis=1) for s in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])
    return radius * tris + np.asarray(center, dtype=np.float64)


def cylinder(radius: float, start: tuple[float, float, float], length: float, segments: int = 64,
             axis: int = 1) -> np.ndarray:
    """A closed prism of ``segments`` sides around the line through ``start`` along coordinate ``axis``."""
    phi = np.linspace(0.0, 2 * np.pi, segments + 1)[:-1]
    other = [i for i in range(3) if i != axis]
    ring = np.zeros((segments, 3))
    ring[:, other[0]], ring[:, other[1]] = radius * np.cos(phi), radius * np.sin(phi)
    if (other[0] - axis) % 3 == 2:  # keep the right-hand rule: the ring runs counter-clockwise about +axis
        ring = ring[::-1]
    s = np.asarray(start, dtype=np.float64)
    e = np.zeros(3)
    e[axis] = length
    bottom, top = s + ring, s + e + ring
    tris = []
    for i in range(segments):
        j = (i + 1) % segments
        tris += [(bottom[i], bottom[j], top[j]), (bottom[i], top[j], top[i]),
                 (s, bottom[j], bottom[i]), (s + e, top[i], top[j])]
    return np.asarray(tris, dtype=np.float64)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kind", choices=["rectangle", "icosphere", "cylinder"])
    parser.add_argument("out", type=Path)
    parser.add_argument("--radius", type=float, default=0.5)
    parser.add_argument("--center", type=float, nargs=3, default=[0.0, 0.0, 0.0])
    parser.add_argument("--level", type=int, default=3)
    parser.add_argument("--binary", action="store_true")
    parser.add_argument("--segments", type=int, default=64, help="cylinder: sides of the prism")
    parser.add_argument("--length", type=float, default=1.0, help="cylinder: length along x2 from --center")
    args = parser.parse_args()
    if args.kind == "icosphere":
        tris = icosphere(args.radius, tuple(args.center), args.level)
    elif args.kind == "rectangle":
        tris = rectangle((-1.0, -1.0), (3.0, 2.0))
    else:
        tris = cylinder(args.radius, tuple(args.center), args.length, segments=args.segments)
    write_stl(args.out, tris, args.binary)


if __name__ == "__main__":
    main()
