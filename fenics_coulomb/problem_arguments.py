"""The API's own arguments of :class:`~fenics_coulomb.problem.ContactProblem`, checked before anything is built: the
settings (a :class:`~fenics_coulomb.settings.SolverSettings`, a dict of its fields or None) and the PETSc options
(names and values, then tried on a small KSP); :func:`show` puts a user's value into a message.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from petsc4py import PETSc

import numpy as np

from fenics_coulomb.errors import InputError
from fenics_coulomb.settings import SolverSettings

__all__ = ["as_settings", "check_petsc_options", "show"]


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
