"""Output of a contact solve: XDMF fields for ParaView and a JSON summary.

``solution.xdmf`` + ``solution.h5`` are written by :class:`XDMFTimeSeries`: ONE grid per output time that
carries ALL point fields, so that ParaView's default reader shows one dataset on which *Warp By Vector* and
colouring by any field work directly. Fields (point data on the mesh vertices; units with E in GPa and
lengths in the mesh's unit L):

``displacement``
    Physical displacement ũ (L), vector, float64.
``contact_state``
    Categorical (int32): 0 open, 1 stick, 2 slip on contact nodes; −1 on all other nodes (see
    :data:`CONTACT_STATES`).
``contact_pressure``
    The contact pressure: the normal contact traction λ / aᵢ ≥ 0 per contact node, force per AREA (GPa), with
    λ the normal part of the nodal contact force and aᵢ the node's contact area (the lumped tributary area
    ∫ φᵢ ds over the contact boundary, the mortar D_j on a dual mortar pair's slave nodes); equal to
    ``problem.report(result).nodes.pressure``. 0 elsewhere.
``contact_force``
    The nodal contact force on the body, a Cartesian 3-vector (GPa·L²; sums to summary.json's
    ``contact_force``). 0 elsewhere.
``tangential_force``
    The tangential part of the nodal contact force per contact node (GPa·L², a Cartesian 3-vector ⊥ the
    node's obstacle normal: its t₁, t₂ components mapped back to x, y, z); it opposes the slip on sliding
    nodes. 0 elsewhere.
``contact_traction``
    The contact traction vector: the nodal contact force divided by the node's contact area aᵢ (GPa); its
    normal component is ``contact_pressure``. 0 elsewhere.
``gap``
    The linearized gap g + n·ũ on contact nodes (L, ≥ 0 at a solution); 0 elsewhere.
``contact_normal``
    The outward unit normal n of each contact node's obstacle; 0 elsewhere.
``stress``
    The Cauchy stress tensor (GPa, 9 components, row-major) of the law in the bilinear form, at the vertices by a
    lumped L2 projection of the cellwise stress (:func:`~fenics_coulomb.io.fields.stress_functions`: positive
    weights, no overshoot, a uniform stress exactly); written when the form gives the stress
    (:func:`~fenics_coulomb.io.fields.stress_from_form`).
``von_mises``
    The von Mises stress √(3/2 s : s) of ``stress`` (GPa).
``body``
    A mesh of several bodies only: the body of every vertex, 1, 2, … (int32), the connected components of the
    mesh numbered by their smallest mesh-file node index (independent of the partition); threshold on it to
    see one body, e.g. the slave surface from the master side.
``master_reaction``
    Contact pairs only (two elastic bodies, :mod:`fenics_coulomb.model.pairs.two_body`): the reaction on each master
    node, f_j = −Σ_s φ_sj f_s (GPa·L², Cartesian); 0 elsewhere. For pairs the contact fields above live on the
    slave contact nodes, ``displacement`` is the physical u = M z, ``gap`` is g + n·w with the relative
    displacement w_s = u_s − Σ_j φ_sj u_j, and ``contact_normal`` is the master's outward normal at the
    closest point.

The grid's ``units`` information item names each field's unit (:meth:`~fenics_coulomb.io.units.Units.fields`).
All fields go through :class:`XDMFTimeSeries` (:func:`write_xdmf`). HDF5 layout (one file, one mesh for the
whole series): ``/Mesh/mesh/geometry`` (N × 3 float64 vertex coordinates in the global P1 vertex numbering),
``/Mesh/mesh/topology`` (cells × vertices, int64 global vertex numbers, VTK/XDMF vertex order) and
``/Function/<field>/<k>`` (N × block size) for the k-th time. The XML uses no XInclude; every grid repeats
the (shared) geometry and topology data items.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, OutputError, check_all
from fenics_coulomb.io.fields import CONTACT_STATES, contact_functions
from fenics_coulomb.io.units import Units
from fenics_coulomb.io.results import HDF5_OVERHEAD, HDF5_OVERHEAD_PER_DATASET, _io_reason, rank0_file, room_for
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.obstacles import closest_obstacle
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scd.resolvent import OPEN

__all__ = ["MESH_GEOMETRY", "MESH_TOPOLOGY", "XDMFTimeSeries", "write_initial_grid", "write_xdmf", "write_result_grid",
           "XDMF_CELLS"]


MESH_GEOMETRY = "/Mesh/mesh/geometry"


MESH_TOPOLOGY = "/Mesh/mesh/topology"


class XDMFTimeSeries:
    """Point fields on one mesh over time as ONE XDMF file (a temporal collection of grids, each carrying all
    fields of its time) with the data in ONE HDF5 file, written in parallel.

    The mesh is written once, in the global numbering of the P1 vertices (owned vertices of each rank as one
    hyperslab, owned cells with global vertex numbers); every field is written at those vertices. ParaView's
    readers (the default for ``.xdmf``, Xdmf3ReaderS and the legacy XDMF reader) show one dataset per time.

    Example::

        with XDMFTimeSeries(Path("out/solution.xdmf"), mesh) as xdmf:
            for t, u, s in steps:
                xdmf.write(t, [u, s], dtypes={"contact_state": np.int32})

    After every :meth:`write` the ``.xdmf`` on disk is complete (it is replaced atomically on rank 0), so an
    interrupted series leaves the times written so far.
    """

    def __init__(self, path: Path | str, mesh: dolfinx.mesh.Mesh, name: str = "solution") -> None:
        """Create ``path`` (.xdmf) and ``path.with_suffix('.h5')`` and write the mesh (collective)."""
        if not isinstance(path, str | Path) or not str(path).strip() or "\0" in str(path):
            raise InputError(f"XDMFTimeSeries: path = {path!r}: give the .xdmf file's name")
        if not isinstance(mesh, dolfinx.mesh.Mesh):
            raise InputError(f"XDMFTimeSeries: mesh = {type(mesh).__name__}: give a dolfinx.mesh.Mesh")
        self.path = Path(path).with_suffix(".xdmf")
        self.h5_path = self.path.with_suffix(".h5")
        self.name = name
        self.mesh = mesh
        self.comm: MPI.Intracomm = mesh.comm
        cell = mesh.topology.cell_name()
        if cell not in XDMF_CELLS:
            raise InputError(f"XDMFTimeSeries supports {', '.join(XDMF_CELLS)} meshes, not {cell}")
        self._cell = XDMF_CELLS[cell]
        self._S = dolfinx.fem.functionspace(mesh, ("Lagrange", 1))
        imap = self._S.dofmap.index_map
        self._owned = imap.size_local
        self._offset = int(imap.local_range[0])
        self.num_vertices = int(imap.size_global)
        x = np.ascontiguousarray(self._S.tabulate_dof_coordinates()[: self._owned], dtype=np.float64)
        tdim = mesh.topology.dim
        num_cells = mesh.topology.index_map(tdim).size_local
        cell_dofs = self._S.dofmap.list[:num_cells]
        # P1 on a degree-1 geometry: cell-local DOF j sits at reference vertex j (DOLFINx order) -> VTK order
        perm = np.asarray(dolfinx.cpp.io.perm_vtk(mesh.topology.cell_type, cell_dofs.shape[1]))
        cells = imap.local_to_global(cell_dofs.ravel()).reshape(cell_dofs.shape)[:, perm].astype(np.int64)
        self.num_cells = int(self.comm.allreduce(num_cells, op=MPI.SUM))
        cell_offset = int(self.comm.exscan(num_cells, op=MPI.SUM) or 0)
        self._vertices_per_cell = int(cells.shape[1])
        if self.comm.rank == 0:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self.comm.barrier()
        _write_slabs(self.comm, self.h5_path, [(MESH_GEOMETRY, x, self.num_vertices, self._offset),
                                               (MESH_TOPOLOGY, cells, self.num_cells, cell_offset)], create=True)
        self._grids: list[ET.Element] = []

    def __enter__(self) -> XDMFTimeSeries:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Nothing is held open between writes; kept for the context-manager protocol."""

    @property
    def times(self) -> list[float]:
        """The times written so far."""
        return [float(_grid_time(g)) for g in self._grids]

    def _check(self, t: Any, named: Mapping[str, Any], dtypes: Mapping[str, npt.DTypeLike]) -> None:
        """InputError on every rank, before anything is written, for a time that is not a finite number at or after
        the last one, a field name that is empty or holds '/' (the HDF5 path), a field that is not a P1 Function on
        the writer's mesh (the mesh object itself: a mesh built alike has another vertex numbering on several ranks),
        or non-finite values stored as integers (collective)."""
        where = f"XDMFTimeSeries {self.path.name}"
        if isinstance(t, bool) or not isinstance(t, int | float | np.integer | np.floating) or not math.isfinite(t):
            raise InputError(f"{where}: t = {t!r}: give a finite number")
        if self._grids and float(t) < self.times[-1]:
            raise InputError(f"{where}: t = {float(t):g} comes before the last time written, {self.times[-1]:g}")
        message = ""
        for key, f in named.items():
            W = getattr(f, "function_space", None)
            if not isinstance(key, str) or not key or "/" in key:
                message = f"{where}: field name {key!r}: give a non-empty name without '/'"
            elif not isinstance(f, dolfinx.fem.Function) or W is None:
                message = f"{where}: field {key!r} is a {type(f).__name__}, not a dolfinx.fem.Function"
            elif W.mesh is not self.mesh and W.mesh._cpp_object is not self.mesh._cpp_object:
                message = (f"{where}: field {key!r} lives on another mesh than the series' (a mesh built alike "
                           "numbers its vertices otherwise on several ranks)")
            elif (W.dofmap.list.shape != self._S.dofmap.list.shape
                  or W.dofmap.index_map.size_global != self.num_vertices):
                message = f"{where}: field {key!r} is not a P1 (vertex) field"
            elif np.dtype(dtypes.get(key, np.float64)).kind in "iu" and not np.all(np.isfinite(f.x.array)):
                message = f"{where}: field {key!r} holds non-finite values, which an integer type cannot store"
            if message:
                break
        check_all(self.comm, not message, message)

    def _vertex_values(self, f: dolfinx.fem.Function) -> npt.NDArray[np.float64]:
        """Values of a P1 Function at this rank's owned vertices (rows in the writer's vertex order; checked by
        :meth:`_check`)."""
        W = f.function_space
        imap = self._S.dofmap.index_map
        to_block = np.empty(imap.size_local + imap.num_ghosts, dtype=np.int32)
        to_block[self._S.dofmap.list.ravel()] = W.dofmap.list.ravel()
        f.x.scatter_forward()
        return f.x.array.reshape(-1, W.dofmap.index_map_bs)[to_block[: self._owned]]

    def write(
        self,
        t: float,
        fields: Sequence[dolfinx.fem.Function] | Mapping[str, dolfinx.fem.Function],
        dtypes: Mapping[str, npt.DTypeLike] | None = None,
        name: str | None = None,
        information: Mapping[str, str] | None = None,
    ) -> None:
        """Append the grid of time ``t`` holding all ``fields`` as point data (collective).

        Args:
            t: Time (or load parameter) of this output.
            fields: P1 Functions on the writer's mesh (scalar or vector), named by ``Function.name`` or by
                the mapping's keys.
            dtypes: Stored type per field name (default float64); integer types round, e.g. a categorical
                field ``{"contact_state": np.int32}``.
            name: Grid name shown by ParaView (default ``"<series name> t=<t>"``).
            information: Extra ``<Information Name= Value=>`` items of the grid (e.g. convergence).
        """
        if isinstance(fields, Mapping):
            named = dict(fields)
        else:
            named = {getattr(f, "name", repr(f)): f for f in fields}
            names = [getattr(f, "name", repr(f)) for f in fields]
            if len(named) != len(names):
                twice = sorted({n for n in names if names.count(n) > 1})
                raise InputError(f"XDMFTimeSeries {self.path.name}: two fields named {twice[0]!r} (name them apart, "
                                 "Function(V, name=...), or pass a dict)")
        dtypes = dict(dtypes or {})
        unknown = set(dtypes) - set(named)
        if unknown:
            raise InputError(f"XDMFTimeSeries {self.path.name}: dtypes given for unknown fields {sorted(unknown)}")
        self._check(t, named, dtypes)
        step = len(self._grids)
        slabs = []
        for key, f in named.items():
            values = self._vertex_values(f)
            dtype = np.dtype(dtypes.get(key, np.float64))
            if dtype.kind in "iu":
                values = np.rint(values)
            values = np.ascontiguousarray(values.astype(dtype))
            if values.shape[1] == 1:
                values = values.ravel()
            slabs.append((f"/Function/{key}/{step}", values, self.num_vertices, self._offset))
        _write_slabs(self.comm, self.h5_path, slabs, create=False)
        self._grids.append(self._grid_element(t, step, slabs, name, information))
        if self.comm.rank == 0:
            self._save_xml()
        self.comm.barrier()

    def _data_item(self, parent: ET.Element, dataset: str, shape: tuple[int, ...], dtype: np.dtype) -> None:
        number, precision = _number_type(dtype)
        item = ET.SubElement(parent, "DataItem", Dimensions=" ".join(map(str, shape)), NumberType=number,
                             Precision=precision, Format="HDF")
        item.text = f"{self.h5_path.name}:{dataset}"

    def _grid_element(self, t: float, step: int, slabs: list, name: str | None,
                      information: Mapping[str, str] | None) -> ET.Element:
        grid = ET.Element("Grid", Name=name or f"{self.name} t={t:g}", GridType="Uniform")
        ET.SubElement(grid, "Time", Value=repr(float(t)))
        for key, value in (information or {}).items():
            ET.SubElement(grid, "Information", Name=str(key), Value=str(value))
        topology = ET.SubElement(grid, "Topology", TopologyType=self._cell, NumberOfElements=str(self.num_cells),
                                 NodesPerElement=str(self._vertices_per_cell))
        self._data_item(topology, MESH_TOPOLOGY, (self.num_cells, self._vertices_per_cell), np.dtype(np.int64))
        geometry = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
        self._data_item(geometry, MESH_GEOMETRY, (self.num_vertices, 3), np.dtype(np.float64))
        for dataset, values, rows, _ in slabs:
            width = values.shape[1] if values.ndim == 2 else 1
            kind = {1: "Scalar", 3: "Vector", 6: "Tensor6", 9: "Tensor"}.get(width, "Matrix")
            attribute = ET.SubElement(grid, "Attribute", Name=dataset.split("/")[2], AttributeType=kind,
                                      Center="Node")
            self._data_item(attribute, dataset, (rows,) if width == 1 else (rows, width), values.dtype)
        return grid

    def _save_xml(self) -> None:
        root = ET.Element("Xdmf", Version="3.0")
        domain = ET.SubElement(root, "Domain")
        series = ET.SubElement(domain, "Grid", Name=self.name, GridType="Collection", CollectionType="Temporal")
        series.extend(self._grids)
        ET.indent(root)
        _write_xml(self.path, '<?xml version="1.0" encoding="utf-8"?>\n<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n'
                   + ET.tostring(root, encoding="unicode") + "\n")


def write_xdmf(path: Path, model: ContactModel, result: SolveResult, units: Units | None = None) -> None:
    """Write the output fields of a solve as ``solution.xdmf``/``.h5`` (collective).

    A solve that did not converge writes its last iterate, named so in the grid and marked by the grid's
    ``converged``/``reason`` information items.
    """
    with XDMFTimeSeries(path, model.V.mesh) as xdmf:
        write_result_grid(xdmf, model, result, 0.0, "solution", units)


def write_result_grid(xdmf: XDMFTimeSeries, model: ContactModel, result: SolveResult, t: float, name: str,
                      units: Units | None = None) -> None:
    """Append the output fields of a solve as the grid of time ``t`` (collective); a solve that did not converge
    is named ``last iterate (NOT converged: <reason>)`` (after ``name`` when it is not "solution") and marked
    by the grid's ``converged``/``reason`` information items."""
    functions = contact_functions(model, result)
    field_units = (units or Units()).fields()
    if not result.converged:
        name = ("" if name == "solution" else f"{name}: ") + f"last iterate (NOT converged: {result.reason})"
    dtypes = {key: np.int32 for key in ("contact_state", "body") if any(f.name == key for f in functions)}
    xdmf.write(t, functions, dtypes=dtypes, name=name,
               information={"converged": str(bool(result.converged)).lower(), "reason": str(result.reason),
                            "contact_state": ", ".join(f"{k} {v}" for k, v in CONTACT_STATES.items()),
                            "units": ", ".join(f"{f.name} {field_units.get(f.name) or '1'}" for f in functions)})


def write_initial_grid(xdmf: XDMFTimeSeries, model: ContactModel, t: float = 0.0) -> None:
    """The unloaded reference state as the grid of time ``t`` (a load path's t = 0; collective): ũ = 0, every
    contact node open at its initial gap, no contact force."""
    m = model.contact.size
    zeros = np.zeros(model.A.getLocalSize()[0])
    gap = np.array(model.contact.gap, dtype=float)
    rigid = np.flatnonzero(~model.coupling.paired_mask(m))
    if rigid.size and model.obstacles:  # the obstacles' nodes' gaps to the obstacles at rest (obstacles.h5 at t)
        rest = [o.at_scene_position().rotated(None) for o in model.obstacles]
        gap[rigid] = closest_obstacle(rest, model.contact.coordinates[rigid])[1]
    result = SolveResult(
        u=zeros, displacement=zeros, converged=True, reason="initial state", iterations=0, krylov_iterations=0,
        residual_history=[], records=[], sets=np.zeros(m, dtype=np.int8), states=np.full(m, OPEN, dtype=np.int8),
        normal_force=np.zeros(m), tangential_force=np.zeros((m, 2)), gap=gap,
        gamma=0.0, contact_force=np.zeros((m, 3)), master_force=model.coupling.initial_master_force(zeros.size))
    write_result_grid(xdmf, model, result, t, "initial state")


def _grid_time(grid: ET.Element) -> str:
    """The time of a grid this writer wrote (its Time element's Value)."""
    stamp = grid.find("Time")
    if stamp is None or "Value" not in stamp.attrib:
        raise ValueError("a grid without its time")
    return stamp.attrib["Value"]


def _number_type(dtype: np.dtype) -> tuple[str, str]:
    """XDMF NumberType and Precision of a NumPy dtype."""
    dtype = np.dtype(dtype)
    if dtype.kind == "f":
        return "Float", str(dtype.itemsize)
    if dtype.kind == "i":
        return ("Char" if dtype.itemsize == 1 else "Int"), str(dtype.itemsize)
    if dtype.kind == "u":
        return ("UChar" if dtype.itemsize == 1 else "UInt"), str(dtype.itemsize)
    raise TypeError(f"no XDMF number type for {dtype}")


def _write_slabs(comm: MPI.Comm, path: Path, slabs: list[tuple[str, np.ndarray, int, int]], create: bool) -> None:
    """Write distributed row blocks into datasets of ONE HDF5 file (collective).

    Each entry ``(name, local, rows, offset)`` is a dataset of ``rows`` global rows of which this rank owns
    ``local`` at ``offset``. No rank ever holds more than its own rows. With an MPI-enabled h5py all ranks
    open the file with the ``mpio`` driver and write their hyperslabs at once; with a serial h5py (Debian's
    default ``python3-h5py``) rank 0 creates the datasets and the ranks then write their own hyperslabs in
    rank order, passing a token (each rank opens the file, writes its rows and closes it before the next).
    """
    import h5py

    # room for the whole write first (HDF5 crashes when it meets a file-size limit or a full disk mid-write)
    total = comm.allreduce(sum(int(local.nbytes) for _, local, _, _ in slabs), op=MPI.SUM)
    short = [f for f in comm.allgather(room_for(path, total + HDF5_OVERHEAD + HDF5_OVERHEAD_PER_DATASET * len(slabs)))
             if f]
    if short:
        raise OutputError(f"the results could not be written ({path.name}: {short[0]}); the earlier results are kept")
    if h5py.get_config().mpi:  # pragma: no cover - Debian's default h5py is serial
        with h5py.File(path, "w" if create else "a", driver="mpio", comm=comm) as h5:
            for name, local, rows, offset in slabs:
                ds = h5.create_dataset(name, (rows, *local.shape[1:]), dtype=local.dtype)
                ds[offset : offset + local.shape[0]] = local
        return
    tag = 7301
    # the token carries the first failure (disk full, a file-size limit): the later ranks skip their turn and
    # every rank raises the same OutputError at the end instead of one rank raising while the others wait
    failure = comm.recv(source=comm.rank - 1, tag=tag) if comm.rank > 0 else ""
    if not failure:
        hook = sys.unraisablehook
        # a failed write leaves h5py objects whose release fails too ("Exception ignored in ObjectID.__dealloc__" on
        # stderr, twice): the failure is reported once, in one line
        sys.unraisablehook = lambda unraisable: None if isinstance(unraisable.exc_value, RuntimeError) else hook(
            unraisable)
        def write() -> None:  # the h5py objects live in this frame: released inside the quiet window below
            with h5py.File(path, "w" if (create and comm.rank == 0) else "a") as h5:
                for name, local, rows, offset in slabs:
                    ds = (h5.create_dataset(name, (rows, *local.shape[1:]), dtype=local.dtype) if comm.rank == 0
                          else h5[name])
                    if local.shape[0]:
                        ds[offset : offset + local.shape[0]] = local

        try:
            with contextlib.redirect_stderr(io.StringIO()):  # Cython prints some of those tracebacks itself
                try:
                    write()
                except (OSError, RuntimeError, ValueError) as err:
                    failure = f"{path.name}: {_io_reason(err)}"
        finally:
            sys.unraisablehook = hook
    if comm.rank < comm.size - 1:
        comm.send(failure, dest=comm.rank + 1, tag=tag)
    failure = comm.bcast(failure, root=comm.size - 1)
    if failure:
        raise OutputError(f"the results could not be written ({failure}); the earlier results are kept")


@rank0_file
def _write_xml(path: Path, text: str) -> None:
    """Replace ``path`` by ``text`` atomically (rank 0)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


#: XDMF topology names of the supported (degree-1) cells.
XDMF_CELLS: dict[str, str] = {"hexahedron": "Hexahedron", "tetrahedron": "Tetrahedron"}

