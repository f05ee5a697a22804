"""PETSc options from the command line: only ``-coulomb_*`` options, checked on a small KSP set up like the
solver's before anything is solved (an option PETSc refuses, or a value out of range, is an InputError),
removed again when the command ends."""

from __future__ import annotations

import ctypes
import functools
import re

from mpi4py import MPI
from petsc4py import PETSc

from fenics_coulomb.errors import InputError
from fenics_coulomb.scd.preconditioner import OPTION_RANGES, check_option_value
from fenics_coulomb.settings import COMMAND_PREFIX

__all__ = ["set_petsc_options", "check_petsc_options", "check_option_values", "option_read", "unread_hint"]


def set_petsc_options(tokens: list[str]) -> list[str]:
    """Put ``-coulomb_*`` options from the command line into PETSc's options database and check them.

    Only prefixed options are accepted, so nothing outside fenics-coulomb's objects is changed. The options
    are tried on a small KSP set up as the solver's (GMRES, right preconditioning, unpreconditioned norm) on
    this rank alone (no communication): an option PETSc refuses (an unknown KSP or PC type, a norm the KSP
    cannot monitor, a missing factorization package) is an InputError; the options are then removed again.

    Returns:
        The option names set (``main`` removes them when it returns, so a second in-process call starts clean).
    """
    from petsc4py import PETSc

    opts = PETSc.Options()
    pairs = _petsc_pairs(tokens)
    for key, _ in pairs:
        if not key.startswith(COMMAND_PREFIX):
            raise InputError(f"unrecognized argument -{key} (PETSc options must carry the prefix -coulomb_)")
        if key == COMMAND_PREFIX:
            raise InputError("PETSc option -coulomb_ has no name after the prefix (e.g. -coulomb_ksp_monitor)")
    for key, value in pairs:
        opts[key] = value
    try:
        check_petsc_options(COMMAND_PREFIX, MPI.COMM_WORLD.size > 1)
    except InputError:
        for key, _ in pairs:
            opts.delValue(key)
        raise
    for key, value in pairs:  # set anew: the trial KSP's reads must not count as the solver's (:func:`option_read`)
        opts.delValue(key)
        opts[key] = value
    return [key for key, _ in pairs]


def check_petsc_options(prefix: str, parallel: bool = False) -> None:
    """Set up a KSP with options prefix ``prefix`` like the solver's on PETSc.COMM_SELF (``parallel``: with the
    parallel matrix type and block Jacobi, as on several ranks, where e.g. ILU has no factorization); InputError
    naming the options when PETSc refuses them."""
    from petsc4py import PETSc

    n = 6
    A = PETSc.Mat().createAIJ([n, n], nnz=3, comm=PETSc.COMM_SELF)
    if parallel:
        A.setType("mpiaij")
        A.setPreallocationNNZ((3, 0))
    for i in range(n):  # the 1D Laplacian: SPD, so every sensible KSP/PC can set up on it
        A.setValue(i, i, 2.0)
        if i > 0:
            A.setValue(i, i - 1, -1.0)
        if i < n - 1:
            A.setValue(i, i + 1, -1.0)
    A.assemble()
    A.setOptionsPrefix(prefix)
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    try:
        ksp.setOptionsPrefix(prefix)
        ksp.setOperators(A)
        ksp.setType(PETSc.KSP.Type.GMRES)
        ksp.setPCSide(PETSc.PC.Side.RIGHT)
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.getPC().setType("bjacobi" if parallel else "ilu")
        ksp.setFromOptions()
        ksp.setUp()
        check_option_values(prefix)
    except PETSc.Error as err:
        given = " ".join(f"-{k} {v}".strip() for k, v in PETSc.Options().getAll().items() if k.startswith(prefix))
        detail = [re.sub(r"^\[\d+\]\s*", "", line.strip()) for line in str(err).splitlines() if line.strip()]
        raise InputError(f"PETSc options {given!r} cannot be used by the solver: "
                         f"{detail[-1] if detail else err}") from None
    finally:
        ksp.destroy()
        A.destroy()


def check_option_values(prefix: str) -> None:
    """InputError naming a numeric option of the database (under ``prefix``) whose value is out of its range
    (:func:`~fenics_coulomb.scd.preconditioner.check_option_value`)."""
    opts = PETSc.Options()
    for key in OPTION_RANGES:
        if opts.hasName(f"{prefix}{key}"):
            check_option_value(f"{prefix}{key}", opts.getString(f"{prefix}{key}"))


def _petsc_pairs(tokens: list[str]) -> list[tuple[str, str]]:
    """Split ``-key [value]`` tokens into (key, value) pairs."""
    pairs: list[tuple[str, str]] = []
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if not token.startswith("-") or token.startswith("--"):
            raise InputError(f"unrecognized argument {token!r}")
        key = token.lstrip("-")
        value = ""
        if i + 1 < len(tokens) and not _is_option(tokens[i + 1]):
            value = tokens[i + 1]
            i += 1
        pairs.append((key, value))
        i += 1
    return pairs


def _is_option(token: str) -> bool:
    if not token.startswith("-"):
        return False
    try:
        float(token)
        return False
    except ValueError:
        return True



@functools.cache
def _options_used() -> ctypes._CFuncPtr | None:  # type: ignore[name-defined]
    """PETSc's ``PetscOptionsUsed`` from the libpetsc this process has loaded (petsc4py does not wrap it), or None
    where it cannot be found (then nothing is reported)."""
    try:
        with open("/proc/self/maps", encoding="utf-8") as maps:
            paths = sorted({line.split()[-1] for line in maps
                            if "libpetsc" in line and line.split()[-1].startswith("/")})
    except OSError:
        return None
    for path in paths:
        try:
            function = ctypes.CDLL(path).PetscOptionsUsed
        except (OSError, AttributeError):
            continue
        function.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.POINTER(ctypes.c_int)]
        function.restype = ctypes.c_int
        return function
    return None


def option_read(name: str) -> bool | None:
    """Whether some PETSc object has read the option ``name`` (without '-') of the options database since it was
    set (PETSc's "used" flag, which ``-options_left`` reports at PetscFinalize); None when that cannot be told.
    Setting an option anew clears the flag."""
    function = _options_used()
    if function is None:
        return None
    used = ctypes.c_int(0)
    if function(None, name.encode(), ctypes.byref(used)) != 0:
        return None
    return bool(used.value)


def unread_hint(names: list[str], parallel: bool) -> str:
    """What to add to the warning naming the unread options ``names``: on several ranks ILU and ICC run inside block
    Jacobi, whose sub-preconditioner reads them with the prefix ``sub_``."""
    factor = parallel and any("pc_factor_" in name and "sub_pc_factor_" not in name for name in names)
    return (" (on several ranks ILU runs inside block Jacobi: its options take the prefix sub_, e.g. "
            "sub_pc_factor_levels)") if factor else ""
