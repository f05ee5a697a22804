"""Contact quantities as mesh fields and totals: nodal areas, the point fields written to the XDMF file
(state, pressure, tangential force, traction, gap, normal, master reaction) and the forces per contact pair."""

from __future__ import annotations

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.forces import block_to_scalar_dofs, contact_areas
from fenics_coulomb.scd.records import SolveResult
from fenics_coulomb.scd.resolvent import NOT_CONTACT, ContactState

__all__ = ["CONTACT_STATES", "contact_functions"]


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
    if not model.coupling.paired:
        return fields
    reaction = dolfinx.fem.Function(V, name="master_reaction")
    if result.master_force is not None:
        reaction.x.petsc_vec.array[:] = result.master_force
    reaction.x.scatter_forward()
    return (*fields, reaction)


#: Categories of the (categorical) ``contact_state`` field.
CONTACT_STATES: dict[int, str] = {NOT_CONTACT: "not a contact node",
                                  **{int(s): s.name.lower() for s in ContactState}}

