"""The loads of a load path's steps: each step's loads as plain data, and the load form's coefficients set to a
blend of two of them in place.

* :class:`LoadState`: every load of one step as plain data (tractions per boundary, body force, prescribed values
  per boundary, δ and rotation per scene obstacle); :func:`scene_state`, :func:`step_state`, :func:`zero_state`
  make them from a scene (what a ``[[path.step]]`` does not set takes the SCENE's value); :func:`blend_vector`
  and :func:`blend_rotation` blend two of them (the substeps of :mod:`fenics_coulomb.scenes.path`).
* :class:`StepLoads`: the load coefficients of the form (a vector Constant per boundary with constant tractions, a
  P1 Function where any state gives expressions, a body-force Constant, a Constant per prescribed boundary held
  by its DirichletBC), set to the blend (1 − w)·start + w·end of two states.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import numpy as np
import numpy.typing as npt
import ufl

from fenics_coulomb.errors import InputError, check_all
from fenics_coulomb.model.obstacle_checks import same_point
from fenics_coulomb.model.obstacles import _rotation
from fenics_coulomb.scenes.scene import FREE, MAX_LOAD, PathStep, Scene

__all__ = ["ZERO", "LoadState", "StepLoads", "blend_rotation", "blend_vector", "plain_rotation", "scene_state",
           "step_state", "zero_state"]

#: A traction: three components, each a number or a function of points x (shape (3, m)).
Traction = tuple[Any, Any, Any]
ZERO = (0.0, 0.0, 0.0)

@dataclass(frozen=True)
class LoadState:
    """All loads of one step (GPa, the mesh's length unit).

    Attributes:
        tractions: Boundary name → traction (numbers or callables of x; the load scale applied).
        body_force: The body force.
        prescribed: Boundary name → prescribed displacement (every boundary of the scene's ``[prescribed]``).
        obstacles: δ of each scene obstacle, in scene order.
        rotations: The rotation [angle_deg, axis, centre] of each scene obstacle (None: none), in scene order.
    """

    tractions: dict[str, Traction]
    body_force: tuple[float, float, float]
    prescribed: dict[str, tuple[float, float, float]]
    obstacles: tuple[tuple[float, float, float], ...]
    rotations: tuple[Any, ...] = ()


def _vec(value: Sequence[float]) -> tuple[float, float, float]:
    return (float(value[0]), float(value[1]), float(value[2]))


def _held(value: Sequence[float | str]) -> tuple[float, float, float]:
    """A ``[prescribed]`` value as 3 numbers ("free" components, which no condition holds, as 0)."""
    return _vec([0.0 if c == FREE else c for c in value])  # type: ignore[misc]


def scene_state(scene: Scene) -> LoadState:
    """The scene's own loads (its static problem)."""
    return LoadState(tractions=dict(scene.traction_table()), body_force=_vec(scene.load.body_force),
                     prescribed={k: _held(v) for k, v in scene.prescribed.items()},
                     obstacles=tuple(_vec(o.displacement) for o in scene.obstacles),
                     rotations=tuple(getattr(o, "rotation", None) for o in scene.obstacles))


def zero_state(scene: Scene) -> LoadState:
    """Step 0 of every path: no load, δ = 0, prescribed displacements 0."""
    return LoadState(tractions={}, body_force=ZERO, prescribed={k: ZERO for k in scene.prescribed},
                     obstacles=tuple(ZERO for _ in scene.obstacles), rotations=tuple(None for _ in scene.obstacles))


def step_state(scene: Scene, step: PathStep) -> LoadState:
    """The loads of a ``[[path.step]]``: its values, and the scene's where it sets none (per boundary for
    tractions and prescribed displacements, per obstacle for δ)."""
    base = scene_state(scene)
    tractions = {**base.tractions, **{k: scene.scaled_traction(k, v) for k, v in step.tractions.items()}}
    names = [getattr(o, "name", None) for o in scene.obstacles]
    obstacles = tuple(_vec(step.move[name]) if name is not None and name in step.move else delta
                      for name, delta in zip(names, base.obstacles, strict=True))
    rotations = tuple(_rotation(step.rotate[name], f"[[path.step]] rotate of {name!r}")
                      if name is not None and name in step.rotate else rotation
                      for name, rotation in zip(names, base.rotations, strict=True))
    return LoadState(tractions=tractions,
                     body_force=base.body_force if step.body_force is None else _vec(step.body_force),
                     prescribed={k: _held(step.prescribed.get(k, v)) for k, v in base.prescribed.items()},
                     obstacles=obstacles, rotations=rotations)


def blend_rotation(a: Any, b: Any, w: float) -> Any:
    """The rotation between ``a`` and ``b`` at weight w: the angle blended about b's axis and centre (a None is
    the angle 0 about them); two rotations about different axes or centres cannot be blended (InputError)."""
    if b is None and a is None:
        return None
    if a is None:
        a = (0.0, b[1], b[2])
    if b is None:
        b = (0.0, a[1], a[2])
    if w == 1.0:
        return b
    if w == 0.0:
        return a
    if not (np.allclose(a[1], b[1], rtol=0, atol=1e-12) and same_point(a[2], b[2])):
        raise InputError(f"substeps between rotations about different axes or centres ({a} and {b}): give the "
                         "step one substep, or rotate about one axis and centre")
    return (_blend(a[0], b[0], w), b[1], b[2])


def plain_rotation(rotation: Any) -> list | None:
    """A rotation as plain JSON data [angle_deg, [ax, ay, az], [cx, cy, cz]] (None: none)."""
    if rotation is None:
        return None
    angle, axis, centre = rotation
    return [float(angle), [float(c) for c in axis], [float(c) for c in centre]]


def _blend(a: float, b: float, w: float) -> float:
    """(1 − w)·a + w·b: exactly b at w = 1, exactly a at w = 0."""
    return (1.0 - w) * a + w * b


def blend_vector(a: Sequence[float], b: Sequence[float], w: float) -> tuple[float, float, float]:
    """Component-wise :func:`_blend` of two 3-vectors."""
    return (_blend(a[0], b[0], w), _blend(a[1], b[1], w), _blend(a[2], b[2], w))


class StepLoads:
    """The load coefficients of a scene's load form, updated in place for each solve of a path.

    Per boundary a vector ``Constant`` (constant tractions) or a P1 ``Function`` (where any of the given
    states has an expression), a body-force ``Constant``, and a ``Constant`` per prescribed boundary (the
    value its DirichletBC holds: give ``prescribed`` to the builder's Dirichlet conditions). Constructed
    with the values of ``initial`` (the scene's static problem), so that a static scene's form is that of a
    plain build.

    Args:
        V: The displacement space.
        facet_tags: The boundary facet tags.
        tags: Boundary name → facet tag.
        initial: The state whose values the coefficients start with.
        states: Every state a path may blend (decides which boundaries carry a Function); the boundaries of
            all states get a coefficient.
    """

    def __init__(self, V: dolfinx.fem.FunctionSpace, facet_tags: dolfinx.mesh.MeshTags, tags: dict[str, int],
                 initial: LoadState, states: Sequence[LoadState] = ()) -> None:
        msh = V.mesh
        self.V = V
        self.facet_tags = facet_tags
        self.tags = dict(tags)
        boundaries = list(initial.tractions)
        for state in states:
            boundaries += [name for name in state.tractions if name not in boundaries]
        fields = {name for state in (initial, *states) for name, value in state.tractions.items()
                  if any(callable(c) for c in value)}
        #: Boundary name → its traction coefficient (Constant or P1 Function).
        self.tractions: dict[str, dolfinx.fem.Constant | dolfinx.fem.Function] = {}
        for name in boundaries:
            if name in fields:
                self.tractions[name] = dolfinx.fem.Function(V)
            else:
                self.tractions[name] = dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))
        self.body_force = dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))
        #: Prescribed boundary name → the Constant its DirichletBC holds.
        self.prescribed = {name: dolfinx.fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))
                           for name in initial.prescribed}
        #: Prescribed boundary name → a scalar Constant per component (the values of the conditions on single
        #: components, ``V.sub(i)``, of a boundary with "free" components), set with :attr:`prescribed`.
        self.prescribed_components = {name: [dolfinx.fem.Constant(msh, PETSc.ScalarType(0.0)) for _ in range(3)]
                                      for name in initial.prescribed}
        # keyed by the traction itself (numbers and callables, held by the key): an id() of a state could be
        # reused by a later state once the first is freed, and hand it the first state's field
        self._cache: dict[Traction, npt.NDArray[np.float64]] = {}
        for state in (initial, *states):  # every expression evaluated and checked before anything is solved
            for name in fields & set(state.tractions):
                self._check_field(name, state.tractions[name], self._field(state, name))
        self.apply(initial, initial, 1.0)

    def _check_field(self, name: str, traction: Traction, values: npt.NDArray[np.float64]) -> None:
        """InputError on every rank unless the traction ``name`` is finite and at most MAX_LOAD at every node of
        its boundary (collective): an expression that overflows or divides by zero there would give a load of
        inf or 1e300 that no solver reports."""
        V = self.V
        facets = self.facet_tags.find(self.tags[name])
        blocks = dolfinx.fem.locate_dofs_topological(V, V.mesh.topology.dim - 1, facets)
        blocks = blocks[blocks < V.dofmap.index_map.size_local]
        at = values.reshape(-1, 3)[blocks]
        bad = np.flatnonzero(~(np.all(np.isfinite(at), axis=1) & np.all(np.abs(at) <= MAX_LOAD, axis=1)))
        message = ""
        if bad.size:
            x = V.tabulate_dof_coordinates()[blocks[bad[0]]]
            text = [getattr(c, "__name__", c) if callable(c) else c for c in traction]
            message = (f"traction on {name!r} = {text}: {at[bad[0]].tolist()} at the boundary node "
                       f"({', '.join(f'{c:.6g}' for c in x)}) is not finite or exceeds {MAX_LOAD:g} GPa in magnitude")
        check_all(V.mesh.comm, not message, message)

    def form(self, v: ufl.Argument) -> ufl.Form:
        """The load form ∫ f·v dx + Σ ∫ t_b·v ds(b) on the coefficients (built once)."""
        msh = self.V.mesh
        ds = ufl.Measure("ds", domain=msh, subdomain_data=self.facet_tags)
        L = ufl.inner(self.body_force, v) * ufl.dx
        for name, coefficient in self.tractions.items():
            L = L + ufl.inner(coefficient, v) * ds(self.tags[name])
        return L

    def _field(self, state: LoadState, name: str) -> npt.NDArray[np.float64]:
        """The traction of ``state`` on ``name`` interpolated into P1 (cached per traction; local array)."""
        value = key = tuple(state.tractions.get(name, ZERO))
        if key not in self._cache:
            g = dolfinx.fem.Function(self.V)
            g.interpolate(lambda x: np.vstack(
                [c(x) if callable(c) else np.full(x.shape[1], float(c)) for c in value]))
            self._cache[key] = g.x.array.copy()
        return self._cache[key]

    def apply(self, start: LoadState, end: LoadState, weight: float) -> None:
        """Set every coefficient to (1 − weight)·start + weight·end (no communication)."""
        for name, coefficient in self.tractions.items():
            if isinstance(coefficient, dolfinx.fem.Function):
                a, b = self._field(start, name), self._field(end, name)
                coefficient.x.array[:] = b if weight == 1.0 else (1.0 - weight) * a + weight * b
            else:
                coefficient.value[:] = blend_vector(start.tractions.get(name, ZERO),
                                                    end.tractions.get(name, ZERO), weight)
        self.body_force.value[:] = blend_vector(start.body_force, end.body_force, weight)
        for name, constant in self.prescribed.items():
            constant.value[:] = blend_vector(start.prescribed.get(name, ZERO), end.prescribed.get(name, ZERO), weight)
            for component, value in zip(self.prescribed_components[name], constant.value, strict=True):
                component.value = value
