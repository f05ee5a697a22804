"""The nodal contact areas of a model (post-processing in the model's terms; the output fields are
:mod:`fenics_coulomb.io.fields`, the forces on each body of a contact pair :mod:`fenics_coulomb.model.pairs.forces`)."""

from __future__ import annotations

import weakref

from petsc4py import PETSc

import dolfinx
import dolfinx.cpp.io
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.model.contact_model import ContactModel

__all__ = ["block_to_scalar_dofs", "contact_areas"]


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
    return model.coupling.contact_areas(_lumped_areas(model))


#: ∫ φᵢ ds over each model's contact boundary per owned DOF block (the mesh, its facet tags and the markers never
#: change in a model's life; plain arrays, no PETSc object).
_LUMPED: weakref.WeakKeyDictionary[ContactModel, npt.NDArray[np.float64]] = weakref.WeakKeyDictionary()


def _lumped_areas(model: ContactModel) -> npt.NDArray[np.float64]:
    """∫ φᵢ ds over the contact boundary at each owned contact node (assembled once per model; collective the
    first time)."""
    if model not in _LUMPED:
        msh = model.V.mesh
        S = model.scalar_space
        v = ufl.TestFunction(S)
        ds = ufl.Measure("ds", domain=msh, subdomain_data=model.facet_tags)
        form = dolfinx.fem.form(sum((v * ds(tag) for tag in model.markers[1:]), v * ds(model.markers[0])))
        b = dolfinx.fem.petsc.assemble_vector(form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        values = b.getArray(readonly=True).copy()
        b.destroy()
        per_block = np.zeros(model.V.dofmap.index_map.size_local + model.V.dofmap.index_map.num_ghosts)
        to_scalar = block_to_scalar_dofs(model.V, S)
        owned = to_scalar < values.size
        per_block[owned] = values[to_scalar[owned]]
        _LUMPED[model] = per_block
    return _LUMPED[model][model.contact.blocks]
