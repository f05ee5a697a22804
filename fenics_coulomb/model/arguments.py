"""The arguments of a contact model checked before anything is built: the sliding model, the friction, the
forms' space, the boundary conditions, the contact boundary (InputError naming the value, the same on every rank,
before any collective call)."""

from __future__ import annotations

from collections.abc import Sequence

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from fenics_coulomb.errors import InputError

__all__ = ["SLIDING", "check_sliding", "validate_friction", "validate_arguments", "function_space", "as_list"]

#: The sliding models: "finite" evaluates the contact geometry in the deformed configuration X + u
#: (:meth:`ContactModel.configure`), "small" once in the reference configuration X.
SLIDING = ("finite", "small")


def check_sliding(sliding: object) -> None:
    """Raise InputError unless ``sliding`` is one of SLIDING (the API's and the scene's one message)."""
    if not isinstance(sliding, str) or sliding not in SLIDING:
        raise InputError(f"sliding = {sliding!r}: must be one of {', '.join(map(repr, SLIDING))}")


def as_list(value: object, name: str, single: type | tuple[type, ...]) -> list:
    """``value`` as a list: None → [], one ``single`` → [it], a list or tuple (or another iterable but a string or
    mapping) → its items; InputError naming ``name`` otherwise (pure)."""
    if value is None:
        return []
    if isinstance(value, single):
        return [value]
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
        raise InputError(f"{name} = {type(value).__name__}: give a list")
    return list(value)  # type: ignore[call-overload]


def validate_friction(friction: float) -> None:
    """Raise InputError unless 0 <= F < inf (a Python or NumPy real number)."""
    if isinstance(friction, bool | np.bool_) or not isinstance(friction, int | float | np.integer | np.floating) or \
            not (np.isfinite(friction) and friction >= 0.0):
        raise InputError(f"friction coefficient F = {friction!r}: must be finite and >= 0")


def _cpp(obj: object) -> object:
    """The C++ object behind a DOLFINx Python wrapper (itself if it is one): identity comparisons of meshes."""
    return getattr(obj, "_cpp_object", obj)


def _same_mesh(mesh: object, msh: dolfinx.mesh.Mesh) -> bool:
    return _cpp(mesh) is _cpp(msh)


def validate_arguments(V: dolfinx.fem.FunctionSpace, L: ufl.Form | None, bcs: Sequence[object],
                       contact: object, friction: object, contact_pairs: Sequence[object] = ()) -> None:
    """InputError naming the argument of :class:`~fenics_coulomb.model.contact_model.ContactModel` that does not
    belong to V's mesh or has the wrong kind (pure: the same on every rank, before any collective call): a friction
    Function on another mesh (DOLFINx would crash on it), facet tags of another mesh, cell tags, a boundary condition
    of another space, the facet tags of a contact pair on another mesh (each would build a wrong model, or crash)."""
    msh = V.mesh
    fdim = msh.topology.dim - 1
    if L is not None:
        if not isinstance(L, ufl.Form) or len(L.arguments()) != 1:
            raise InputError(f"L: {type(L).__name__} is not a linear UFL form (or None)")
        test = L.arguments()[0].ufl_function_space()
        if not _same_mesh(getattr(test, "mesh", None), msh):
            raise InputError("L: its test function lives on another mesh than the bilinear form's")
    for i, bc in enumerate(bcs):
        if not isinstance(bc, dolfinx.fem.DirichletBC):
            raise InputError(f"bcs[{i}]: {type(bc).__name__} is not a dolfinx.fem.DirichletBC")
        space = bc.function_space
        if not _same_mesh(space.mesh, msh) or space.dofmap.index_map_bs != V.dofmap.index_map_bs or \
                space.dofmap.index_map.size_global != V.dofmap.index_map.size_global:
            raise InputError(f"bcs[{i}]: a boundary condition of another function space (give it V or V.sub(i) of "
                             "the bilinear form's space, not a collapsed or foreign space)")
    if contact is not None:
        if not (isinstance(contact, tuple | list) and len(contact) == 2):
            raise InputError(f"contact = {type(contact).__name__}: give (facet_tags, markers)")
        tags, markers = contact
        if not isinstance(tags, dolfinx.mesh.MeshTags):
            raise InputError(f"contact: {type(tags).__name__} is not dolfinx MeshTags of facets")
        if tags.dim != fdim:
            raise InputError(f"contact: mesh tags of dimension {tags.dim} (cells or edges?): the contact boundary "
                             f"needs facet tags (dimension {fdim})")
        if _cpp(tags.topology) is not _cpp(msh.topology):
            raise InputError("contact: the facet tags belong to another mesh than the bilinear form's")
        values = list(markers) if isinstance(markers, list | tuple | np.ndarray) else [markers]
        if any(isinstance(m, bool) or not isinstance(m, int | np.integer) for m in values):
            raise InputError(f"contact: markers {markers!r} must be a list of integer tag values (empty: no contact "
                             "boundary)")
    for i, pair in enumerate(contact_pairs):
        tags = getattr(pair, "facet_tags", None)
        if isinstance(tags, dolfinx.mesh.MeshTags) and (tags.dim != fdim or
                                                         _cpp(tags.topology) is not _cpp(msh.topology)):
            raise InputError(f"contact_pairs[{i}]: its facet tags belong to another mesh than the bilinear form's "
                             f"(or are not facet tags: dimension {tags.dim})")
    if isinstance(friction, dolfinx.fem.Function):
        if not _same_mesh(friction.function_space.mesh, msh):
            raise InputError("friction: the friction Function lives on another mesh than the bilinear form's")
        if friction.function_space.dofmap.index_map_bs * friction.function_space.dofmap.bs != 1 and \
                friction.ufl_shape != ():
            raise InputError("friction: the friction Function must be scalar")


def function_space(a: ufl.Form) -> dolfinx.fem.FunctionSpace:
    """The trial space of ``a``; raise InputError unless it is a 3D vector P1/Q1 space."""
    if not isinstance(a, ufl.Form) or len(a.arguments()) != 2:
        raise InputError(f"a: {type(a).__name__} is not a bilinear UFL form")
    V = a.arguments()[-1].ufl_function_space()
    if not isinstance(V, dolfinx.fem.FunctionSpace):
        raise InputError("the bilinear form must be defined on a dolfinx.fem.FunctionSpace")
    topology = V.mesh.topology
    vertices = dolfinx.cpp.mesh.cell_num_vertices(topology.cell_type)
    if V.dofmap.index_map_bs != 3 or V.mesh.geometry.dim != 3 or V.dofmap.dof_layout.num_dofs != vertices:
        raise InputError(f"the contact solver needs a 3D vector P1/Q1 space (block size 3, one node per vertex); "
                         f"got block size {V.dofmap.index_map_bs} with {V.dofmap.dof_layout.num_dofs} nodes "
                         f"per {topology.cell_type.name}")
    return V
