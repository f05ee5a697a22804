"""Output of a contact solve: XDMF fields for ParaView and a JSON summary.

Fields written to ``solution.xdmf`` (point data on the mesh vertices; units with E in GPa and lengths in
the mesh's unit L):

``displacement``
    Physical displacement ũ (L), vector.
``contact_state``
    0 open, 1 stick, 2 slip on contact nodes; −1 on all other nodes.
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
"""

from __future__ import annotations

import json
import logging
import platform
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.io
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.model import ContactModel
from fenics_coulomb.newton import SolveResult
from fenics_coulomb.problem import interpolate_displacement

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
    contact_traction, gap, contact_normal); see the module docstring."""
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
    return (
        u,
        point_field(S, "contact_state", scalar_dofs, result.states, fill=-1.0),
        point_field(S, "contact_pressure", scalar_dofs, result.normal_force),
        point_field(V, "tangential_force", vector_dofs, tangential),
        point_field(V, "contact_traction", vector_dofs, traction),
        point_field(S, "gap", scalar_dofs, result.gap),
        point_field(V, "contact_normal", vector_dofs, cmap.normals),
    )


def write_xdmf(path: Path, model: ContactModel, result: SolveResult) -> None:
    """Write the mesh and the output fields to an XDMF/HDF5 pair (collective)."""
    msh = model.V.mesh
    functions = contact_functions(model, result)
    with dolfinx.io.XDMFFile(msh.comm, str(path), "w") as xdmf:
        xdmf.write_mesh(msh)
        for f in functions:
            xdmf.write_function(f, 0.0)


def read_displacement(path: Path, V: dolfinx.fem.FunctionSpace, padding: float = 1e-6) -> npt.NDArray[np.float64]:
    """Read ``displacement`` from an earlier run's solution.xdmf/.h5 and interpolate it onto V (collective).

    The meshes need not match (nested iteration across levels): the old field is rebuilt as a P1 function
    on the old mesh and interpolated point-wise; nodes up to ``padding`` outside the old mesh (the bottoms
    of two levels follow d at different resolutions) take the value of the closest cell.

    Returns:
        The interpolated physical displacement on V's owned DOFs.
    """
    import h5py

    comm = V.mesh.comm
    with dolfinx.io.XDMFFile(comm, str(path.with_suffix(".xdmf")), "r") as xdmf:
        old = xdmf.read_mesh(name="mesh")
    with h5py.File(path.with_suffix(".h5"), "r") as h5:
        values = np.asarray(h5["Function/displacement/0"][:], dtype=np.float64)
    V_old = dolfinx.fem.functionspace(old, ("Lagrange", 1, (3,)))
    u_old = dolfinx.fem.Function(V_old)
    # P1 on the mesh's own (degree-1) geometry: cell-local node j is cell-local DOF j.
    nodes = old.geometry.dofmap.ravel()
    blocks = V_old.dofmap.list.ravel()
    u_old.x.array.reshape(-1, 3)[blocks] = values[old.geometry.input_global_indices[nodes]]
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
    versions and ``extra``."""
    comm = model.V.mesh.comm
    data = result.summary(comm)
    data["versions"] = software_versions()
    if extra:
        data.update(extra)
    return data


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


def write_summary(path: Path, data: dict[str, Any], comm: MPI.Comm) -> None:
    """Write the summary as JSON on rank 0."""
    if comm.rank == 0:
        path.write_text(json.dumps(data, indent=2) + "\n")
