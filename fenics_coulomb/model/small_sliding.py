"""Small sliding says when it breaks: the largest slide of a contact node against its partner, in units of the
partner's size, after a solve that paired once in the reference configuration (docs/sliding, "Small sliding says
when it breaks"); a warning above :data:`SMALL_SLIDE_WARNING`."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:  # pragma: no cover
    from fenics_coulomb.model.contact_model import ContactModel

__all__ = ["SMALL_SLIDE_WARNING", "largest_slide"]

Array = npt.NDArray[np.float64]

#: Small sliding warns when a contact node has slid farther than this many partner sizes (:func:`largest_slide`).
SMALL_SLIDE_WARNING = 0.5


def largest_slide(model: ContactModel, u: Array, z: Array) -> tuple[float, list[float]]:
    """Small sliding: the largest slide of a contact node against its partner, in units of the partner's size, and
    that node's reference position (collective; the same on every rank).

    A paired node's slide is its total relative tangential displacement against the master material point beneath
    it, |P w| with w = u_s − Σ_l Φ_jl u_l (the unknown z on the node) and P = I − n nᵀ, over the diameter of the
    master facet beneath it (its node-to-surface closest point's, at the pairing: the partner's size whatever the
    slave's mesh); an obstacle node's is its tangential displacement against the obstacle's translation,
    |P(u − δ)|, over the obstacle's radius (sphere, cylinder) or the node's cell diameter (a triangulated surface);
    a plane has no size (no warning).
    """
    comm = model.comm
    cmap = model.contact
    paired = model.coupling.paired_mask(cmap.size)
    n = cmap.normals
    v = np.asarray(z, dtype=np.float64).reshape(-1)[cmap.local_dofs] - np.where(
        paired[:, None], 0.0, getattr(model, "obstacle_displacement", np.zeros((cmap.size, 3))))
    slide = np.linalg.norm(v - np.einsum("ij,ij->i", n, v)[:, None] * n, axis=1) if cmap.size else np.zeros(0)
    size = model.node_size()[cmap.blocks].copy()
    for j, obstacle in enumerate(model.obstacles):
        mine = ~paired & (cmap.obstacle_index == j)
        radius = getattr(obstacle, "radius", None)
        size[mine] = np.inf if obstacle.affine else (float(radius) if radius is not None else size[mine])
    size = model.coupling.partner_sizes(size)
    ratio = slide / size
    local = (float(ratio.max()), list(map(float, cmap.coordinates[int(np.argmax(ratio))]))) if ratio.size \
        else (0.0, [])
    best = max(comm.allgather(local), key=lambda r: r[0])
    return best
