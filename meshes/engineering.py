"""Bodies meshed the way engineers mesh them (issue 27): graded toward the contact, unoptimized, thin.

Each function writes a gmsh 4.1 ``.msh`` file of linear elements whose physical groups are the facet tags of
:data:`BLOCK_TAGS` (blocks and plates) and returns a small record of the mesh (nodes, cells, smallest and
largest edge, smallest scaled Jacobian). Used by ``benchmarks/robustness.py`` and its fast subset in the
tests; run inside the environment, e.g.::

    container/run python3 meshes/engineering.py graded-tet out/block.msh --h0 0.0625 --growth 1.3

- :func:`graded_tetrahedra`: the block [0, 1]² × [0, H] in tetrahedra whose edge length grows from ``h0`` at
  the contact target (the top centre point, or the line x₂ = ½ on the top face) by ``growth − 1`` per unit
  distance beyond a ball (or cylinder) of radius ``refined`` meshed at ``h0`` (gmsh's size callback, Delaunay,
  optimized unless ``optimize=False``: gmsh's raw mesh keeps its slivers).
- :func:`graded_hexahedra`: the same block in hexahedra graded toward the top centre by the power map
  x = ½ + ½ sign(ξ)|ξ|ᵖ (the same for x₂) and x₃ = H(1 − (1 − ζ)ᵖ), a structured mesh written node by node.
- :func:`thin_plate`: the plate [0, 1]² × [z₀, z₀ + t] in tetrahedra of edge ``size`` (two to three layers).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import gmsh
import numpy as np

#: Facet tags of the blocks and plates (gmsh physical surface groups).
BLOCK_TAGS = {"bottom": 1, "top": 2, "sides": 3}

__all__ = ["BLOCK_TAGS", "MeshInfo", "graded_tetrahedra", "graded_hexahedra", "thin_plate"]


@dataclass
class MeshInfo:
    """What a generated mesh is: node and cell counts, edge lengths, the worst element.

    Attributes:
        path: The written file.
        nodes: Number of mesh nodes (3 unknowns each before boundary conditions).
        cells: Number of volume cells.
        min_edge: Shortest edge.
        max_edge: Longest edge.
        min_quality: Smallest scaled Jacobian (gmsh's minSICN for tetrahedra, minSJ for hexahedra): 1 for a
            regular element, near 0 for a sliver.
    """

    path: Path
    nodes: int
    cells: int
    min_edge: float
    max_edge: float
    min_quality: float


def _start(name: str) -> None:
    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(name)


def _info(path: Path, cell_type: int, quality: str) -> MeshInfo:
    tags, nodes = gmsh.model.mesh.getElementsByType(cell_type)
    coords = gmsh.model.mesh.getNodes()[1].reshape(-1, 3)
    node_tags = gmsh.model.mesh.getNodes()[0]
    index = np.empty(int(node_tags.max()) + 1, dtype=np.int64)
    index[node_tags.astype(np.int64)] = np.arange(node_tags.size)
    cells = index[nodes.astype(np.int64)].reshape(tags.size, -1)
    pairs = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)] if cells.shape[1] == 4 else \
        [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
    lengths = np.concatenate([np.linalg.norm(coords[cells[:, i]] - coords[cells[:, j]], axis=1) for i, j in pairs])
    q = gmsh.model.mesh.getElementQualities(tags, quality)
    return MeshInfo(path, int(node_tags.size), int(tags.size), float(lengths.min()), float(lengths.max()),
                    float(np.min(q)))


def _tag_block_faces(volume: int, height: float) -> None:
    groups: dict[str, list[int]] = {name: [] for name in BLOCK_TAGS}
    for _, tag in gmsh.model.getBoundary([(3, volume)], oriented=False):
        _, _, z = gmsh.model.occ.getCenterOfMass(2, tag)
        groups["bottom" if abs(z) < 1e-9 else "top" if abs(z - height) < 1e-9 else "sides"].append(tag)
    gmsh.model.addPhysicalGroup(3, [volume], 1, name="body")
    for name, tags in groups.items():
        gmsh.model.addPhysicalGroup(2, tags, BLOCK_TAGS[name], name=name)


def graded_tetrahedra(path: Path, h0: float, growth: float = 1.3, toward: str = "point", height: float = 0.5,
                      h_max: float = 0.25, optimize: bool = True, refined: float = 0.0) -> MeshInfo:
    """The block [0, 1]² × [0, height] in tetrahedra graded toward the top centre point or the line x₂ = ½.

    Args:
        path: Output ``.msh`` file.
        h0: Edge length at the target.
        growth: The edge length grows by ``(growth − 1) · distance`` beyond ``refined`` from the target (1.3:
            each element about 30 % larger than its neighbour toward the target).
        toward: ``"point"`` (½, ½, height) — a sphere's contact — or ``"line"`` x₂ = ½, x₃ = height — a
            cylinder's along x₁.
        height: Block height H.
        h_max: Largest edge length.
        optimize: gmsh's tetrahedral optimization; False keeps the raw Delaunay mesh with its slivers.
        refined: Radius around the target meshed at ``h0`` (the contact zone and a margin).
    """
    if toward not in ("point", "line"):
        raise ValueError(f"toward = {toward!r}: 'point' or 'line'")
    _start("graded_tetrahedra")
    try:
        occ = gmsh.model.occ
        box = occ.addBox(0.0, 0.0, 0.0, 1.0, 1.0, height)
        occ.synchronize()
        _tag_block_faces(box, height)

        def size(dim: int, tag: int, x: float, y: float, z: float, lc: float) -> float:
            d = math.hypot(y - 0.5, z - height) if toward == "line" else math.dist((x, y, z), (0.5, 0.5, height))
            return min(h_max, h0 + (growth - 1.0) * max(0.0, d - refined))

        gmsh.model.mesh.setSizeCallback(size)
        for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
            gmsh.option.setNumber(option, 0)
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)
        gmsh.option.setNumber("Mesh.Optimize", 1 if optimize else 0)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
        return _info(Path(path), 4, "minSICN")
    finally:
        gmsh.finalize()


def graded_hexahedra(path: Path, n: int, power: float = 2.0, height: float = 0.5) -> MeshInfo:
    """The block [0, 1]² × [0, height] in 2n × 2n × n hexahedra graded toward the top centre (see module doc).

    Args:
        path: Output ``.msh`` file.
        n: Cells across the height (2n across the width).
        power: Grading exponent p (1: uniform; the ratio of the largest to the smallest cell grows like nᵖ⁻¹).
        height: Block height H.
    """
    xi = np.linspace(-1.0, 1.0, 2 * n + 1)
    x = 0.5 + 0.5 * np.sign(xi) * np.abs(xi) ** power
    z = height * (1.0 - (1.0 - np.linspace(0.0, 1.0, n + 1)) ** power)
    nx, nz = x.size, z.size
    X, Y, Z = np.meshgrid(x, x, z, indexing="ij")
    coords = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    node = np.arange(coords.shape[0]).reshape(nx, nx, nz) + 1  # gmsh node tags start at 1
    i, j, k = np.meshgrid(np.arange(nx - 1), np.arange(nx - 1), np.arange(nz - 1), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    hexes = np.column_stack([node[i, j, k], node[i + 1, j, k], node[i + 1, j + 1, k], node[i, j + 1, k],
                             node[i, j, k + 1], node[i + 1, j, k + 1], node[i + 1, j + 1, k + 1],
                             node[i, j + 1, k + 1]])

    def face(axis: int, index: int) -> np.ndarray:
        """Quadrilaterals of the boundary face where coordinate ``axis`` has grid index ``index``."""
        grid = np.moveaxis(node, axis, 0)[index]
        a, b = np.meshgrid(np.arange(grid.shape[0] - 1), np.arange(grid.shape[1] - 1), indexing="ij")
        a, b = a.ravel(), b.ravel()
        return np.column_stack([grid[a, b], grid[a + 1, b], grid[a + 1, b + 1], grid[a, b + 1]])

    faces = {"bottom": [face(2, 0)], "top": [face(2, nz - 1)],
             "sides": [face(0, 0), face(0, nx - 1), face(1, 0), face(1, nx - 1)]}
    _start("graded_hexahedra")
    try:
        volume = gmsh.model.addDiscreteEntity(3)
        gmsh.model.mesh.addNodes(3, volume, node.ravel().tolist(), coords.ravel().tolist())
        gmsh.model.mesh.addElementsByType(volume, 5, [], hexes.ravel().tolist())
        gmsh.model.addPhysicalGroup(3, [volume], 1, name="body")
        for name, quads in faces.items():
            surface = gmsh.model.addDiscreteEntity(2)
            gmsh.model.mesh.addElementsByType(surface, 3, [], np.concatenate(quads).ravel().tolist())
            gmsh.model.addPhysicalGroup(2, [surface], BLOCK_TAGS[name], name=name)
        gmsh.write(str(path))
        return _info(Path(path), 5, "minSJ")
    finally:
        gmsh.finalize()


def thin_plate(path: Path, thickness: float, size: float, z0: float = 0.0) -> MeshInfo:
    """The plate [0, 1]² × [z0, z0 + thickness] in tetrahedra of edge ``size`` (tags bottom, top, sides)."""
    _start("thin_plate")
    try:
        box = gmsh.model.occ.addBox(0.0, 0.0, z0, 1.0, 1.0, thickness)
        gmsh.model.occ.synchronize()
        groups: dict[str, list[int]] = {name: [] for name in BLOCK_TAGS}
        for _, tag in gmsh.model.getBoundary([(3, box)], oriented=False):
            _, _, z = gmsh.model.occ.getCenterOfMass(2, tag)
            groups["bottom" if abs(z - z0) < 1e-9 else "top" if abs(z - z0 - thickness) < 1e-9 else "sides"].append(
                tag)
        gmsh.model.addPhysicalGroup(3, [box], 1, name="body")
        for name, tags in groups.items():
            gmsh.model.addPhysicalGroup(2, tags, BLOCK_TAGS[name], name=name)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", size)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
        return _info(Path(path), 4, "minSICN")
    finally:
        gmsh.finalize()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kind", choices=["graded-tet", "graded-hex", "plate"])
    parser.add_argument("path", type=Path)
    parser.add_argument("--h0", type=float, default=1 / 16)
    parser.add_argument("--growth", type=float, default=1.3)
    parser.add_argument("--toward", default="point")
    parser.add_argument("--raw", action="store_true", help="no gmsh optimization (slivers)")
    parser.add_argument("--n", type=int, default=12)
    parser.add_argument("--power", type=float, default=2.0)
    parser.add_argument("--thickness", type=float, default=0.05)
    args = parser.parse_args(argv)
    if args.kind == "graded-tet":
        info = graded_tetrahedra(args.path, args.h0, args.growth, args.toward, optimize=not args.raw)
    elif args.kind == "graded-hex":
        info = graded_hexahedra(args.path, args.n, args.power)
    else:
        info = thin_plate(args.path, args.thickness, args.h0)
    print(info)


if __name__ == "__main__":
    main()
