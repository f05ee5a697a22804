"""Reading a result set back: the mesh and the displacement of a ``solution.xdmf`` written by
:class:`~fenics_coulomb.io.xdmf.XDMFTimeSeries` (the last time, or a load path's step), rebuilt in parallel and
interpolated onto another space (``--start``, nested iteration across levels, a path resumed after a step)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.io.xdmf import XDMF_CELLS
from fenics_coulomb.model.dof_values import set_owned_values
from fenics_coulomb.start_rule import interpolate_displacement

__all__ = ["solution_datasets", "read_displacement", "displacement_function"]


def solution_datasets(path: Path, time: float | None = None) -> dict[str, Any]:
    """Locate the mesh and the displacement of the last time (or of time ``time``, e.g. a path's step number)
    of a ``solution.xdmf`` (no MPI).

    Returns:
        ``cell`` (DOLFINx cell name) and ``(h5 file, dataset)`` pairs for ``topology``, ``geometry`` and
        ``displacement``.

    Raises:
        ValueError: The file is not such an XDMF file or lacks a field (message names what is missing).
        OSError: A file cannot be read.
    """
    path = Path(path).with_suffix(".xdmf")
    try:
        grid = _last_grid(path, time)
    except ET.ParseError as err:
        raise ValueError(f"not an XDMF file ({err})") from err
    topology = grid.find("Topology")
    cells = {v: k for k, v in XDMF_CELLS.items()}
    kind = topology.get("TopologyType") if topology is not None else None
    if kind not in cells:
        raise ValueError(f"topology {kind!r} is not one of {', '.join(cells)}")
    displacement = [a for a in grid.findall("Attribute") if a.get("Name") == "displacement"]
    if not displacement:
        raise ValueError("no point field 'displacement'")
    information = {i.get("Name"): i.get("Value") for i in grid.findall("Information")}
    return {
        "converged": information.get("converged", "true") != "false",
        "cell": cells[kind],
        "topology": _h5_item(path, topology.find("DataItem"), "the topology"),  # type: ignore[union-attr]
        "geometry": _h5_item(path, grid.find("Geometry/DataItem"), "the geometry"),
        "displacement": _h5_item(path, displacement[0].find("DataItem"), "displacement"),
    }


def read_displacement(path: Path, V: dolfinx.fem.FunctionSpace, padding: float | None = None,
                      time: float | None = None) -> npt.NDArray[np.float64]:
    """Read ``displacement`` (the last time, or the time ``time``: a load path's step number) of an earlier
    run's solution.xdmf/.h5 and interpolate it onto V (collective).

    The old mesh is rebuilt in parallel from row blocks of the file; the meshes need not match (nested
    iteration across levels): the old field is rebuilt as a P1 function on the old mesh and interpolated
    point-wise; nodes up to ``padding`` outside the old mesh (the bottoms of two levels follow d at different
    resolutions; default: :func:`~fenics_coulomb.start_rule.interpolate_displacement`'s) take the value of the
    closest cell.

    Returns:
        The interpolated physical displacement on V's owned DOFs.
    """
    import basix.ufl
    import h5py

    comm = V.mesh.comm
    info = solution_datasets(Path(path), time)
    (tfile, tset), (gfile, gset), (ufile, uset) = info["topology"], info["geometry"], info["displacement"]
    with h5py.File(tfile, "r") as h5:
        lo, hi = _rows(comm, h5[tset].shape[0])
        vtk_cells = np.asarray(h5[tset][lo:hi], dtype=np.int64)
    with h5py.File(gfile, "r") as h5:
        lo, hi = _rows(comm, h5[gset].shape[0])
        x = np.asarray(h5[gset][lo:hi], dtype=np.float64)
    cell_type = dolfinx.mesh.to_type(info["cell"])
    perm = np.asarray(dolfinx.cpp.io.perm_vtk(cell_type, vtk_cells.shape[1]))
    cells = np.empty_like(vtk_cells)
    cells[:, perm] = vtk_cells
    domain = ufl.Mesh(basix.ufl.element("Lagrange", info["cell"], 1, shape=(3,)))
    old = dolfinx.mesh.create_mesh(comm, cells, x, domain)
    V_old = dolfinx.fem.functionspace(old, ("Lagrange", 1, (3,)))
    u_old = dolfinx.fem.Function(V_old)
    # P1 on the mesh's own (degree-1) geometry: cell-local node j is cell-local DOF j.
    nodes = old.geometry.dofmap.ravel()
    original = np.asarray(old.geometry.input_global_indices, dtype=np.int64)
    first, last = (int(original.min()), int(original.max()) + 1) if original.size else (0, 0)
    with h5py.File(ufile, "r") as h5:
        values = np.asarray(h5[uset][first:last], dtype=np.float64).reshape(-1, 3)
    u_old.x.array.reshape(-1, 3)[V_old.dofmap.list.ravel()] = values[original[nodes] - first]
    u_old.x.scatter_forward()
    return interpolate_displacement(u_old, V, padding)


def displacement_function(V: dolfinx.fem.FunctionSpace, owned: npt.NDArray[np.float64]) -> dolfinx.fem.Function:
    """A Function on V holding the owned DOF values ``owned`` (ghosts updated)."""
    return set_owned_values(dolfinx.fem.Function(V, name="displacement"), owned)


def _last_grid(path: Path, time: float | None = None) -> ET.Element:
    """The grid of the last time in an XDMF file written by :class:`XDMFTimeSeries` (or a single grid), or
    the grid of time ``time``."""
    root = ET.parse(path).getroot()
    domain = root.find("Domain")
    grid = domain.find("Grid") if domain is not None else None
    if grid is None:
        raise ValueError("no Domain/Grid")
    children = grid.findall("Grid") if grid.get("GridType") == "Collection" else [grid]
    if not children:
        raise ValueError("an empty grid collection")
    if time is None:
        return children[-1]
    for child in children:
        stamp = child.find("Time")
        if stamp is not None and float(stamp.get("Value", "nan")) == float(time):
            return child
    raise ValueError(f"no grid of time {time:g}")


def _h5_item(path: Path, item: ET.Element | None, what: str) -> tuple[Path, str]:
    """The HDF5 file and dataset of an XDMF DataItem."""
    text = item.text if item is not None else None
    if not text or not text.strip() or ":" not in text:
        raise ValueError(f"no HDF5 data item for {what}")
    file, dataset = text.strip().rsplit(":", 1)
    return path.parent / file, dataset


def _rows(comm: MPI.Comm, total: int) -> tuple[int, int]:
    """This rank's contiguous block of ``total`` rows."""
    return total * comm.rank // comm.size, total * (comm.rank + 1) // comm.size
