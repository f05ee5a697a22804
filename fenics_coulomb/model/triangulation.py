"""A triangulated surface read from a file: the triangles of an STL file (ASCII or binary) or of a gmsh ``.msh``
surface mesh (its 3-node triangles), checked, their vertices merged — the geometry of
:class:`~fenics_coulomb.model.surface.Surface` obstacles.

Vertices: the file's vertices are merged when they coincide to 1e-12 of the bounding box's diagonal (STL
repeats them per triangle); the merged numbering (lexicographic in the coordinates) fixes the tie rule, so the
result does not depend on the file's vertex order or on the ranks.

File identity: the triangles are cached by the file's absolute path, modification time and size
(:data:`Source`, recorded on creation and kept by every moved or rotated copy), never by its name: a file rewritten
in place, or another file of the same relative name after a change of directory, is read anew, and an obstacle
keeps the geometry it was created with.

Bad input — an unreadable or empty file, a non-finite coordinate, a degenerate triangle (area below 1e-12 of
the squared diagonal), an inconsistent orientation — is an :class:`~fenics_coulomb.errors.InputError` naming
the file and the triangle (1-based, in the file's order).
"""

from __future__ import annotations

import functools
import struct
from pathlib import Path

import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs.projection import norm as _norm

__all__ = ["MERGE_TOL", "DEGENERATE_TOL", "Source", "file_source", "read_triangles"]

Array = npt.NDArray[np.float64]

#: Coincident vertices are merged to this fraction of the bounding box's diagonal.
MERGE_TOL = 1e-12
#: A triangle of area below this fraction of the squared diagonal is degenerate.
DEGENERATE_TOL = 1e-12


def _read_stl(path: Path) -> Array:
    data = path.read_bytes()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count:  # binary: 80-byte header, count, 50 bytes per triangle
            record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            return np.frombuffer(data, dtype=record, count=count, offset=84)["v"].astype(np.float64)
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError:
        raise InputError(f"surface {path}: neither a binary STL (size 84 + 50 × triangles) nor ASCII STL") from None
    if not text.lstrip().lower().startswith("solid"):
        raise InputError(f"surface {path}: an ASCII STL starts with 'solid'")
    vertices = []
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split()
        if words and words[0].lower() == "vertex":
            try:
                vertices.append([float(w) for w in words[1:4]])
            except ValueError:
                raise InputError(f"surface {path}: line {number}: a vertex needs three numbers") from None
            if len(words) != 4:
                raise InputError(f"surface {path}: line {number}: a vertex needs three numbers")
    if len(vertices) % 3:
        raise InputError(f"surface {path}: {len(vertices)} vertices are not whole triangles")
    return np.asarray(vertices, dtype=np.float64).reshape(-1, 3, 3)


def _read_msh(path: Path) -> Array:
    """The 3-node triangles of a gmsh file, read in a model of its own: a gmsh session the caller opened is left
    as it was (its current model and terminal option; finalized only when this function initialized gmsh)."""
    import gmsh

    own = not gmsh.isInitialized()
    if own:
        # not interruptible: gmsh would leave SIGINT at SIG_DFL (fenics_coulomb/scenes/meshes.py)
        gmsh.initialize(["-noenv"], readConfigFiles=False, interruptible=False)
    terminal = gmsh.option.getNumber("General.Terminal")
    previous = gmsh.model.getCurrent() if not own else ""
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(f"fenics_coulomb surface {path}")
        try:
            gmsh.merge(str(path))
        except Exception as err:  # gmsh raises a bare Exception with its log's last line
            raise InputError(f"surface {path}: gmsh cannot read it ({err})") from None
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, nodes = gmsh.model.mesh.getElementsByType(2)  # 3-node triangles
        index = np.empty(int(tags.max(initial=0)) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(tags.size)
        x = coords.reshape(-1, 3)
        return x[index[nodes.astype(np.int64)]].reshape(-1, 3, 3)
    finally:
        if own:
            gmsh.finalize()
        else:
            gmsh.model.remove()
            if previous:
                gmsh.model.setCurrent(previous)
            gmsh.option.setNumber("General.Terminal", terminal)


#: A surface file as read: (absolute path, modification time in ns, size in bytes). The triangles are cached by it,
#: so a file rewritten in place, or another file of the same relative name after a change of directory, is read
#: anew, and an obstacle keeps the geometry it was created with.
Source = tuple[str, int, int]


def file_source(file: str) -> Source:
    """The :data:`Source` of a surface file now (InputError when there is no such file)."""
    path = Path(file)
    if not path.is_file():
        raise InputError(f"surface {file}: no such file")
    stat = path.stat()
    return str(path.resolve()), int(stat.st_mtime_ns), int(stat.st_size)


def read_triangles(file: str, source: Source | None = None) -> tuple[Array, npt.NDArray[np.int64]]:
    """The checked triangles of a surface file: (vertex coordinates (k, 3, 3), merged vertex numbers (k, 3)).

    Args:
        file: The file's name as given (in messages).
        source: The file as read earlier (:func:`file_source`); None for the file as it is now.

    Raises:
        InputError: Unreadable, empty, non-finite, degenerate or inconsistently oriented (see the module doc), or
            changed on disk since ``source`` and no longer cached.
    """
    return _read_triangles(file, file_source(file) if source is None else source)


@functools.lru_cache(maxsize=16)
def _read_triangles(file: str, source: Source) -> tuple[Array, npt.NDArray[np.int64]]:
    if file_source(source[0]) != source:
        raise InputError(f"surface {file}: the file changed on disk after the obstacle was created from it")
    path = Path(source[0])
    suffix = Path(file).suffix.lower()
    if suffix == ".stl":
        X = _read_stl(path)
    elif suffix == ".msh":
        X = _read_msh(path)
    else:
        raise InputError(f"surface {file}: give an .stl (ASCII or binary) or a gmsh .msh file")
    if X.shape[0] == 0:
        raise InputError(f"surface {file}: no triangles")
    bad = np.flatnonzero(~np.isfinite(X).all(axis=(1, 2)))
    if bad.size:
        raise InputError(f"surface {file}: triangle {bad[0] + 1} has a non-finite coordinate {X[bad[0]].tolist()}")
    points = X.reshape(-1, 3)
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    area = 0.5 * _norm(np.asarray(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), dtype=np.float64))
    bad = np.flatnonzero(area <= DEGENERATE_TOL * diagonal**2)
    if bad.size:
        raise InputError(f"surface {file}: triangle {bad[0] + 1} is degenerate (area {area[bad[0]]:.3g})")
    key = np.round((points - points.min(axis=0)) / (MERGE_TOL * diagonal))
    _, number = np.unique(key, axis=0, return_inverse=True)
    V = number.reshape(-1, 3).astype(np.int64)
    if np.any((V[:, 0] == V[:, 1]) | (V[:, 1] == V[:, 2]) | (V[:, 0] == V[:, 2])):
        k = int(np.flatnonzero((V[:, 0] == V[:, 1]) | (V[:, 1] == V[:, 2]) | (V[:, 0] == V[:, 2]))[0])
        raise InputError(f"surface {file}: triangle {k + 1} is degenerate (two vertices coincide)")
    # orientation: each directed edge at most once; each undirected edge in at most two triangles
    directed = np.concatenate([V[:, [0, 1]], V[:, [1, 2]], V[:, [2, 0]]])
    owner = np.tile(np.arange(V.shape[0]), 3)
    _, first, counts = np.unique(directed, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        e = directed[first[np.flatnonzero(counts > 1)[0]]]
        both = np.sort(owner[np.flatnonzero((directed == e).all(axis=1))]) + 1
        raise InputError(f"surface {file}: triangles {both[0]} and {both[1]} are oriented inconsistently (they "
                         "traverse their common edge in the same direction)")
    undirected = np.sort(directed, axis=1)
    _, first, counts = np.unique(undirected, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 2):
        raise InputError(f"surface {file}: triangle {owner[first[np.flatnonzero(counts > 2)[0]]] + 1} shares an "
                         "edge with two or more others (not a surface)")
    return X, V
