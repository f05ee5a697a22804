"""Where the rigid obstacles are at a placement, as the contact nodes see them: the checks of a placement (a buried
obstacle, one moved or turned through the body), the closest obstacle of every contact node with its gap and frame,
and the tangential offset of a load path's step (:meth:`ContactModel.place
<fenics_coulomb.model.contact_model.ContactModel.place>` derives the shift from them)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.contact_map import ContactMap, boundary_blocks
from fenics_coulomb.model.mesh_checks import BodyLocator, displaced_geometry
from fenics_coulomb.model.obstacle_checks import check_solid_side, core_path, rotation_text
from fenics_coulomb.model.obstacles import Obstacle, closest_obstacle

__all__ = ["FARTHEST", "ObstaclePlacement", "previous_placements"]

#: How far an obstacle may be placed or moved, in units of the body's size (its largest absolute coordinate): a
#: node's gap to an obstacle at distance D carries a round-off of about 1e-16 D, and D = 1e12 sizes leaves 1e-4 of
#: the body's size. A sphere at 1e200 gave a residual of inf - inf (NaN) and a traceback.
FARTHEST = 1e12


def previous_placements(obstacles: Sequence[Obstacle], previous: Any) -> list[Obstacle] | None:
    """The previous placements of the obstacles when a rotation is involved (now or then), else None (the
    translation-only offsets δ_k − δ_{k−1} apply, bit for bit): ``previous`` is None (the scene position), the
    previous δ per obstacle (no rotation then), or the previous obstacles themselves."""
    if previous is not None and len(previous) and isinstance(previous[0], Obstacle):
        before = list(previous)
    elif previous is None:
        before = [o.at_scene_position().rotated(None) for o in obstacles]
    else:
        deltas = np.asarray(previous, dtype=np.float64).reshape(-1, 3)
        before = [o.moved(d).rotated(None) for o, d in zip(obstacles, deltas, strict=True)]
    rotating = any(getattr(o, "rotation", None) is not None for o in [*obstacles, *before])
    return before if rotating else None



def _same_placements(a: tuple, b: tuple) -> bool:
    """Whether two (obstacles, previous placements) keys of :meth:`ObstaclePlacement.check_motion` are the same
    placements: the same obstacle objects (placed obstacles are immutable; a move makes new ones) and the same
    previous obstacles or displacements."""
    def same(x: Any, y: Any) -> bool:
        if x is None or y is None or isinstance(x, bytes) or isinstance(y, bytes):
            return x == y
        return len(x) == len(y) and all(p is q for p, q in zip(x, y))
    return same(a[0], b[0]) and same(a[1], b[1])


class ObstaclePlacement:
    """The obstacles' side of a model's placements: the checks of every placement and the closest points of the
    contact nodes, remembered for the last evaluation (the geometry check of finite sliding and the next placement
    ask again for the same points).

    Args:
        mesh: The body's mesh (the reference configuration).
        obstacles: The obstacles at construction (a body locator is built when one has a core that can be buried).
        size: The mesh's size (the largest absolute coordinate): round-off below a surface counts as touching.
    """

    def __init__(self, mesh: dolfinx.mesh.Mesh, obstacles: Sequence[Obstacle], size: float) -> None:
        self.mesh = mesh
        self.comm: MPI.Comm = mesh.comm
        self.size = size
        #: Where the body is: rejects obstacles buried in it or moved through it (:meth:`check_motion`).
        self._locator = BodyLocator(mesh) if any(o.core(np.zeros(3), np.ones(3), 2).size for o in obstacles) \
            else None
        self._scene_obstacles: list[Obstacle] | None = None
        self._closest_cache: tuple | None = None  # (obstacles, points, closest_obstacle's result, resolution)
        #: The configuration's own displacement error (a length; 0: the reference configuration, exact), to which
        #: :meth:`place` decides a triangulated surface's ties (:meth:`ContactModel.configure` sets it).
        self.resolution = 0.0
        self._motion_checked: tuple | None = None  # the placements check_motion passed last
        self._material_cache: tuple | None = None  # (obstacle, points, its closest points)
        self._boundary: tuple[npt.NDArray[np.int32], npt.NDArray[np.float64]] | None = None

    def boundary(self, V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags, markers: Sequence[int]
                 ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.float64]]:
        """The owned nodes of the obstacles' contact boundary (ascending; contact nodes or not) and their reference
        coordinates (computed once; collective the first time)."""
        if self._boundary is None:
            blocks = boundary_blocks(V, facet_tags, list(markers)) if markers else np.zeros(0, np.int32)
            blocks = blocks[blocks < V.dofmap.index_map.size_local].astype(np.int32)
            self._boundary = (blocks, V.tabulate_dof_coordinates()[blocks])
        return self._boundary

    def check_supported(self, obstacles: Sequence[Obstacle], V: dolfinx.fem.FunctionSpace,
                        facet_tags: dolfinx.mesh.MeshTags, markers: Sequence[int], held: npt.NDArray[np.bool_],
                        dirichlet_rows: npt.NDArray[np.int32], values: npt.NDArray[np.float64]) -> None:
        """InputError on every rank (collective) for a node of the obstacles' contact boundary that the supports hold
        inside an obstacle, whatever its free components do: its three components held, or against a plane the
        components along the plane's normal (a support that drives the body into the obstacle; a clamped node inside
        an obstacle moved onto it). ``held`` per local node and component, ``values`` the supports' values at
        ``dirichlet_rows``."""
        blocks, x = self.boundary(V, facet_tags, markers)
        some = held[blocks].any(axis=1)
        u = np.zeros(3 * V.dofmap.index_map.size_local)
        u[dirichlet_rows] = values
        at = x[some] + u.reshape(-1, 3)[blocks[some]]
        free = ~held[blocks][some]
        message, worst = "", 1e-8 * self.size
        for obstacle in obstacles:
            g, n, _ = obstacle.evaluate(at) if at.size else (np.zeros(0), np.zeros((0, 3)), None)
            # the free components cannot move the node off: none (three held), or a plane's normal has none
            fixed = ~free.any(axis=1) | (obstacle.affine & ~np.any(free & (np.abs(n) > 1e-12), axis=1))
            g = np.where(fixed, g, np.inf)
            if g.size and -g.min() > worst:
                i = int(np.argmin(g))
                worst = -float(g[i])
                where = ", ".join(f"{c:.6g}" for c in x[some][i])
                message = (f"the supports hold the contact-boundary node at ({where}) {worst:.4g} inside obstacle "
                           f"{obstacle.label} (the components they hold put it there, and it is no contact node): a "
                           "prescribed or clamped boundary that drives the body into an obstacle; move the support "
                           "off the obstacle, or leave the node out of it")
        everyone = [(d, m) for d, m in self.comm.allgather((worst, message)) if m]
        check_all(self.comm, not everyone, max(everyone)[1] if everyone else "")

    def closest(self, obstacles: Sequence[Obstacle], x: npt.NDArray[np.float64], resolution: float = 0.0
                ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.float64], npt.NDArray[np.float64],
                           npt.NDArray[np.float64]]:
        """:func:`~fenics_coulomb.model.obstacles.closest_obstacle` of the points ``x`` known to ``resolution``,
        remembered for the last obstacles, points and resolution: the geometry check of finite sliding and the next
        placement ask for the same (copies returned)."""
        cached = self._closest_cache
        if cached is not None and len(cached[0]) == len(obstacles) and all(
                a is b for a, b in zip(cached[0], obstacles)) and np.array_equal(cached[1], x) \
                and cached[3] == resolution:
            result = cached[2]
        else:
            result = closest_obstacle(obstacles, x, resolution)
            self._closest_cache = (list(obstacles), np.array(x, copy=True), result, resolution)
        return tuple(np.array(r, copy=True) for r in result)  # type: ignore[return-value]

    def material_point(self, obstacle: Obstacle, x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """``obstacle.closest_point(x)``, remembered for the last obstacle and points: a rotating obstacle's
        material point beneath a node at the previous step is the same at every geometry update of a step."""
        cached = self._material_cache
        if cached is not None and cached[0] is obstacle and np.array_equal(cached[1], x):
            return np.array(cached[2], copy=True)
        point = obstacle.closest_point(x)
        self._material_cache = (obstacle, np.array(x, copy=True), np.array(point, copy=True))
        return point

    def check_motion(self, obstacles: Sequence[Obstacle], previous_displacements: Any,
                     configuration: tuple[dolfinx.fem.FunctionSpace, npt.NDArray[np.float64]] | None = None) -> None:
        """InputError on every rank (collective) for obstacles whose placement the contact nodes cannot see:

        * at the first placement, an obstacle at its scene position with the whole body inside it (a plane or an
          open surface whose solid side is the body's side;
          :func:`~fenics_coulomb.model.obstacle_checks.check_solid_side`);
        * an obstacle whose core (a sphere's centre, a cylinder's axis, the deepest part of a closed surface) lies
          inside the body at its placement, or passes through the body on its rigid motion — translation and
          rotation (:func:`~fenics_coulomb.model.obstacle_checks.core_path`) — from the previous placement
          (``previous_displacements``: the previous obstacles, their δ, or None for the scene position): a buried
          obstacle, or one moved or turned across the body within one step, which the contact nodes, all on one
          side, would not see. The body is where the contact geometry is evaluated: ``configuration`` (V and the
          displacement u of its local DOFs: the body at X + u, finite sliding at the start of a step) or the
          reference configuration X (None).
        """
        for k, obstacle in enumerate(obstacles):
            rotation = getattr(obstacle, "rotation", None)
            far = max(abs(c) for c in (*obstacle.placed, *obstacle.displacement,
                                       *(rotation[2] if rotation is not None else ())))
            if far > FARTHEST * self.size:
                raise InputError(f"obstacle {k + 1} ({obstacle.label}): placed at {list(obstacle.placed)} "
                                 f"(displacement {list(obstacle.displacement)}, rotation "
                                 f"{rotation_text(obstacle)}), {far / self.size:.3g} times the "
                                 f"body's size {self.size:.6g}: farther than {FARTHEST:g} times it, where double "
                                 "precision no longer resolves the body against it")
        if self._scene_obstacles is None:
            self._scene_obstacles = [o.moved(np.zeros(3)) for o in obstacles]
            check_solid_side(obstacles, self.mesh.geometry.x, self.comm, self.size)
        if self._locator is None:
            return
        # the check depends on the placements only (the body's reference mesh): once per placement, not again at
        # every geometry update of finite sliding
        if previous_displacements is None or (len(previous_displacements) and
                                              isinstance(previous_displacements[0], Obstacle)):
            previous_key: Any = None if previous_displacements is None else tuple(previous_displacements)
        else:
            previous_key = np.asarray(previous_displacements, dtype=np.float64).tobytes()
        key = (tuple(obstacles), previous_key)
        if self._motion_checked is not None and _same_placements(self._motion_checked, key):
            return
        if configuration is None:
            self._check_paths(obstacles, previous_displacements, self._locator)
        else:
            with displaced_geometry(*configuration):
                self._check_paths(obstacles, previous_displacements, BodyLocator(self.mesh))
        self._motion_checked = key

    def _check_paths(self, obstacles: Sequence[Obstacle], previous_displacements: Any, loc: BodyLocator) -> None:
        """InputError (collective) for the first obstacle whose core lies in the body ``loc`` locates, or passes
        through it from its previous placement (:meth:`check_motion`)."""
        if previous_displacements is None:
            before = list(self._scene_obstacles or [])
        elif len(previous_displacements) and isinstance(previous_displacements[0], Obstacle):
            before = list(previous_displacements)
        else:
            deltas = np.asarray(previous_displacements, dtype=np.float64).reshape(-1, 3)
            before = [o.moved(d).rotated(None) for o, d in zip(obstacles, deltas, strict=True)]
        for k, (obstacle, previous) in enumerate(zip(obstacles, before, strict=True)):
            points, t = core_path(previous, obstacle, loc.lo, loc.hi, 0.5 * loc.spacing)
            if not points.size:
                continue
            hit = loc.first_inside(points)
            if hit < 0:
                continue
            core = {"sphere": "centre", "cylinder": "axis"}.get(obstacle.kind, "deepest part")
            where = "(" + ", ".join(f"{c:.6g}" for c in points[hit]) + ")"
            then, now = previous.displacement, obstacle.displacement
            moved = then != now or \
                getattr(previous, "rotation", None) != getattr(obstacle, "rotation", None)
            if moved and t[hit] < 1.0:
                turned = "" if getattr(previous, "rotation", None) == getattr(obstacle, "rotation", None) else \
                    f" and from rotation {rotation_text(previous)} to {rotation_text(obstacle)}"
                what = (f"its {core} would pass through the body at {where} on its way from displacement "
                        f"{list(then)} to {list(now)}{turned}: move it around "
                        "the body, not through it, or in smaller steps")
            else:
                what = (f"its {core} lies inside the body at {where} (displacement {list(now)}): "
                        "an obstacle buried in the body, or indenting it too deep")
            raise InputError(f"obstacle {k + 1} ({obstacle.label}): {what}")

    def buried(self, obstacles: Sequence[Obstacle], V: dolfinx.fem.FunctionSpace, u: npt.NDArray[np.float64],
               shift: npt.ArrayLike = (0.0, 0.0, 0.0), previous: npt.ArrayLike | None = None) -> str:
        """"" unless an obstacle's core lies inside the body at X + ``u`` (the ghosted physical displacement), or
        passed through it on the body's motion within the solve (``shift``: the body's mean displacement over the
        solve, ``previous`` the obstacles' δ before it, default theirs now: relative to the body at its end each core
        came from previous δ + shift to its place), else what: a body moved onto or past
        an obstacle within one solve, whose contact nodes, all on one side, never met it (collective)."""
        if self._locator is None:
            return ""
        with displaced_geometry(V, u):
            loc = BodyLocator(self.mesh)
            for k, obstacle in enumerate(obstacles):
                start = np.asarray(obstacle.displacement if previous is None else np.asarray(previous)[k], dtype=float)
                before = obstacle.moved(start + np.asarray(shift, dtype=np.float64))
                points, _ = core_path(before, obstacle, loc.lo, loc.hi, 0.5 * loc.spacing)
                hit = loc.first_inside(points) if points.size else -1
                if hit >= 0:
                    core = {"sphere": "centre", "cylinder": "axis"}.get(obstacle.kind, "deepest part")
                    where = ", ".join(f"{c:.6g}" for c in points[hit])
                    return (f"obstacle {k + 1} ({obstacle.label}): its {core} lies inside the deformed body at "
                            f"({where}), or passed through it as the body moved (by "
                            f"({', '.join(f'{c:.4g}' for c in np.asarray(shift, dtype=np.float64))}) on "
                            "average) within one solve, its contact nodes never meeting it; give the motion in "
                            "substeps ([[path.step]] substeps)")
        return ""

    def place(self, cmap: ContactMap, rigid: npt.NDArray[np.intp], obstacles: Sequence[Obstacle],
              configuration: npt.NDArray[np.float64] | None, previous_displacement: npt.NDArray[np.float64] | None,
              previous_obstacles: list[Obstacle] | None, previous_obstacle_displacements: npt.ArrayLike | None,
              offset: npt.NDArray[np.float64], obstacle_displacement: npt.NDArray[np.float64]) -> None:
        """The obstacles' contact nodes ``rigid`` of ``cmap`` placed (their obstacle, gap and frame, linearized
        about ``configuration``, the ghosted physical displacement, when given), their obstacle's displacement δ
        into ``obstacle_displacement`` and their tangential offset (δ_k − δ_{k−1}, or the motion of their
        material point of a rotating obstacle) into ``offset`` (collective for surface obstacles)."""
        if not rigid.size:
            return
        finite = configuration is not None
        X = cmap.coordinates[rigid]
        u = configuration.reshape(-1, 3)[cmap.blocks[rigid]] if configuration is not None else np.zeros((rigid.size, 3))
        index, gap, _, frames = self.closest(obstacles, X + u if finite else X, self.resolution if finite else 0.0)
        # round-off below the surface (e.g. from mesh generators) counts as touching
        gap[(gap < 0.0) & (gap > -1e-12 * self.size)] = 0.0
        if finite:  # linearized about the configuration: g(X + u_c) + n·(u − u_c)
            gap = gap - np.einsum("ij,ij->i", frames[:, :, 2], u)
            for j, obstacle in enumerate(obstacles):
                mine = index == j
                if obstacle.affine and np.any(mine):  # g(X + u_c) − n·u_c = g(X) exactly, frames constant
                    g0, _, frames[mine] = obstacle.evaluate(X[mine])
                    gap[mine] = np.where((g0 < 0.0) & (g0 > -1e-12 * self.size), 0.0, g0)
        cmap.obstacle_index[rigid], cmap.gap[rigid], cmap.frames[rigid] = index, gap, frames
        delta = np.array([o.displacement for o in obstacles], dtype=np.float64).reshape(-1, 3)
        obstacle_displacement[rigid] = delta[index]
        offset[rigid] = delta[index]
        if previous_obstacles is not None:  # a rotation: each node's material point of its obstacle
            x = X if not (finite and previous_displacement is not None) else \
                X + np.asarray(previous_displacement, dtype=np.float64).reshape(-1, 3)[rigid]
            moved = np.zeros((rigid.size, 3))
            for j, (now, before) in enumerate(zip(obstacles, previous_obstacles, strict=True)):
                mine = index == j
                if np.any(mine):
                    moved[mine] = now.motion(before, self.material_point(before, x[mine]))
            offset[rigid] = moved
        elif previous_obstacle_displacements is not None:
            previous = np.asarray(previous_obstacle_displacements, dtype=np.float64).reshape(-1, 3)
            offset[rigid] -= previous[index]
