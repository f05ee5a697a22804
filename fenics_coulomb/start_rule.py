r"""The start of a solve: the rule that picks the first iterate of a step without a history, and a displacement
taken from another mesh.

**The start rule** (``settings.start = "auto"``, :func:`auto_start`): the paper's u⁽⁰⁾ = 0 of the shifted unknown
("zero", ũ = −d) or the undeformed body ("undeformed", ũ = 0), chosen from where the undeformed body's residual
lies (one approximation step at ũ = 0, no product with A, no linear solve).

ŷ(ũ = 0) (:meth:`~fenics_coulomb.scd.newton.SCDNewtonSolver.undeformed`) has a
part in the contact nodes' rows, ‖ŷ_c‖ — obstacles overlapping the body at rest, or loads on the contact
nodes themselves — and one in the free rows, ‖ŷ_f‖ = (‖ŷ‖² − ‖ŷ_c‖²)^½ — loads and prescribed
displacements not yet carried by the body. The start is "zero" (every contact node on its obstacle) when
the free part is the larger, "undeformed" otherwise (and when ŷ(ũ = 0) = 0, where ũ = 0 is the solution):

* Driven by its loads, the whole body moves toward its obstacles; from ũ = 0, where every contact node is
  open, the first Newton direction is the free elastic response, which runs through the obstacles, and
  the line search creeps (the paper's cuboid at ν = 0.499, lev 5: ‖ŷ‖ stays within 10 % of ‖ŷ(0)‖ for the
  first 6 Newton steps, 19 in all against 14 from the paper's start). The paper's start is the discretization's
  own image of that motion: measured ‖ŷ_c‖/‖ŷ‖ ≈ 0.02 at ũ = 0 on the cuboid (ν = 0.3 and 0.499, every
  gap and load case), 0.07 on a roller pressed onto a plane, 0 for two bodies pressed together.
* Driven by its obstacles (an indenter displaced into the body, no load), ŷ(ũ = 0) lies in the contact
  rows (‖ŷ_c‖/‖ŷ‖ = 1 on every sphere, cylinder and plate case of docs/robustness) and the body at rest is
  right away from the indentation; the paper's start moves every contact node onto the indenter, up to
  the largest gap away (7–15 Newton steps from ũ = 0 against 12–28 from the paper's on the single solves
  of docs/robustness).

The smaller of the two starts' residuals ‖ŷ⁽⁰⁾‖ does not tell them apart: the paper's start has the larger
one on every case measured (the cuboid 7–2300×, whose Newton iteration it nevertheless shortens),
because its misfit A d is one the first Newton step removes.

**A displacement on another mesh** (:func:`interpolate_displacement`): a start given by the user, a coarser
level's solution of nested iteration, a load path resumed from a file.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.dof_values import owned_values
from fenics_coulomb.problem_arguments import show as _show

if TYPE_CHECKING:
    from fenics_coulomb.scd.newton import SCDNewtonSolver

__all__ = ["INTERPOLATION_PADDING", "interpolate_displacement", "auto_start"]


#: Nodes of the target mesh this fraction of the source mesh's largest cell outside it still take a value
#: (:func:`interpolate_displacement`).
INTERPOLATION_PADDING = 0.1


def interpolate_displacement(
    u_from: dolfinx.fem.Function, V: dolfinx.fem.FunctionSpace, padding: float | None = None
) -> npt.NDArray[np.float64]:
    """Interpolate a (possibly non-matching) vector field onto V; return V's owned DOF values (collective).

    Nodes up to ``padding`` outside the other mesh (default INTERPOLATION_PADDING times its largest cell extent)
    take the value of the closest cell, extended: a curved boundary (the cuboid's wavy bottom) puts the finer
    mesh's boundary nodes up to O(h²) outside the coarser mesh, where a padding of round-off size found no cell
    and left them 0.

    Raises:
        InputError: when ``u_from`` is not a vector Function of 3 components (the same on every rank).
    """
    if not isinstance(u_from, dolfinx.fem.Function) or u_from.function_space.dofmap.index_map_bs != 3:
        raise InputError(f"displacement = {_show(u_from)}: give a dolfinx.fem.Function of a 3-component "
                         "vector space (on any mesh)")
    u = dolfinx.fem.Function(V)
    tdim = V.mesh.topology.dim
    cells = np.arange(V.mesh.topology.index_map(tdim).size_local, dtype=np.int32)
    if u_from.function_space.mesh is V.mesh:
        u.interpolate(u_from)
    else:
        if padding is None:
            source = u_from.function_space.mesh
            x = source.geometry.x[source.geometry.dofmap].reshape(-1, source.geometry.dofmap.shape[1], 3)
            extent = float(np.max(x.max(axis=1) - x.min(axis=1), initial=0.0))
            padding = INTERPOLATION_PADDING * source.comm.allreduce(extent, op=MPI.MAX)
        data = dolfinx.fem.create_interpolation_data(V, u_from.function_space, cells, padding=padding)
        u.interpolate_nonmatching(u_from, cells, data)
    u.x.scatter_forward()
    return owned_values(u)


def auto_start(solver: SCDNewtonSolver) -> tuple[str, str]:
    """The start of ``settings.start = "auto"`` for the loads and obstacles as placed (see the module docstring):
    ("zero" or "undeformed", the line that says why, for the log); collective."""
    zero = solver.undeformed()
    contact = solver.contact_norm(zero.e)
    free = math.sqrt(max(zero.residual**2 - contact**2, 0.0))
    choice = "zero" if free > contact else "undeformed"
    return choice, (f"start (auto): {choice} (|y(u = 0)| = {zero.residual:.3e}: contact rows {contact:.3e}, free rows "
                    f"{free:.3e})")
