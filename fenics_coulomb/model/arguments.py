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

from fenics_coulomb.errors import InputError, check_all

__all__ = ["SLIDING", "check_sliding", "validate_friction", "validate_arguments", "function_space", "as_list",
           "stiffness_rows", "integrates_every_cell"]

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
        if test is not V:
            raise InputError("L: its test function must be on the bilinear form's function space (the one of the "
                             "displacement)")
    for i, bc in enumerate(bcs):
        if not isinstance(bc, dolfinx.fem.DirichletBC):
            raise InputError(f"bcs[{i}]: {type(bc).__name__} is not a dolfinx.fem.DirichletBC")
        space = bc.function_space
        if not _same_mesh(space.mesh, msh) or not V._cpp_object.contains(_cpp(space)):  # a twin space: other DOFs
            raise InputError(f"bcs[{i}]: a boundary condition of another function space (give it V or V.sub(i) of "
                             "the bilinear form's space, not a collapsed, foreign or second space built alike)")
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
    if isinstance(friction, dolfinx.fem.Constant):
        raise InputError("friction: a dolfinx Constant: give a number (or a scalar Function for a field)")
    if not isinstance(friction, dolfinx.fem.Function):
        validate_friction(friction)  # type: ignore[arg-type]
    elif not _same_mesh(friction.function_space.mesh, msh):
        raise InputError("friction: the friction Function lives on another mesh than the bilinear form's")
    elif friction.ufl_shape != ():
        raise InputError(f"friction: the friction Function must be scalar (its shape is {friction.ufl_shape})")


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
    element = V.ufl_element()
    family = getattr(element, "family_name", "?")
    if family != "P" or element.discontinuous or element.embedded_superdegree != 1:
        kind = "discontinuous " if element.discontinuous else ""
        raise InputError(f"the contact solver needs a continuous vector Lagrange space of degree 1 (P1/Q1); got a "
                         f"{kind}{family} space of degree {element.embedded_superdegree} (its nodes are not the "
                         "mesh's vertices shared by the cells)")
    for argument in a.arguments():
        if argument.ufl_function_space() is not V:
            raise InputError("a: its test and trial functions must be on the same function space (the one of the "
                             "displacement; two spaces built alike are two dof numberings)")
    check_all(V.mesh.comm, *integrates_every_cell(a, V))
    return V


def stiffness_rows(V: dolfinx.fem.FunctionSpace, diagonal: np.ndarray, free: np.ndarray) -> tuple[bool, str]:
    """(whether every free owned DOF has a positive stiffness on the diagonal, the message naming one without): a
    bilinear form that integrates over part of the mesh (``dx(1)`` of several cell tags) leaves the others' DOFs
    with no stiffness at all — a singular body, and rows PETSc cannot even scale."""
    empty = np.flatnonzero(free & ~(diagonal > 0.0))
    if not empty.size:
        return True, ""
    x = V.tabulate_dof_coordinates()[empty[0] // 3]
    at = ", ".join(f"{c:.6g}" for c in x)
    return False, (f"a: the bilinear form gives the DOF at ({at}) no stiffness (diagonal {diagonal[empty[0]]:.3g}): "
                   "does it integrate over every cell (a dx without a subdomain, or every cell tag)?")


def integrates_every_cell(a: ufl.Form, V: dolfinx.fem.FunctionSpace) -> tuple[bool, str]:
    """(whether the bilinear form's cell integrals cover every cell this rank owns, the message naming one they
    leave out): ``dx(1) + dx(3)`` of three cell tags leaves the cells of tag 2 without stiffness — a body in pieces,
    whose rows PETSc cannot even assemble."""
    msh = V.mesh
    tdim = msh.topology.dim
    covered: list[np.ndarray] = []
    for integral in a.integrals_by_type("cell"):
        tags = integral.subdomain_data()
        if integral.subdomain_id() in ("everywhere", "otherwise") or not isinstance(tags, dolfinx.mesh.MeshTags):
            return True, ""
        covered.append(tags.find(int(integral.subdomain_id())))
    cells = np.unique(np.concatenate(covered)) if covered else np.zeros(0, np.int32)
    left = np.setdiff1d(np.arange(msh.topology.index_map(tdim).size_local, dtype=np.int32), cells)
    if not left.size:
        return True, ""
    at = ", ".join(f"{c:.6g}" for c in dolfinx.mesh.compute_midpoints(msh, tdim, left[:1])[0])
    return False, (f"a: the bilinear form does not integrate over the cell at ({at}) (nor over {left.size - 1} more "
                   "of this rank's): every cell needs its stiffness (a dx without a subdomain, or every cell tag)")
