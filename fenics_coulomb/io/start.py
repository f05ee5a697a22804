"""A start file (``--start FILE.xdmf``, a scene's ``start``): the one validator and the reader.

A start is an earlier run's ``solution.xdmf``; :func:`check_start_file` reads its XML and HDF5 metadata on
rank 0 and checks every dataset for non-finite values in blocks (one line naming the node), before any
collective call; :func:`start_function` reads it onto the problem's space."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import numpy as np

from fenics_coulomb.errors import check_all
from fenics_coulomb.model.dof_values import set_owned_values

__all__ = ["MAX_XDMF_BYTES", "START_CHECK_ROWS", "start_function", "check_start_file"]


#: Largest scene-independent start file read for validation (an XDMF is a few kB of XML).
MAX_XDMF_BYTES = 16 * 2**20


#: A start file's datasets are checked for non-finite values in blocks of this many rows.
START_CHECK_ROWS = 1 << 20


def start_function(start: str, V: dolfinx.fem.FunctionSpace) -> dolfinx.fem.Function | None:
    """The start ũ⁽⁰⁾ of a start setting: None for "auto" and "zero" (the problem's rule,
    :attr:`~fenics_coulomb.settings.SolverSettings.start`), zero for "undeformed", or an earlier run's solution
    (checked beforehand by :func:`check_start_file`), interpolated onto V."""
    if start in ("auto", "zero"):
        return None
    u0 = dolfinx.fem.Function(V)
    if start == "undeformed":
        return u0
    from fenics_coulomb.io.xdmf_read import read_displacement

    return set_owned_values(u0, read_displacement(Path(start), V))


def check_start_file(comm: MPI.Comm, start: str) -> None:
    """Check on rank 0 that ``start`` is the solution.xdmf of an earlier run: readable XML naming a 3D mesh
    (hexahedra or tetrahedra) with XYZ geometry and a 3-vector point field ``displacement`` whose HDF5
    datasets exist with matching shapes. InputError on every rank otherwise (collective)."""
    message = ""
    if comm.rank == 0:
        try:
            message = _start_file_problem(Path(start).with_suffix(".xdmf"))
        except Exception as err:  # any failure to read a foreign file is a bad input, reported in one line
            message = f"cannot be read ({type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''})"
        if message:
            message = f"--start {start!r}: {message}"
    message = comm.bcast(message, root=0)
    check_all(comm, not message, message)


def _start_file_problem(xdmf: Path) -> str:
    """What is wrong with ``xdmf`` as a start file ("" if nothing)."""
    import h5py

    if not xdmf.is_file():
        return "no such file"
    if xdmf.stat().st_size > MAX_XDMF_BYTES:
        return "too large for an XDMF file of fenics-coulomb"
    try:
        root = ET.fromstring(xdmf.read_bytes())
    except ET.ParseError as err:
        return f"not an XDMF (XML) file ({err})"
    strip = {el: el.tag.rsplit("}", 1)[-1] for el in root.iter()}
    topologies = [el for el, tag in strip.items() if tag == "Topology"]
    geometries = [el for el, tag in strip.items() if tag == "Geometry"]
    if not topologies or not geometries:
        return "no mesh (Topology/Geometry) in the XDMF file"
    kinds = {(el.get("TopologyType") or el.get("Type") or "").lower() for el in topologies}
    if not kinds <= {"hexahedron", "tetrahedron"}:
        return f"the mesh has cells of type {', '.join(sorted(kinds))}, not 3D hexahedra or tetrahedra"
    if any((el.get("GeometryType") or el.get("Type") or "XYZ").upper() != "XYZ" for el in geometries):
        return "the mesh geometry is not XYZ (3D)"
    fields = [el for el, tag in strip.items() if tag == "Attribute" and el.get("Name") == "displacement"]
    if not fields:
        return "no 'displacement' field in the XDMF file"

    def dataset(element: ET.Element, what: str) -> tuple[int, ...]:
        """The shape of an element's HDF5 dataset; ValueError naming the first non-finite value in it (read in
        blocks of rows, so that a large file is not loaded at once)."""
        item = next((el for el in element.iter() if el.tag.rsplit("}", 1)[-1] == "DataItem"), None)
        if item is None or (item.get("Format") or "XML").upper() != "HDF" or not item.text:
            raise ValueError("its data are not stored in HDF5")
        file, _, name = item.text.strip().partition(":")
        path = xdmf.parent / file if not Path(file).is_absolute() else Path(file)
        with h5py.File(path, "r") as h5:
            data = h5[name]
            if not isinstance(data, h5py.Dataset):
                raise ValueError(f"{file}:{name} is not a dataset")
            rows = data.shape[0] if data.ndim else 0
            for first in range(0, rows, START_CHECK_ROWS):
                block = np.asarray(data[first:first + START_CHECK_ROWS], dtype=np.float64).reshape(-1, 3) \
                    if data.ndim == 2 and data.shape[1] == 3 else None
                if block is None:
                    break
                bad = np.flatnonzero(~np.all(np.isfinite(block), axis=1))
                if bad.size:
                    raise ValueError(f"{what} of node {first + int(bad[0])} is {block[bad[0]].tolist()}: not finite")
            return tuple(data.shape)

    try:
        points = dataset(geometries[0], "the coordinates")
        values = dataset(fields[0], "the displacement")
        for field in fields[1:]:  # a load path's later grids
            dataset(field, "the displacement")
    except ValueError as err:
        return str(err)
    except (OSError, KeyError) as err:
        return f"the HDF5 data cannot be read ({err})"
    if len(points) != 2 or points[1] != 3 or points[0] == 0:
        return f"the mesh geometry has shape {points}, not (nodes, 3)"
    if len(values) != 2 or values[1] != 3 or values[0] != points[0]:
        return f"'displacement' has shape {values}, not ({points[0]}, 3) (a 3-vector per mesh node)"
    return ""

