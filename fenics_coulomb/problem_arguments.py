"""The API's own arguments of :class:`~fenics_coulomb.problem.ContactProblem`, checked before anything is built: the
options prefix, the Dirichlet conditions' container, the contact markers, the settings (a
:class:`~fenics_coulomb.settings.SolverSettings`, a dict of its fields or None) and the PETSc options (names and
values, then tried on a small KSP); the obstacle named by ``move`` and the placement given to ``reset``;
:func:`show` puts a user's value into a message.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from petsc4py import PETSc

import dolfinx.fem
import numpy as np
import numpy.typing as npt

from fenics_coulomb.errors import InputError
from fenics_coulomb.settings import SolverSettings

if TYPE_CHECKING:
    from fenics_coulomb.model.obstacles import Obstacle

__all__ = ["as_settings", "check_bcs", "check_contact", "check_petsc_options", "check_prefix", "form_ranks",
           "history_placement", "obstacle_index", "show"]


def form_ranks(a: object) -> int:
    """The size of the communicator of the bilinear form's mesh (1 when ``a`` is not a form: refused later)."""
    try:
        return int(a.arguments()[0].ufl_function_space().mesh.comm.size)  # type: ignore[attr-defined]
    except (AttributeError, IndexError, TypeError):
        return 1


def check_prefix(prefix: Any) -> None:
    """InputError unless ``prefix`` is a non-empty PETSc options prefix (no leading '-', no spaces)."""
    if not isinstance(prefix, str) or not prefix:
        raise InputError("petsc_options_prefix: a non-empty PETSc options prefix is required")
    if prefix.startswith("-") or any(c.isspace() for c in prefix):
        raise InputError(f"petsc_options_prefix = {prefix!r}: a PETSc options prefix neither starts "
                         "with '-' nor holds spaces (e.g. 'contact_')")


def check_bcs(bcs: Any) -> None:
    """InputError unless ``bcs`` is a sequence (of DirichletBCs: the model checks the items)."""
    if isinstance(bcs, dolfinx.fem.DirichletBC | str | bytes) or not isinstance(bcs, Sequence):
        raise InputError(f"bcs = {type(bcs).__name__}: give a list of dolfinx.fem.DirichletBC (or [])")


def check_contact(contact: Any, contact_pairs: Any) -> None:
    """InputError without a contact boundary and without pairs, or for markers that are not a sequence of values."""
    if contact is None and not contact_pairs:
        raise InputError("contact: give the facet tags and the markers of the contact boundary")
    if contact is not None and isinstance(contact, tuple | list) and len(contact) == 2 and (
            isinstance(contact[1], str | bytes) or not isinstance(contact[1], Sequence | np.ndarray)):
        raise InputError(f"contact: markers = {show(contact[1])}: give a list of facet tag values, e.g. [1]")


def obstacle_index(obstacles: Sequence[Obstacle], obstacle: Any) -> int:
    """The index of the obstacle ``move`` names (its name or index); InputError for any other value."""
    names = [getattr(o, "name", None) for o in obstacles]
    if isinstance(obstacle, str):
        if obstacle not in names:
            raise InputError(f"move: no obstacle named {obstacle!r} (obstacles: {names})")
        return names.index(obstacle)
    if isinstance(obstacle, int | np.integer) and not isinstance(obstacle, bool) and (
            0 <= int(obstacle) < len(obstacles)):
        return int(obstacle)
    raise InputError(f"move: obstacle {obstacle!r} is neither a name nor an index below {len(obstacles)}")


def history_placement(obstacles: Sequence[Obstacle], displacements: Any, rotations: Any
                      ) -> tuple[npt.NDArray[np.float64] | None, list[Obstacle] | None]:
    """``reset``'s previous placement: (δ of every obstacle, shape (obstacles, 3), or None; the obstacles moved and
    rotated as at that step, or None without rotations). InputError for a wrong shape, a non-finite δ or not one
    rotation (or None) per obstacle."""
    delta = None
    if displacements is not None:
        try:
            delta = np.asarray(displacements, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"reset: obstacle_displacements = {show(displacements)}: need finite "
                             f"values of shape ({len(obstacles)}, 3)") from None
        if delta.size == 0 and not obstacles:
            delta = delta.reshape(0, 3)
        if delta.shape != (len(obstacles), 3):
            raise InputError(f"reset: obstacle_displacements of shape {delta.shape}: need finite values of "
                             f"shape ({len(obstacles)}, 3)")
        if not np.all(np.isfinite(delta)):
            row = int(np.flatnonzero(~np.isfinite(delta).all(axis=1))[0])
            raise InputError(f"reset: obstacle_displacements[{row}] = {delta[row].tolist()}: must be finite")
    if rotations is None:
        return delta, None
    if isinstance(rotations, str | bytes) or not isinstance(rotations, Sequence) or len(rotations) != len(obstacles):
        raise InputError(f"reset: obstacle_rotations = {rotations!r}: give one rotation (or None) "
                         f"per obstacle ({len(obstacles)})")
    deltas = delta if delta is not None else np.zeros((len(obstacles), 3))
    return delta, [o.moved(d).rotated(r) for o, d, r in zip(obstacles, deltas, rotations, strict=True)]


def as_settings(settings: SolverSettings | dict[str, Any] | None) -> SolverSettings:
    """Validated settings from a SolverSettings, a dict of its fields or None (the defaults)."""
    if settings is not None and not isinstance(settings, SolverSettings | dict):
        raise InputError(f"settings = {show(settings)}: give a SolverSettings, a dict of its fields or None")
    if isinstance(settings, dict):
        unknown = [key for key in settings if key not in SolverSettings.__dataclass_fields__]
        if unknown:
            raise InputError(f"unknown solver setting(s) {sorted(map(repr, unknown))}")
        settings = SolverSettings(**settings)
    return settings or SolverSettings()  # validated where it was constructed


def show(value: Any) -> str:
    """A value as the user gave it, on one line (at most 80 characters)."""
    text = repr(value).replace("\n", " ")
    return text if len(text) <= 80 else text[:77] + "..."


def check_petsc_options(options: Any, prefix: str, parallel: bool = False) -> None:
    """InputError for ``petsc_options`` that are not a mapping of option names (without '-' and prefix) to values,
    or that PETSc refuses (an unknown KSP or PC type, …): tried on a small KSP on this rank alone, before anything
    collective (:func:`fenics_coulomb.scd.options.check_petsc_options`), then removed from the database again."""
    if options is None:
        return
    if not isinstance(options, Mapping):
        raise InputError(f"petsc_options = {show(options)}: give a dict of PETSc option names (without '-' and "
                         "prefix) to values, e.g. {'ksp_rtol': 1e-6}")
    for key, value in options.items():
        if not isinstance(key, str) or not key or key.startswith("-"):
            raise InputError(f"petsc_options: key {key!r} must be an option name without '-' and prefix, "
                             "e.g. 'ksp_monitor'")
        if value is not None and not isinstance(value, str | int | float | bool | np.integer | np.floating):
            raise InputError(f"petsc_options: {key} = {show(value)}: give a string, a number, a bool or None")
    from fenics_coulomb.scd.options import check_petsc_options as check_in_petsc

    trial = f"{prefix}apicheck_"
    database = PETSc.Options()
    names = [f"{trial}{key}" for key in options]
    try:
        for name, value in zip(names, options.values(), strict=True):
            database[name] = "" if value is None else value
        check_in_petsc(trial, parallel)
    except InputError as err:
        raise InputError(f"petsc_options: {str(err).replace('-' + trial, '')}") from None
    finally:
        for name in names:
            database.delValue(name)
