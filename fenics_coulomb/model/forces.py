"""The nodal contact areas of a model (post-processing in the model's terms; the output fields are
:mod:`fenics_coulomb.io.fields`, the forces on each body of a contact pair :mod:`fenics_coulomb.model.pairs.forces`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from petsc4py import PETSc

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

if TYPE_CHECKING:
    from fenics_coulomb.model.contact_model import ContactModel

__all__ = ["block_to_scalar_dofs", "boundary_areas", "contact_areas"]


def block_to_scalar_dofs(V: dolfinx.fem.FunctionSpace, S: dolfinx.fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Map DOF blocks of the vector space V to DOFs of the scalar space S on the same P1 element."""
    blocks = V.dofmap.list.ravel()
    scalars = S.dofmap.list.ravel()
    num = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    mapping = np.full(num, -1, dtype=np.int32)
    mapping[blocks] = scalars
    return mapping


def contact_areas(model: ContactModel) -> npt.NDArray[np.float64]:
    """Each owned contact node's share of the contact surface: ∫ φᵢ ds over the contact boundary (lumped facet
    areas), and D_j = ∫ ψ_j N_j ds on a dual mortar pair's slave nodes (= ∫ N_j ds over its slave facets: the
    pressure there is f_j·n_j / D_j; collective)."""
    if not model.markers:
        return np.zeros(model.contact.size)
    return model.coupling.contact_areas(model.boundary_areas[model.contact.blocks])


def boundary_areas(V: dolfinx.fem.FunctionSpace, S: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags,
                   markers: list[int]) -> npt.NDArray[np.float64]:
    """∫ φᵢ ds over the facets tagged ``markers`` at each local DOF block of the vector P1 space ``V`` (owned
    blocks; 0 at ghosts and off those facets), φᵢ the basis of its scalar space ``S`` (collective: one vector
    assembly)."""
    msh = V.mesh
    v = ufl.TestFunction(S)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=facet_tags)
    form = dolfinx.fem.form(sum((v * ds(tag) for tag in markers[1:]), v * ds(markers[0])))
    b = dolfinx.fem.petsc.assemble_vector(form)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    values = b.getArray(readonly=True).copy()
    b.destroy()
    per_block = np.zeros(V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts)
    to_scalar = block_to_scalar_dofs(V, S)
    owned = to_scalar < values.size
    per_block[owned] = values[to_scalar[owned]]
    return per_block
