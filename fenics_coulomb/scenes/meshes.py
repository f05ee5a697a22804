"""A body's mesh from a gmsh file: read on rank 0, distributed by the deterministic partitioner
(:mod:`fenics_coulomb.scenes.partition`: the same file on the same ranks gives the same partition and the same
bits), with its facet and cell tags; a file that is not a readable gmsh mesh is an InputError naming it."""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.io.gmshio
import dolfinx.mesh
import numpy as np

from fenics_coulomb.errors import check_all
from fenics_coulomb.scenes.partition import create_partitioner

__all__ = ["read_gmsh", "read_gmsh_tags"]


def _number_nodes_continuously(gmsh: object) -> None:
    """Renumber the nodes (and elements) 1..n when the file's numbers have gaps, which MSH 2.2 and 4 allow and
    DOLFINx's reader does not (it assumes the tags 1..n); a file numbered 1..n is left as it is (bit for bit)."""
    tags = np.asarray(gmsh.model.mesh.getNodes()[0], dtype=np.int64)  # type: ignore[attr-defined]
    if tags.size and (tags.min() != 1 or tags.max() != tags.size or np.unique(tags).size != tags.size):
        gmsh.model.mesh.renumberNodes()  # type: ignore[attr-defined]
        gmsh.model.mesh.renumberElements()  # type: ignore[attr-defined]


def read_gmsh(path: str, comm: MPI.Comm) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags]:
    """Read a gmsh .msh file on rank 0 (quietly) and distribute it; return (mesh, facet tags)."""
    msh, _, facet_tags = read_gmsh_tags(path, comm)
    return msh, facet_tags


def read_gmsh_tags(path: str, comm: MPI.Comm
                   ) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """Read a gmsh .msh file on rank 0 (quietly) and distribute it; return (mesh, cell tags, facet tags)."""
    import gmsh

    message = ""
    if comm.rank == 0:
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.merge(path)
            if not gmsh.model.getEntities(3):
                message = f"mesh file {path!r} holds no volume (3D) entities"
            else:
                _number_nodes_continuously(gmsh)
        except Exception as err:  # gmsh raises plain Exceptions
            message = f"mesh file {path!r} cannot be read by gmsh: {err}"
        if message:
            gmsh.finalize()
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)
    # The deterministic partitioner, from the coordinates gmsh holds on rank 0 (the rows model_to_mesh gives
    # create_mesh): the same file on the same ranks gives the same partition in every run.
    x = dolfinx.io.gmshio.extract_geometry(gmsh.model) if comm.rank == 0 else np.zeros((0, 3))
    msh, cell_tags, facet_tags = dolfinx.io.gmshio.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0,
                                                                 gdim=3, partitioner=create_partitioner(comm, x))
    if comm.rank == 0:
        gmsh.finalize()
    return msh, cell_tags, facet_tags

