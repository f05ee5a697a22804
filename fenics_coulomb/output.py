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
    Normal contact force λ = −ϑ ≥ 0 per contact node (the paper's normal nodal force, GPa·L²); 0 elsewhere.
``tangential_force``
    Tangential contact force the obstacle exerts on the body per contact node (GPa·L², a Cartesian 3-vector
    ⊥ the node's obstacle normal: its t₁, t₂ components mapped back to x, y, z); it opposes the slip on
    sliding nodes. 0 elsewhere.
``contact_traction``
    The contact force on the body per unit contact area (GPa, Cartesian vector): the nodal contact force
    divided by the node's share of the contact surface (the lumped facet areas ∫ φᵢ ds over the contact
    boundary), comparable with a pressure distribution. 0 elsewhere.
``gap``
    The linearized gap g + n·ũ on contact nodes (L, ≥ 0 at a solution); 0 elsewhere.
``contact_normal``
    The outward unit normal n of each contact node's obstacle; 0 elsewhere.
``master_reaction``
    Contact pairs only (two elastic bodies, :mod:`fenics_coulomb.two_body`): the reaction on each master node,
    f_j = −Σ_s φ_sj f_s (GPa·L², Cartesian); 0 elsewhere. For pairs the contact fields above live on the
    slave contact nodes, ``displacement`` is the physical u = M z, ``gap`` is g + n·w with the relative
    displacement w_s = u_s − Σ_j φ_sj u_j, and ``contact_normal`` is the master's outward normal at the
    closest point.

All fields go through :class:`XDMFTimeSeries` (:func:`write_xdmf`). HDF5 layout (one file, one mesh for the
whole series): ``/Mesh/mesh/geometry`` (N × 3 float64 vertex coordinates in the global P1 vertex numbering),
``/Mesh/mesh/topology`` (cells × vertices, int64 global vertex numbers, VTK/XDMF vertex order) and
``/Function/<field>/<k>`` (N × block size) for the k-th time. The XML uses no XInclude; every grid repeats
the (shared) geometry and topology data items.
"""


from __future__ import annotations

import contextlib
import functools
import glob
import io
import json
import logging
import os
import platform
import re
import shutil
import socket
import sys
import uuid
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import OutputError
from fenics_coulomb.model import ContactModel
from fenics_coulomb.problem import interpolate_displacement
from fenics_coulomb.records import SolveResult

logger = logging.getLogger(__name__)


def block_to_scalar_dofs(V: dolfinx.fem.FunctionSpace, S: dolfinx.fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Map DOF blocks of the vector space V to DOFs of the scalar space S on the same P1 element."""
    blocks = V.dofmap.list.ravel()
    scalars = S.dofmap.list.ravel()
    num = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    mapping = np.full(num, -1, dtype=np.int32)
    mapping[blocks] = scalars
    return mapping


def contact_areas(model: ContactModel) -> npt.NDArray[np.float64]:
    """Each owned contact node's share of the contact surface, ∫ φᵢ ds over the contact boundary (lumped facet
    areas; collective)."""
    if not model.markers:
        return np.zeros(model.contact.size)
    msh = model.V.mesh
    S = dolfinx.fem.functionspace(msh, ("Lagrange", 1))
    v = ufl.TestFunction(S)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=model.facet_tags)
    form = dolfinx.fem.form(sum((v * ds(tag) for tag in model.markers[1:]), v * ds(model.markers[0])))
    b = dolfinx.fem.petsc.assemble_vector(form)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    values = b.getArray(readonly=True).copy()
    b.destroy()
    return values[block_to_scalar_dofs(model.V, S)[model.contact.blocks]]


def contact_functions(model: ContactModel, result: SolveResult) -> tuple[dolfinx.fem.Function, ...]:
    """The output Functions (displacement, contact_state, contact_pressure, tangential_force,
    contact_traction, gap, contact_normal, and master_reaction for contact pairs); see the module docstring."""
    V = model.V
    msh = V.mesh
    S = dolfinx.fem.functionspace(msh, ("Lagrange", 1))
    cmap = model.contact
    to_scalar = block_to_scalar_dofs(V, S)
    scalar_dofs = to_scalar[cmap.blocks]
    vector_dofs = cmap.local_dofs.ravel()

    def point_field(space: dolfinx.fem.FunctionSpace, name: str, dofs: npt.NDArray[np.int32],
                    values: npt.ArrayLike, fill: float = 0.0) -> dolfinx.fem.Function:
        f = dolfinx.fem.Function(space, name=name)
        f.x.array[:] = fill
        f.x.array[dofs] = np.ravel(values)
        f.x.scatter_forward()  # owned contact nodes were set on their owner: make the ghosts agree
        return f

    u = dolfinx.fem.Function(V, name="displacement")
    u.x.petsc_vec.array[:] = result.displacement
    u.x.scatter_forward()
    tangential = np.einsum("iab,ib->ia", cmap.frames[:, :, :2], result.tangential_force)  # t₁, t₂ → x, y, z
    areas = contact_areas(model)
    force = result.contact_force if result.contact_force.shape == (cmap.size, 3) else np.zeros((cmap.size, 3))
    traction = np.divide(force, areas[:, None], out=np.zeros_like(force), where=areas[:, None] > 0)
    fields = (
        u,
        point_field(S, "contact_state", scalar_dofs, result.states, fill=-1.0),
        point_field(S, "contact_pressure", scalar_dofs, result.normal_force),
        point_field(V, "tangential_force", vector_dofs, tangential),
        point_field(V, "contact_traction", vector_dofs, traction),
        point_field(S, "gap", scalar_dofs, result.gap),
        point_field(V, "contact_normal", vector_dofs, cmap.normals),
    )
    if model.coupling is None:
        return fields
    reaction = dolfinx.fem.Function(V, name="master_reaction")
    if result.master_force is not None:
        reaction.x.petsc_vec.array[:] = result.master_force
    reaction.x.scatter_forward()
    return (*fields, reaction)


def pair_forces(model: ContactModel, result: SolveResult,
                pairs: Sequence[Any] | None = None) -> list[dict[str, Any]]:
    """Per contact pair, the total force on each body from that body's own residual (collective; the same list
    on all ranks; empty for one body).

    The residual K u − l̃⁰ of the physical displacement u, assembled WITHOUT boundary conditions
    (:func:`fenics_coulomb.checks.unconstrained_residual`), is the force the other body and the supports exert
    on each node. Summed over the pair's slave contact nodes it is the force on the slave body; summed over
    the master nodes of the facets the pair's contact nodes use (the stencils φ_sj) it is the force on the
    master body. Equilibrium (Σ_j φ_sj = 1) makes them equal and opposite; a supported (Dirichlet) node among
    either set adds its support reaction (counted in ``prescribed_nodes``), and a master node shared by
    several pairs' stencils counts for each of them.

    Args:
        model: The model of a solve with contact pairs.
        result: Its result (``displacement`` = the physical u).
        pairs: The :class:`~fenics_coulomb.pairing.ContactPair` s in the order given to the problem, for
            their names and tags (optional).

    Returns:
        One dict per pair: ``pair`` (index), ``name``, ``slave``/``master`` tags (when ``pairs`` is given),
        ``contact_nodes``, ``master_nodes``, ``prescribed_nodes``, ``force_on_slave_body`` and
        ``force_on_master_body`` (3-vectors from the residuals), ``contact_force`` (Σ of the solver's force
        on the slave contact nodes) and ``balance`` = ‖slave + master‖ / ‖slave‖.
    """
    from fenics_coulomb.checks import unconstrained_residual

    pairing = model.pairing
    if pairing is None:
        return []
    comm = model.comm
    imap = model.V.dofmap.index_map
    n, r0 = imap.size_local, int(imap.local_range[0])
    pairs = list(pairs if pairs is not None else getattr(model, "pairs", None) or [])
    count = max(len(pairs), comm.allreduce(int(pairing.pair_index.max(initial=-1)) + 1, op=MPI.MAX))
    full = unconstrained_residual(model, result.displacement)
    prescribed = np.zeros(n, dtype=bool)
    prescribed[model.dirichlet_rows // 3] = True
    force = np.asarray(result.contact_force, dtype=np.float64).reshape(-1, 3)
    out: list[dict[str, Any]] = []
    for k in range(count):
        mine = pairing.pair_index == k
        slave = pairing.blocks[mine]
        stencil = pairing.master_blocks[mine]
        used = np.unique(stencil[stencil >= 0])
        used = np.unique(np.concatenate(comm.allgather(used))).astype(np.int64)
        master = (used[(used >= r0) & (used < r0 + n)] - r0).astype(np.int32)
        local = np.concatenate([full[slave].sum(axis=0), full[master].sum(axis=0), force[mine].sum(axis=0),
                                [slave.size, master.size, prescribed[slave].sum() + prescribed[master].sum()]])
        total = np.asarray(comm.allreduce(local, op=MPI.SUM))
        on_slave, on_master = total[0:3], total[3:6]
        scale = float(np.linalg.norm(on_slave))
        entry: dict[str, Any] = {"pair": k}
        if k < len(pairs):
            q = pairs[k]
            entry["name"] = getattr(q, "name", None)
            entry["slave"] = [int(t) for t in np.atleast_1d(q.slave)]
            entry["master"] = [int(t) for t in np.atleast_1d(q.master)]
        entry.update({
            "contact_nodes": int(total[9]),
            "master_nodes": int(total[10]),
            "prescribed_nodes": int(total[11]),
            "force_on_slave_body": [float(c) for c in on_slave],
            "force_on_master_body": [float(c) for c in on_master],
            "contact_force": [float(c) for c in total[6:9]],
            "balance": float(np.linalg.norm(on_slave + on_master) / scale) if scale > 0 else 0.0,
        })
        out.append(entry)
    return out


#: Categories of the (categorical) ``contact_state`` field.
CONTACT_STATES: dict[int, str] = {-1: "not a contact node", 0: "open", 1: "stick", 2: "slip"}

#: XDMF topology names of the supported (degree-1) cells.
XDMF_CELLS: dict[str, str] = {"hexahedron": "Hexahedron", "tetrahedron": "Tetrahedron"}

MESH_GEOMETRY = "/Mesh/mesh/geometry"
MESH_TOPOLOGY = "/Mesh/mesh/topology"


#: Deferred write errors of rank-0-only files, one list per active :meth:`ResultDirectory.writing` (a stack).
_DEFERRED: list[list[str]] = []
#: The temporary directories of the result sets being written by this process (:func:`abandon_results`).
_WRITING: set[Path] = set()


def abandon_results() -> None:
    """Remove the temporary directories of every result set this process is writing (for a run that ends now,
    e.g. on a signal, without unwinding: the earlier result sets stay untouched)."""
    for path in list(_WRITING):
        shutil.rmtree(path, ignore_errors=True)
        _WRITING.discard(path)


def rank0_file(write: Callable[..., None]) -> Callable[..., None]:
    """Make a writer that writes ``path`` (its first argument) on rank 0 alone safe inside
    :meth:`ResultDirectory.writing`: an OSError there (disk full, a file-size limit) is kept for the whole set
    instead of raised on rank 0 alone, which would leave the other ranks waiting in the next collective call; the
    set then fails on every rank together. Outside a result directory it raises as usual."""

    @functools.wraps(write)
    def wrapper(path: Path, *args: Any, **kwargs: Any) -> None:
        if not _DEFERRED:
            write(path, *args, **kwargs)
            return
        if _DEFERRED[-1]:  # an earlier file of the set failed: the set is lost anyway
            return
        try:
            write(path, *args, **kwargs)
        except OSError as err:
            _DEFERRED[-1].append(f"{Path(path).name}: {_io_reason(err)}")

    return wrapper


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


def _io_reason(err: BaseException) -> str:
    """The reason of a failed write in a few words (HDF5 packs errno and its text into a long message)."""
    code = getattr(err, "errno", None)
    if not isinstance(code, int):
        found = re.search(r"errno = (\d+)", str(err))
        code = int(found.group(1)) if found else None
    if isinstance(code, int) and code > 0:
        return os.strerror(code)
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    return lines[0] if lines else type(err).__name__


def _write_slabs(comm: MPI.Comm, path: Path, slabs: list[tuple[str, np.ndarray, int, int]], create: bool) -> None:
    """Write distributed row blocks into datasets of ONE HDF5 file (collective).

    Each entry ``(name, local, rows, offset)`` is a dataset of ``rows`` global rows of which this rank owns
    ``local`` at ``offset``. No rank ever holds more than its own rows. With an MPI-enabled h5py all ranks
    open the file with the ``mpio`` driver and write their hyperslabs at once; with a serial h5py (Debian's
    default ``python3-h5py``) rank 0 creates the datasets and the ranks then write their own hyperslabs in
    rank order, passing a token (each rank opens the file, writes its rows and closes it before the next).
    """
    import h5py

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
        self.path = Path(path).with_suffix(".xdmf")
        self.h5_path = self.path.with_suffix(".h5")
        self.name = name
        self.mesh = mesh
        self.comm: MPI.Comm = mesh.comm
        cell = mesh.topology.cell_name()
        if cell not in XDMF_CELLS:
            raise ValueError(f"XDMFTimeSeries supports {', '.join(XDMF_CELLS)} meshes, not {cell}")
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
        return [float(g.find("Time").get("Value")) for g in self._grids]  # type: ignore[union-attr]

    def _vertex_values(self, f: dolfinx.fem.Function) -> npt.NDArray[np.float64]:
        """Values of a P1 Function at this rank's owned vertices (rows in the writer's vertex order)."""
        W = f.function_space
        if W.dofmap.list.shape != self._S.dofmap.list.shape or W.dofmap.index_map.size_global != self.num_vertices:
            raise ValueError(f"field {f.name!r} is not a P1 (vertex) field")
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
        named = dict(fields) if isinstance(fields, Mapping) else {f.name: f for f in fields}
        dtypes = dict(dtypes or {})
        unknown = set(dtypes) - set(named)
        if unknown:
            raise ValueError(f"dtypes given for unknown fields {sorted(unknown)}")
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


@rank0_file
def _write_xml(path: Path, text: str) -> None:
    """Replace ``path`` by ``text`` atomically (rank 0)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def write_xdmf(path: Path, model: ContactModel, result: SolveResult) -> None:
    """Write the output fields of a solve as ``solution.xdmf``/``.h5`` (collective).

    A solve that did not converge writes its last iterate, named so in the grid and marked by the grid's
    ``converged``/``reason`` information items.
    """
    with XDMFTimeSeries(path, model.V.mesh) as xdmf:
        write_result_grid(xdmf, model, result, 0.0, "solution")


def write_result_grid(xdmf: XDMFTimeSeries, model: ContactModel, result: SolveResult, t: float, name: str) -> None:
    """Append the output fields of a solve as the grid of time ``t`` (collective); a solve that did not converge
    is named ``last iterate (NOT converged: <reason>)`` (after ``name`` when it is not "solution") and marked
    by the grid's ``converged``/``reason`` information items."""
    functions = contact_functions(model, result)
    if not result.converged:
        name = ("" if name == "solution" else f"{name}: ") + f"last iterate (NOT converged: {result.reason})"
    xdmf.write(t, functions, dtypes={"contact_state": np.int32}, name=name,
               information={"converged": str(bool(result.converged)).lower(), "reason": str(result.reason),
                            "contact_state": ", ".join(f"{k} {v}" for k, v in CONTACT_STATES.items())})


def grid_times(path: Path) -> list[float]:
    """The times of the grids of an XDMF file written by :class:`XDMFTimeSeries` (no MPI)."""
    root = ET.parse(Path(path).with_suffix(".xdmf")).getroot()
    grid = root.find("Domain/Grid")
    if grid is None:
        return []
    grids = grid.findall("Grid") if grid.get("GridType") == "Collection" else [grid]
    return [float(g.find("Time").get("Value", "nan")) if g.find("Time") is not None else float("nan")
            for g in grids]


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
    if item is None or not (item.text or "").strip() or ":" not in item.text:
        raise ValueError(f"no HDF5 data item for {what}")
    file, dataset = item.text.strip().rsplit(":", 1)
    return path.parent / file, dataset


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


def check_solution_file(path: Path) -> str:
    """Why ``path`` cannot serve as ``--start`` (empty string if it can); reads only metadata (no MPI)."""
    import h5py

    try:
        info = solution_datasets(path)
        shapes = {}
        for key in ("topology", "geometry", "displacement"):
            file, dataset = info[key]
            with h5py.File(file, "r") as h5:
                shapes[key] = h5[dataset].shape
    except (OSError, KeyError, ValueError) as err:
        return f"no displacement from an earlier run can be read ({err})"
    nodes = shapes["geometry"][0]
    if shapes["geometry"] != (nodes, 3) or shapes["displacement"] != (nodes, 3):
        return f"'displacement' is not a 3-vector field on the mesh's vertices (shape {shapes['displacement']})"
    if len(shapes["topology"]) != 2:
        return f"the topology has shape {shapes['topology']}"
    return ""


def _rows(comm: MPI.Comm, total: int) -> tuple[int, int]:
    """This rank's contiguous block of ``total`` rows."""
    return total * comm.rank // comm.size, total * (comm.rank + 1) // comm.size


def read_displacement(path: Path, V: dolfinx.fem.FunctionSpace, padding: float | None = None,
                      time: float | None = None) -> npt.NDArray[np.float64]:
    """Read ``displacement`` (the last time, or the time ``time``: a load path's step number) of an earlier
    run's solution.xdmf/.h5 and interpolate it onto V (collective).

    The old mesh is rebuilt in parallel from row blocks of the file; the meshes need not match (nested
    iteration across levels): the old field is rebuilt as a P1 function on the old mesh and interpolated
    point-wise; nodes up to ``padding`` outside the old mesh (the bottoms of two levels follow d at different
    resolutions; default: :func:`~fenics_coulomb.problem.interpolate_displacement`'s) take the value of the
    closest cell.

    Returns:
        The interpolated physical displacement on V's owned DOFs.
    """
    import basix.ufl
    import h5py
    import ufl

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
    u = dolfinx.fem.Function(V, name="displacement")
    u.x.petsc_vec.array[:] = owned
    u.x.scatter_forward()
    return u


def software_versions() -> dict[str, str]:
    """Versions of the numerical stack."""
    import ufl

    major, minor, sub = PETSc.Sys.getVersion()
    return {
        "dolfinx": dolfinx.__version__,
        "ufl": ufl.__version__,
        "petsc": f"{major}.{minor}.{sub}",
        "numpy": np.__version__,
        "python": platform.python_version(),
        "mpi": MPI.Get_library_version().splitlines()[0].strip(),
    }


def summary(model: ContactModel, result: SolveResult, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """Global summary of a solve (collective; identical on all ranks): the result's own summary, the software
    versions, for contact pairs the force on each body per pair (``contact_pairs``, :func:`pair_forces`) and
    ``extra``."""
    comm = model.V.mesh.comm
    data = result.summary(comm)
    if model.coupling is not None:
        data["contact_pairs"] = pair_forces(model, result)
    data["versions"] = software_versions()
    if extra:
        data.update(extra)
    return data


@rank0_file
def write_convergence_csv(path: Path, result: SolveResult, comm: MPI.Comm) -> None:
    """Per-iteration history as CSV on rank 0: residual, relative residual, step, Krylov, states."""
    if comm.rank != 0:
        return
    h0 = result.residual_history[0] if result.residual_history else 0.0
    lines = ["iteration,residual,relative_residual,step_length,krylov_iterations,open,stick,slip,forcing,"
             "linear_residual"]
    lines.append(f"0,{h0:.17g},1,,,,,,,")
    for rec in result.records:
        rel = rec.residual / h0 if h0 > 0 else 0.0
        lines.append(f"{rec.iteration},{rec.residual:.17g},{rel:.17g},{rec.step_length:.17g},"
                     f"{rec.krylov_iterations},{rec.open},{rec.stick},{rec.slip},{rec.forcing:.6g},"
                     f"{rec.linear_residual:.6g}")
    path.write_text("\n".join(lines) + "\n")


@rank0_file
def write_path_csv(path: Path, steps: Sequence[Mapping[str, Any]], comm: MPI.Comm) -> None:
    """One row per solve of a load path on rank 0 (``steps``: summary.json's "steps"): solve, time (the step
    number), step, substep, load factor, converged, Newton and Krylov iterations, open/stick/slip, the total
    contact force, the applied load's resultant, the reaction per Dirichlet boundary and δ per obstacle (x, y,
    z components each; a boundary group "a,b" is named "a+b"), wall time."""
    if comm.rank != 0 or not steps:
        return
    xyz = ("x", "y", "z")
    reactions = list(steps[0]["reactions"])
    obstacles = list(steps[0]["obstacle_displacements"])
    header = ["solve", "time", "step", "substep", "load_factor", "converged", "newton_iterations",
              "krylov_iterations", "open", "stick", "slip",
              *[f"contact_force_{c}" for c in xyz], *[f"applied_load_{c}" for c in xyz],
              *[f"reaction_{name.replace(',', '+')}_{c}" for name in reactions for c in xyz],
              *[f"delta_{name.replace(',', '+')}_{c}" for name in obstacles for c in xyz], "wall_time_s"]
    lines = [",".join(header)]
    for s in steps:
        counts = s["state_counts"]
        row = [s["index"], f"{s['time']:.17g}", s["step"], s["substep"], f"{s['load_factor']:.17g}",
               str(bool(s["converged"])).lower(), s["newton_iterations"], s["krylov_iterations"],
               counts["open"], counts["stick"], counts["slip"],
               *[f"{c:.17g}" for c in s["contact_force"]], *[f"{c:.17g}" for c in s["applied_load"]],
               *[f"{c:.17g}" for name in reactions for c in s["reactions"][name]],
               *[f"{c:.17g}" for name in obstacles for c in s["obstacle_displacements"][name]],
               f"{s['wall_time_s']:.6g}"]
        lines.append(",".join(map(str, row)))
    path.write_text("\n".join(lines) + "\n")


@rank0_file
def write_summary(path: Path, data: dict[str, Any], comm: MPI.Comm) -> None:
    """Write the summary as JSON on rank 0."""
    if comm.rank == 0:
        path.write_text(json.dumps(data, indent=2) + "\n")


#: Files of a result set written before the manifest (``summary.json`` "files") existed.
RESULT_FILES = ("solution.xdmf", "solution.h5", "summary.json", "convergence.csv", "convergence.png",
                "contact_states.png", "deformed.png", "path.csv", "path.png")


def _owner() -> str:
    """HOST-PID of this process, for the names of temporary result directories."""
    return f"{socket.gethostname().replace('-', '_')}-{os.getpid()}"


def _split_owner(rest: str) -> tuple[str, str]:
    """(host as :func:`_owner` writes it, pid) of the HOST-PID-RANDOM tail of a temporary result directory's name
    ("", "" if it has none)."""
    parts = rest.split("-")
    if len(parts) != 3:
        return "", ""
    return parts[0], parts[1]


#: A run that did not converge writes its set here, beside the output directory, when that holds a converged set.
FAILED_SUFFIX = ".not-converged"


class ResultDirectory:
    """The result set of a run, written as a whole: into a temporary sibling of the output directory, then
    renamed into place (MPI-aware: rank 0 checks and renames, every rank writes into the temporary directory).
    A run that did not converge (``failed``) never replaces a converged set: it goes to ``NAME.not-converged``
    beside it.

    Until :meth:`writing` commits, an existing result set stays untouched; if writing fails the temporary
    directory is removed. The output directory belongs to the run: an existing one is replaced as a whole,
    except for entries that the previous run did not write (listed in its ``summary.json`` "files"), which are
    carried over. A non-empty directory that is not a fenics-coulomb result set is refused.
    """

    MANIFEST = "summary.json"
    #: Set by the caller before the set is committed: the run did not converge (:meth:`writing`).
    failed: bool = False

    def __init__(self, comm: MPI.Comm, path: str | Path) -> None:
        """Check that the result set can be written to ``path`` (collective; InputError on every rank)."""
        from fenics_coulomb.errors import check_all

        self.comm = comm
        self.given = str(path)
        final = Path(path)
        self.path = final.absolute()
        #: Where the last set went (:meth:`writing`): the output directory, or for a failed run beside an earlier
        #: converged set, ``NAME.not-converged``.
        self.committed = self.path
        check_all(comm, not (message := self._check_name()), message)  # pure: every rank, before the file system
        message = ""
        if comm.rank == 0:
            if final.is_symlink():
                self.path = Path(os.path.realpath(final)).absolute()
            message = self._check()
        message = comm.bcast(message, root=0)
        check_all(comm, not message, message)

    def _check_name(self) -> str:
        """"" if every component of the path fits the file system, with room for the temporary directory's tail
        (the set is written into ".NAME.partial-HOST-PID-RANDOM" first)."""
        tail = len(f"..partial-{_owner()}-00000000".encode())
        for i, part in enumerate(self.path.parts):
            limit = 255 - (tail if i == len(self.path.parts) - 1 else 0)
            if len(part.encode()) > limit:
                shown = part if len(part) <= 40 else part[:37] + "..."
                return (f"--out: the name {shown!r} has {len(part.encode())} bytes; at most {limit} fit a file "
                        "name here")
        return ""

    def _check(self) -> str:
        prefix = f"--out {self.given!r}"
        try:
            cwd = Path.cwd()
            if self.path == cwd or self.path in cwd.parents:
                return f"{prefix}: the output directory would replace the current directory or one above it"
            if self.path.exists():
                if not self.path.is_dir():
                    return f"{prefix}: exists and is not a directory"
                if any(self.path.iterdir()) and not (self.path / self.MANIFEST).is_file():
                    return (f"{prefix}: a non-empty directory that is not a fenics-coulomb result set (no "
                            f"{self.MANIFEST}); refusing to replace it")
            self.path.parent.mkdir(parents=True, exist_ok=True)
            probe = self.path.parent / f".{self.path.name}.probe-{os.getpid()}"
            probe.mkdir()
            probe.rmdir()
        except OSError as err:
            return f"{prefix}: output directory is not writable ({err.strerror or err})"
        return ""

    @contextlib.contextmanager
    def writing(self) -> Iterator[Path]:
        """Yield the temporary directory to write the result set into; commit it on success (collective).

        The temporary directory is named ``.NAME.partial-HOST-PID-RANDOM`` after rank 0's host and process, so that
        a later run into the same parent removes what a run that was killed left behind (:meth:`clean_stale`).
        On an exception (an interrupt included) every rank that sees it removes the temporary directory at once
        (no communication: the run ends, and a rank waiting for another must not keep it) and the exception
        propagates. Rank-0-only files that fail (:func:`rank0_file`) fail the set on every rank together:
        :class:`~fenics_coulomb.errors.OutputError`, one line, with the earlier result set kept.
        """
        tmp = ""
        if self.comm.rank == 0:
            self.clean_stale()
            tmp = str(self.path.parent / f".{self.path.name}.partial-{_owner()}-{uuid.uuid4().hex[:8]}")
            try:
                os.mkdir(tmp)
            except OSError as err:
                tmp = f"\0{err.strerror or err}"
        tmp = self.comm.bcast(tmp, root=0)
        if tmp.startswith("\0"):
            raise OutputError(f"--out {self.given!r}: the results cannot be written ({tmp[1:]})")
        tmp_path = Path(tmp)
        errors: list[str] = []
        _DEFERRED.append(errors)
        _WRITING.add(tmp_path)
        try:
            yield tmp_path
        except BaseException:
            shutil.rmtree(tmp_path, ignore_errors=True)
            raise
        finally:
            _DEFERRED.remove(errors)
            _WRITING.discard(tmp_path)
        failed = [e for e in self.comm.allgather(errors[0] if errors else "") if e]
        error = None
        if failed:
            error = f"results could not be written into {self.given} ({failed[0]}); the earlier results are kept"
            if self.comm.rank == 0:
                shutil.rmtree(tmp_path, ignore_errors=True)
        elif self.comm.rank == 0:
            target = self.path
            if self.failed and self._holds_converged_set():  # a failed run never replaces a solution
                target = self.path.with_name(f"{self.path.name}{FAILED_SUFFIX}")
            try:
                self._commit(tmp_path, target)
                self.committed = target
            except OSError as err:
                error = (f"results could not be moved into {target}: {err.strerror or err} (the complete set is "
                         f"kept in {tmp_path})")
        error, self.committed = self.comm.bcast((error, self.committed), root=0)
        if error:
            raise OutputError(error)

    def _holds_converged_set(self) -> bool:
        """Whether the output directory holds the result set of a run that converged (rank 0)."""
        try:
            return bool(json.loads((self.path / self.MANIFEST).read_text()).get("converged"))
        except (OSError, ValueError, AttributeError):
            return False

    def clean_stale(self) -> None:
        """Remove temporary siblings (``.NAME.partial-*``, ``.NAME.previous-*``) of runs on this host whose
        process is gone (rank 0 only; no communication)."""
        host = _owner().rsplit("-", 1)[0]
        for kind in ("partial", "previous"):
            prefix = f".{self.path.name}.{kind}-"
            for entry in self.path.parent.glob(f"{glob.escape(prefix)}*"):
                owner_host, pid = _split_owner(entry.name[len(prefix):])
                if owner_host != host or not pid.isdigit() or int(pid) == os.getpid():
                    continue
                try:
                    os.kill(int(pid), 0)
                except ProcessLookupError:
                    shutil.rmtree(entry, ignore_errors=True)
                except OSError:  # alive under another user: not ours to remove
                    continue

    def _commit(self, tmp: Path, target: Path) -> None:
        """Rename the new set to ``target``; carry over foreign entries of the previous one; drop the rest."""
        if not target.exists():
            os.rename(tmp, target)
            return
        previous = target.parent / f".{target.name}.previous-{_owner()}-{uuid.uuid4().hex[:8]}"
        os.rename(target, previous)
        os.rename(tmp, target)
        ours = set(RESULT_FILES)
        with contextlib.suppress(OSError, ValueError, TypeError):
            ours |= set(json.loads((previous / self.MANIFEST).read_text()).get("files", []))
        for entry in previous.iterdir():
            if entry.name not in ours and not (target / entry.name).exists():
                os.rename(entry, target / entry.name)
        shutil.rmtree(previous, ignore_errors=True)
