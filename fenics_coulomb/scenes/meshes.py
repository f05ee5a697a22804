"""A body's mesh from a gmsh file: read on rank 0, distributed by the deterministic partitioner
(:mod:`fenics_coulomb.scenes.partition`: the same file on the same ranks gives the same partition and the same
bits), with its facet and cell tags; a file that is not a readable gmsh mesh is an InputError naming it, and so is
one whose physical surfaces hold elements that are not faces of its volume elements (DOLFINx would drop them from
the facet tags without a word: a boundary condition on that surface would miss them)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx.io.gmshio
import dolfinx.mesh
import numpy as np

from fenics_coulomb.errors import check_all
from fenics_coulomb.scenes.partition import create_partitioner

__all__ = ["read_gmsh", "read_gmsh_tags", "surface_elements_off_volume", "unmatched_surface_elements"]


def _number_nodes_continuously(gmsh: object) -> None:
    """Renumber the nodes (and elements) 1..n when the file's numbers have gaps, which MSH 2.2 and 4 allow and
    DOLFINx's reader does not (it assumes the tags 1..n); a file numbered 1..n is left as it is (bit for bit)."""
    tags = np.asarray(gmsh.model.mesh.getNodes()[0], dtype=np.int64)  # type: ignore[attr-defined]
    if tags.size and (tags.min() != 1 or tags.max() != tags.size or np.unique(tags).size != tags.size):
        gmsh.model.mesh.renumberNodes()  # type: ignore[attr-defined]
        gmsh.model.mesh.renumberElements()  # type: ignore[attr-defined]


#: gmsh's surface element types (3-node and 6-node triangles; 4-, 9- and 8-node quadrangles) → their corner count.
_SURFACE_CORNERS = {2: 3, 9: 3, 3: 4, 10: 4, 16: 4}


def _rows(nodes: np.ndarray, corners: int) -> np.ndarray:
    """Each element's corner node tags, sorted, as one opaque value per element (for set membership)."""
    rows = np.ascontiguousarray(np.sort(np.asarray(nodes, dtype=np.uint64).reshape(-1, corners), axis=1))
    return rows.view(np.dtype((np.void, rows.dtype.itemsize * corners))).ravel()


def _volume_faces(gmsh: object) -> dict[int, np.ndarray]:
    """The faces of the current gmsh model's volume elements, per corner count (3, 4), as :func:`_rows`."""
    mesh = gmsh.model.mesh  # type: ignore[attr-defined]
    faces: dict[int, list[np.ndarray]] = {3: [], 4: []}
    for etype in mesh.getElementTypes(3):
        for corners in (3, 4):  # gmsh's face types: 3 triangles, 4 quadrangles
            try:
                nodes = mesh.getElementFaceNodes(etype, corners, primary=True)
            except Exception:  # noqa: BLE001 -- gmsh raises a plain Exception for a face type the element lacks
                continue
            if len(nodes):
                faces[corners].append(_rows(nodes, corners))
    return {k: np.concatenate(v) if v else np.zeros(0, dtype=np.void) for k, v in faces.items()}


def surface_elements_off_volume(gmsh: object, surfaces: list[int] | None = None) -> dict[int, tuple[int, int]]:
    """Per surface entity of the current gmsh model (``surfaces``, default all): (the number of its elements that
    are not faces of a volume element, its number of elements); only the entities with such elements."""
    mesh = gmsh.model.mesh  # type: ignore[attr-defined]
    known = _volume_faces(gmsh)
    if surfaces is None:
        surfaces = [t for _, t in gmsh.model.getEntities(2)]  # type: ignore[attr-defined]
    # every entity's rows tested at once per corner count: each np.isin sorts the volume's faces again (8 calls of
    # 0.025 s each on a 1.4 MB mesh of 2 bodies)
    rows: dict[int, list[np.ndarray]] = {3: [], 4: []}
    owner: dict[int, list[np.ndarray]] = {3: [], 4: []}
    for k, entity in enumerate(surfaces):
        types, _, nodes = mesh.getElements(2, entity)
        for etype, enodes in zip(types, nodes, strict=True):
            corners = _SURFACE_CORNERS.get(int(etype))
            if corners is None:
                continue
            width = mesh.getElementProperties(etype)[3]
            rows[corners].append(_rows(np.asarray(enodes).reshape(-1, width)[:, :corners], corners))
            owner[corners].append(np.full(len(rows[corners][-1]), k, dtype=np.int64))
    total = np.zeros(len(surfaces), dtype=np.int64)
    bad = np.zeros(len(surfaces), dtype=np.int64)
    for corners in (3, 4):
        if not rows[corners]:
            continue
        entities = np.concatenate(owner[corners])
        total += np.bincount(entities, minlength=len(surfaces))
        outside = ~np.isin(np.concatenate(rows[corners]), known[corners])
        bad += np.bincount(entities[outside], minlength=len(surfaces))
    return {int(entity): (int(bad[k]), int(total[k])) for k, entity in enumerate(surfaces) if bad[k]}


def unmatched_surface_elements(gmsh: object) -> str:
    """'' when every element of every physical surface of the current gmsh model is a face of one of its volume
    elements, else a message naming the physical surfaces that hold others (e.g. a transfinite surface whose
    triangles' diagonals differ from those of its transfinite volume's tetrahedra), with the counts."""
    model = gmsh.model  # type: ignore[attr-defined]
    groups = model.getPhysicalGroups(2)
    entities = {tag: [int(e) for e in model.getEntitiesForPhysicalGroup(dim, tag)] for dim, tag in groups}
    off = surface_elements_off_volume(gmsh, sorted({e for v in entities.values() for e in v}))
    found = []
    for dim, tag in groups:
        bad = sum(off[e][0] for e in entities[tag] if e in off)
        if bad:
            total = sum(len(_rows_of(gmsh, e)) for e in entities[tag])
            name = model.getPhysicalName(dim, tag) or "(unnamed)"
            found.append(f"{bad} of the {total} elements of physical surface {tag} {name!r}")
    if not found:
        return ""
    return ("; ".join(found) + " are not faces of the volume's elements (the surface mesh does not match the "
            "volume mesh, e.g. a transfinite surface whose diagonals differ from its volume's): their facets "
            "would not be tagged")


def _rows_of(gmsh: object, entity: int) -> list[int]:
    """The element tags of a surface entity's triangles and quadrangles."""
    types, tags, _ = gmsh.model.mesh.getElements(2, entity)  # type: ignore[attr-defined]
    return [int(t) for ty, ts in zip(types, tags, strict=True) if int(ty) in _SURFACE_CORNERS for t in ts]


def read_gmsh(path: str | Path, comm: MPI.Comm) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """Read a gmsh .msh file on rank 0 (quietly) and distribute it; return (mesh, facet tags)."""
    msh, _, facet_tags = read_gmsh_tags(path, comm)
    return msh, facet_tags


def read_gmsh_tags(path: str | Path, comm: MPI.Comm
                   ) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """Read a gmsh .msh file on rank 0 (quietly) and distribute it; return (mesh, cell tags, facet tags). A gmsh
    session the caller has open is kept: the file is read into a model of its own, removed afterwards, and the
    caller's current model and terminal option are restored."""
    import gmsh

    path = str(path) if isinstance(path, Path) else path
    message = ""
    session: tuple[str, float] | None = None  # the caller's open session: its current model, its terminal option
    if comm.rank == 0:
        if gmsh.isInitialized():
            session = (gmsh.model.getCurrent(), gmsh.option.getNumber("General.Terminal"))
        else:
            # not interruptible: gmsh's default sets SIGINT to SIG_DFL and its finalize() does not restore the
            # previous handler (gmsh 4.13 keeps it in a local variable): Ctrl-C would kill rank 0 without the
            # launcher's message and without keeping the earlier results
            gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("fenics_coulomb_read_gmsh")
        try:
            gmsh.merge(path)
            if not gmsh.model.getEntities(3):
                message = f"mesh file {path!r} holds no volume (3D) entities"
            elif not gmsh.model.getPhysicalGroups(3):
                message = (f"mesh file {path!r} has no physical volume: name the body's volume(s) and the "
                           "boundary surfaces [boundaries] refers to as gmsh physical groups "
                           "(gmsh.model.addPhysicalGroup), and save them")
            elif len(types := [int(t) for t in gmsh.model.mesh.getElementTypes(3)]) > 1:
                names = [gmsh.model.mesh.getElementProperties(t)[0] for t in types]
                message = (f"mesh file {path!r} holds volume cells of several types ({', '.join(names)}): a DOLFINx "
                           "0.9 mesh has one cell type; mesh every volume with one type (all tetrahedra, or all "
                           "hexahedra)")
            else:
                _number_nodes_continuously(gmsh)
                unmatched = unmatched_surface_elements(gmsh)
                if unmatched:
                    message = f"mesh file {path!r}: {unmatched}"
        except Exception as err:  # gmsh raises plain Exceptions
            message = f"mesh file {path!r} cannot be read by gmsh: {err}"
        if message:
            _end_gmsh(gmsh, session)
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)
    # The deterministic partitioner, from the coordinates gmsh holds on rank 0 (the rows model_to_mesh gives
    # create_mesh): the same file on the same ranks gives the same partition in every run.
    x = dolfinx.io.gmshio.extract_geometry(gmsh.model) if comm.rank == 0 else np.zeros((0, 3))
    msh, cell_tags, facet_tags = dolfinx.io.gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0,
                                                                 gdim=3, partitioner=create_partitioner(comm, x))
    if comm.rank == 0:
        _end_gmsh(gmsh, session)
    return msh, cell_tags, facet_tags


def _end_gmsh(gmsh: Any, session: tuple[str, float] | None) -> None:
    """Finalize the gmsh session :func:`read_gmsh_tags` opened, or give the caller's back as it was."""
    if session is None:
        gmsh.finalize()
        return
    gmsh.model.remove()
    gmsh.model.setCurrent(session[0])
    gmsh.option.setNumber("General.Terminal", session[1])

