"""Geometry of the contact scenes: the cuboid of the reference paper (Section 7) with a deformed bottom.

The body is

    Ω(d) = {(x1, x2, x3) | (x1, x2) ∈ (0, 2) × (0, 1), d(x1, x2) < x3 < 1},

meshed with n_x1 × n_x2 × n_x3 trilinear hexahedra, n_x1 = ⌈4·2^(lev/2)⌉, n_x2 = n_x3 = ⌈2·2^(lev/2)⌉.
The box mesh's vertices are moved in x3 so that the bottom follows d with uniform spacing between d and 1.
The rigid obstacle is the half-space x3 ≤ 0, so a bottom node's initial gap is its height x3 = d(x1, x2).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.scenes.partition import box_partitioner

__all__ = ["LEFT", "RIGHT", "BOTTOM", "TOP", "SIDES", "FACE_NAMES", "LENGTH", "WIDTH", "HEIGHT", "gap_d1",
           "gap_d2", "gap_d3", "GAP_PROFILES", "LOAD_CASES", "paper_tractions", "cells_per_direction",
           "expected_sizes", "Body", "box_coordinates", "resolve_gap", "create_cuboid"]

GapFunction = Callable[[npt.NDArray[np.float64], npt.NDArray[np.float64]], npt.NDArray[np.float64]]

#: Facet tags of the cuboid's faces.
LEFT, RIGHT, BOTTOM, TOP, SIDES = 1, 2, 3, 4, 5
FACE_NAMES: dict[str, int] = {"left": LEFT, "right": RIGHT, "bottom": BOTTOM, "top": TOP, "sides": SIDES}

#: Cuboid extent (0, 2) × (0, 1) × (0, 1).
LENGTH, WIDTH, HEIGHT = 2.0, 1.0, 1.0


def gap_d1(x1: npt.NDArray[np.float64], x2: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Flat bottom: d1 = 0.01."""
    return np.full_like(np.asarray(x1, dtype=np.float64), 0.01)


def gap_d2(x1: npt.NDArray[np.float64], x2: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Cone-shaped bottom: d2 = max(0.01 − 0.015·√(0.5(x1−1)² + 2(x2−0.5)²), 0.0025)."""
    return np.maximum(0.01 - 0.015 * np.sqrt(0.5 * (x1 - 1.0) ** 2 + 2.0 * (x2 - 0.5) ** 2), 0.0025)


def gap_d3(x1: npt.NDArray[np.float64], x2: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Wavy bottom: d3 = 0.01 + 0.005·(sin(2πx1) + cos(2πx2))."""
    return 0.01 + 0.005 * (np.sin(2.0 * np.pi * x1) + np.cos(2.0 * np.pi * x2))


GAP_PROFILES: dict[str, GapFunction] = {"d1": gap_d1, "d2": gap_d2, "d3": gap_d3}

#: Surface tractions (GPa) of the paper's load cases: P_T on the top face, P_R on the right face.
LOAD_CASES: dict[str, dict[int, tuple[float, float, float]]] = {
    "L1": {TOP: (0.0, 0.0, -1.0), RIGHT: (-0.2, 0.0, 0.0)},
    "L2": {TOP: (0.0, 0.0, -1.0), RIGHT: (-0.17, -0.1, 0.0)},
}


def paper_tractions(load: str, scale: float = 1.0) -> dict[str, tuple[float, float, float]]:
    """The tractions (GPa) of a Section 7 load case keyed by boundary name, times ``scale``."""
    if load not in LOAD_CASES:
        raise InputError(f"load case {load!r}: choose one of {sorted(LOAD_CASES)}")
    names = {tag: name for name, tag in FACE_NAMES.items()}
    return {names[tag]: (scale * v[0], scale * v[1], scale * v[2]) for tag, v in LOAD_CASES[load].items()}


def cells_per_direction(lev: int) -> tuple[int, int, int]:
    """Return (n_x1, n_x2, n_x3) = (⌈4·2^(lev/2)⌉, ⌈2·2^(lev/2)⌉, ⌈2·2^(lev/2)⌉)."""
    if isinstance(lev, bool) or not isinstance(lev, int | np.integer) or lev < 0:
        raise InputError(f"lev must be an integer >= 0, got {lev!r}")
    s = 2.0 ** (lev / 2)
    # Guard the ceiling against round-off for even levels, where 4·2^(lev/2) is an exact integer.
    n1 = math.ceil(4.0 * s - 1e-9)
    n2 = math.ceil(2.0 * s - 1e-9)
    return n1, n2, n2


def expected_sizes(lev: int) -> tuple[int, int]:
    """Return (p, n): contact nodes and unknowns after the Dirichlet DOFs, as in Section 7."""
    n1, n2, n3 = cells_per_direction(lev)
    return n1 * (n2 + 1), 3 * n1 * (n2 + 1) * (n3 + 1)


@dataclass
class Body:
    """A meshed elastic body with tagged boundary facets.

    Attributes:
        mesh: The DOLFINx mesh (vertices already at their reference positions).
        facet_tags: Facet markers; ``boundaries`` maps names to their values.
        boundaries: Named boundary tags, e.g. ``{"left": 1, ...}``.
        dirichlet: Names of the clamped boundaries (u = 0).
        contact: Names of the boundaries that may touch the obstacle x3 <= 0.
        description: Human-readable description for logs and summaries.
        cell_tags: Cell markers (the volumes of a gmsh mesh), or None.
    """

    mesh: dolfinx.mesh.Mesh
    facet_tags: dolfinx.mesh.MeshTags
    boundaries: dict[str, int]
    dirichlet: list[str] = field(default_factory=lambda: ["left"])
    contact: list[str] = field(default_factory=lambda: ["bottom"])
    description: str = ""
    #: Cell markers of a mesh with several volumes (bodies), or None.
    cell_tags: dolfinx.mesh.MeshTags | None = None

    def tag(self, name: str) -> int:
        """Return the facet tag of a named boundary."""
        try:
            return self.boundaries[name]
        except KeyError:
            raise InputError(f"unknown boundary {name!r}; the body has {sorted(self.boundaries)}") from None


def box_coordinates(x: npt.NDArray[np.float64], gap: str | GapFunction) -> npt.NDArray[np.float64]:
    """The points x of a cuboid Ω(d) mapped back to the box [0, LENGTH]×[0, WIDTH]×[0, HEIGHT] they came from.

    :func:`create_cuboid` moves every vertex of the box grid in x3 only, x3 ← d + t·(HEIGHT − d) with
    d = d(x1, x2), so t = (x3 − d)/(HEIGHT − d): the inverse of that map, shape (m, 3) → (m, 3).
    """
    x = np.asarray(x, dtype=np.float64)
    d = np.broadcast_to(np.asarray(resolve_gap(gap)(x[:, 0], x[:, 1]), dtype=np.float64), x[:, 0].shape)
    box = x.copy()
    box[:, 2] = (x[:, 2] - d) / (HEIGHT - d)
    return box


def resolve_gap(gap: str | GapFunction) -> GapFunction:
    """Return the gap profile for a name ('d1', 'd2', 'd3') or a callable d(x1, x2)."""
    if callable(gap):
        return gap
    try:
        return GAP_PROFILES[gap]
    except KeyError:
        raise InputError(f"unknown gap profile {gap!r}; choose one of {sorted(GAP_PROFILES)}") from None


def create_cuboid(
    comm: MPI.Comm,
    lev: int,
    gap: str | GapFunction = "d1",
    ghost_mode: dolfinx.mesh.GhostMode = dolfinx.mesh.GhostMode.shared_facet,
) -> Body:
    """Create the paper's cuboid body Ω(d) at discretization level ``lev``.

    Args:
        comm: MPI communicator.
        lev: Discretization level (>= 0).
        gap: Gap profile name or callable ``d(x1, x2)`` with values in [0, 1).
        ghost_mode: Ghosting of the distributed mesh.

    Returns:
        The body with facets tagged left/right/bottom/top/sides.
    """
    # Validate before the first collective call (create_box): every rank sees the same arguments.
    n = cells_per_direction(lev)
    d = resolve_gap(gap)
    corners = [np.array([0.0, 0.0, 0.0]), np.array([LENGTH, WIDTH, HEIGHT])]
    # The deterministic partitioner: the same level on the same ranks gives the same partition, and so the
    # same bits, in every run (DOLFINx's default, PT-Scotch, does not repeat).
    msh = dolfinx.mesh.create_box(
        comm,
        corners,
        list(n),
        dolfinx.mesh.CellType.hexahedron,
        ghost_mode=ghost_mode,
        partitioner=box_partitioner(corners, n, ghost_mode),
    )
    tdim = msh.topology.dim
    fdim = tdim - 1
    msh.topology.create_connectivity(fdim, tdim)

    # Tag the faces on the undeformed box, where they are coordinate planes.
    tol = 1e-10
    markers = [
        (LEFT, lambda x: np.isclose(x[0], 0.0, atol=tol)),
        (RIGHT, lambda x: np.isclose(x[0], LENGTH, atol=tol)),
        (BOTTOM, lambda x: np.isclose(x[2], 0.0, atol=tol)),
        (TOP, lambda x: np.isclose(x[2], HEIGHT, atol=tol)),
        (SIDES, lambda x: np.isclose(x[1], 0.0, atol=tol) | np.isclose(x[1], WIDTH, atol=tol)),
    ]
    indices, values = [], []
    for value, marker in markers:
        facets = dolfinx.mesh.locate_entities_boundary(msh, fdim, marker)
        indices.append(facets)
        values.append(np.full_like(facets, value))
    facet_indices = np.hstack(indices).astype(np.int32)
    facet_values = np.hstack(values).astype(np.int32)
    order = np.argsort(facet_indices)
    facet_tags = dolfinx.mesh.meshtags(msh, fdim, facet_indices[order], facet_values[order])

    # Move the vertices in x3: x3 ← d(x1, x2) + x3·(1 − d(x1, x2)). Every rank moves its own and its
    # ghost nodes with the same formula, so the geometry stays consistent across ranks.
    x = msh.geometry.x
    message = ""
    try:
        dval = np.broadcast_to(np.asarray(d(x[:, 0], x[:, 1]), dtype=np.float64), x[:, 0].shape).copy()
    except Exception as err:  # a user callable may fail in any way; report it on every rank
        dval = np.zeros_like(x[:, 0])
        message = f"the gap profile failed: {err}"
    bad = ~np.isfinite(dval) | (dval < 0.0) | (dval >= HEIGHT)
    if not message and np.any(bad):
        message = f"gap profile value {dval[bad][0]!r} outside [0, {HEIGHT}) (the body would invert)"
    check_all(comm, not message, message)
    # create_box leaves round-off (~1e-17) on the coordinate planes: snap the box's x3 to [0, 1] first, so
    # that the bottom sits exactly at d (a zero gap stays zero, not slightly negative).
    t = np.clip(x[:, 2], 0.0, HEIGHT)
    t[np.abs(t) < 1e-12] = 0.0
    x[:, 2] = dval + t * (HEIGHT - dval)

    name = gap if isinstance(gap, str) else getattr(gap, "__name__", "custom")
    return Body(
        mesh=msh,
        facet_tags=facet_tags,
        boundaries=dict(FACE_NAMES),
        dirichlet=["left"],
        contact=["bottom"],
        description=f"cuboid (0,2)x(0,1)x(0,1), lev={lev} ({n[0]}x{n[1]}x{n[2]} hexahedra), gap {name}",
    )
