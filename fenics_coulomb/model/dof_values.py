"""A Function's owned DOF values, read and written without a PETSc vector.

DOLFINx creates a ``Function``'s PETSc vector lazily (``u.x.petsc_vec``) and destroys it in the vector's
``__del__``, that is whenever Python's garbage collector frees the Function. On several ranks the cyclic
collector runs at different moments on each rank; when that vector is the last PETSc object on the mesh's
communicator, PETSc frees its inner communicator on one rank only, and the next PETSc object created on
that mesh duplicates the communicator on that rank alone while the other ranks enter the object's own
collectives: the ranks deadlock (both spinning in DOLFINx's ``create_petsc_vector``). The package therefore
never creates a Function's PETSc vector; it reads and writes the owned values through ``u.x.array``.
"""

from __future__ import annotations

import dolfinx.fem
import numpy as np
import numpy.typing as npt

__all__ = ["owned_size", "owned_values", "set_owned_values"]


def owned_size(u: dolfinx.fem.Function) -> int:
    """The number of DOF values ``u`` owns on this rank (blocks × block size, no ghosts)."""
    imap = u.function_space.dofmap.index_map
    return int(imap.size_local * u.function_space.dofmap.index_map_bs)


def owned_values(u: dolfinx.fem.Function) -> npt.NDArray[np.float64]:
    """A copy of the DOF values ``u`` owns on this rank (the PETSc vector's local array, without creating it)."""
    return np.array(u.x.array[:owned_size(u)], copy=True)


def set_owned_values(u: dolfinx.fem.Function, values: npt.ArrayLike) -> dolfinx.fem.Function:
    """Set the DOF values ``u`` owns on this rank and update the ghosts from their owners (collective).

    Returns:
        ``u``.
    """
    n = owned_size(u)
    u.x.array[:n] = np.ravel(np.asarray(values, dtype=u.x.array.dtype))
    u.x.scatter_forward()
    return u
