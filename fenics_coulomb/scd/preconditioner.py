"""The Newton system's KSP and the choice of its preconditioner.

GMRES, right preconditioned, stopped on the unpreconditioned relative residual; the preconditioner is
chosen by name (:data:`~fenics_coulomb.settings.PRECONDITIONERS`). Everything is under the solver's options
prefix, so ``-<prefix>ksp_*`` / ``-<prefix>pc_*`` options tune it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.la

from fenics_coulomb.errors import InputError
from fenics_coulomb.model.nullspace import rigid_body_modes
from fenics_coulomb.model.reproducible import FIXED_ORDER_PTAP, MIN_RANKS
from fenics_coulomb.scd.physical_preconditioner import PhysicalGAMG

__all__ = ["AUTO_GAMG_UNKNOWNS", "AUTO_ILU_MAX_RANKS", "AUTO_STALL_ITS", "AUTO_LU_MAX_UNKNOWNS",
           "DETERMINISTIC_PTAP", "DETERMINISTIC_PTAP_MIN_RANKS", "GAMG_SMOOTHER_SWEEPS",
           "GAMG_PROLONGATOR_SMOOTHS", "UNSMOOTHED_CELL_TYPES", "HYPRE_ELASTICITY",
           "NEARLY_INCOMPRESSIBLE_POISSON", "OPTION_RANGES", "check_option_value", "choose_preconditioner",
           "auto_ladder", "resolve_pc", "default_options", "create_ksp"]

#: pc = "auto" (:func:`choose_preconditioner`) takes ILU (the paper's) only on hexahedral meshes below this many
#: unknowns on at most AUTO_ILU_MAX_RANKS ranks, GAMG everywhere else (docs/pc-auto; docs/ratio, docs/table2:
#: on the cuboid ILU was the faster up to lev 6 (27 744 unknowns), GAMG from lev 7 (79 488) on, with smoothed
#: aggregation. With unsmoothed aggregation (2026-11-24) GAMG is the faster from lev 5 (0.2 s against 0.26 s);
#: the threshold stays, so that the paper's Section 7 runs at lev 2-6 keep the paper's ILU and their solutions).
AUTO_GAMG_UNKNOWNS = 50_000
#: Block-Jacobi ILU's Krylov counts grow with the number of blocks (docs/pc-auto: d3/L2 lev 6, ν = 0.45:
#: 137 on 1 rank, 210 on 2; lev 5 d2/L1 145 on 1 rank, 245 on 16) while GAMG's do not.
AUTO_ILU_MAX_RANKS = 2
#: pc = "auto": a linear solve that has not reached its tolerance after this many GMRES iterations per decade of
#: reduction (two restart cycles; on every measured case the chosen preconditioner needs at most 41 (ILU) and 55
#: (GAMG) per step at tol = 0.1, docs/pc-auto, docs/robustness) has stagnated: the next preconditioner of
#: :func:`auto_ladder` takes over for the rest of the solve instead of running on to ksp_max_it. ILU-GMRES
#: stagnates for nearly incompressible materials (d3/L2 lev 2, ν = 0.49: 2000 iterations per step on 2 ranks
#: without reaching tol = 0.1, a breakdown after 28 000 iterations on 1 rank), which the rule cannot see.
AUTO_STALL_ITS = 200
#: The last resort of the ladder, a direct solver (MUMPS in parallel), only up to this many unknowns (about
#: 2 GiB of factors for 3D elasticity at 300 000 unknowns).
AUTO_LU_MAX_UNKNOWNS = 300_000
#: GAMG's Galerkin coarse matrices are parallel triple products PᵀAP, which PETSc by default sums in the order
#: the messages arrive (three and more ranks): :mod:`fenics_coulomb.model.reproducible` has the option that fixes
#: the order; the solver sets it for the duration of its own KSP solves (where GAMG sets up), unless the user
#: gave it. Only from MIN_RANKS ranks: on 2 the default product repeats bit for bit, while "allatonce" costs
#: (d3/L2 lev 8 on 2 ranks: 16.3 s with it, 9.5 s without; docs/scale/idle-2026-11-23).
DETERMINISTIC_PTAP = FIXED_ORDER_PTAP
DETERMINISTIC_PTAP_MIN_RANKS = MIN_RANKS
#: GAMG's level smoother (Chebyshev) sweeps unless -<prefix>mg_levels_ksp_max_it says otherwise: one sweep
#: costs more Krylov iterations than PETSc's two but less time (lev 8: 8.4 s against 10.3 s; lev 10: 78 s
#: against 105 s).
GAMG_SMOOTHER_SWEEPS = 1
#: Smoothing steps of GAMG's tentative prolongators (-<prefix>pc_gamg_agg_nsmooths) on meshes of the cell types
#: in UNSMOOTHED_CELL_TYPES, unless the user says otherwise; elsewhere PETSc's default 1 (smoothed aggregation).
#: Unsmoothed aggregation keeps the coarse operators as sparse as A's: a set-up a third as expensive and a
#: cheaper V-cycle for more Krylov iterations, which pays because the hierarchy of A is set up once (2 ranks,
#: d3/L2: lev 10 nested 62.1 s → 54.4 s, lev 8 8.5 s → 7.5 s, lev 11 180 s → 174 s and 16.9 → 12.4 GiB;
#: docs/gamg-sweeps).
GAMG_PROLONGATOR_SMOOTHS = 0
#: Where unsmoothed aggregation is measured robust (docs/pc-auto/gamg-unsmoothed-2026-11-24): on the hexahedral
#: cuboid at most 17 GMRES iterations per Newton step (ν 0.3, 0.45, lev 5-10) and faster in every group. On
#: the tetrahedral roller the counts grew with the mesh (up to 56 per step against smoothed aggregation's 17,
#: ν = 0.45, 63 900 unknowns, twice the time), so tetrahedra keep smoothed aggregation.
#: Nor is it for nearly incompressible hexahedral bodies: d3/L2 lev 6, 2 ranks, ν = 0.49: 260 Krylov (28 per
#: step) against 173 (19); ν = 0.499: 726 (83) against 469 (51), 4.2 s against 3.5 s. So :func:`default_options`
#: keeps smoothed aggregation when the settings' ``poisson_ratio`` (a scene's largest ν; None from the API, where
#: -coulomb_pc_gamg_agg_nsmooths 1 is the user's to give) reaches NEARLY_INCOMPRESSIBLE_POISSON.
UNSMOOTHED_CELL_TYPES = ("hexahedron",)
#: BoomerAMG for 3D elasticity: nodal (block) coarsening on the 3 components of a node and the strength threshold
#: 0.7 that hypre's documentation recommends in 3D (the default 0.25 is for 2D). On the graded Hertz block of
#: benchmarks/hertz.py with the paper's scalar γ (where GAMG on A stagnates), 2 ranks: 14 Newton / 42 GMRES iterations
#: in 1.3 s, against 14 / 27 in 4.9 s with hypre's defaults; the interpolation of the rigid-body modes
#: (vec_interp_variant 2, 3 with the near-nullspace) took 8–9 s and diverged (NaN) on the lev 2 cuboid.
HYPRE_ELASTICITY = {"pc_hypre_boomeramg_strong_threshold": 0.7, "pc_hypre_boomeramg_nodal_coarsen": 6}


#: A body whose largest Poisson ratio is at least this is nearly incompressible for the preconditioners: ILU-GMRES
#: breaks down (d3/L2 lev 6, 2 ranks, ν = 0.49 and 0.499: DIVERGED_BREAKDOWN after 100 iterations in the first
#: Newton step) and GAMG needs smoothed aggregation also on hexahedra (ν = 0.49: 11 Newton / 170 Krylov against
#: 14 / 273 unsmoothed; ν = 0.499: 14 / 493 against 14 / 737; BoomerAMG 12 / 178 and 22 / 855, 10-20x slower).
NEARLY_INCOMPRESSIBLE_POISSON = 0.48


#: Ranges of numeric KSP/PC options that PETSc would take, or silently ignore when negative (a -3 for ksp_max_it
#: ran with the default): key (without prefix) → (parse, test, what is allowed).
OPTION_RANGES: dict[str, tuple[Callable[[str], float], Callable[[float], bool], str]] = {
    "ksp_max_it": (int, lambda v: v >= 1, "an integer >= 1"),
    "ksp_rtol": (float, lambda v: 0.0 < v < 1.0, "a number in (0, 1)"),
    "ksp_atol": (float, lambda v: v >= 0.0, "a number >= 0"),
    "ksp_divtol": (float, lambda v: v > 1.0, "a number > 1"),
    "ksp_gmres_restart": (int, lambda v: v >= 1, "an integer >= 1"),
    "mg_levels_ksp_max_it": (int, lambda v: v >= 1, "an integer >= 1"),
    "pc_gamg_agg_nsmooths": (int, lambda v: v >= 0, "an integer >= 0"),
    "pc_gamg_threshold": (float, lambda v: -1.0 <= v < 1.0, "a number in [-1, 1)"),
}


def check_option_value(name: str, raw: object) -> None:
    """InputError unless the option ``name`` (a key of OPTION_RANGES after its prefix) has a value in range."""
    key = next((k for k in OPTION_RANGES if name.endswith(k)), None)
    if key is None:
        return
    parse, ok, text = OPTION_RANGES[key]
    try:
        value = parse(str(raw).strip())
    except ValueError:
        raise InputError(f"PETSc option -{name} {raw!r}: must be {text}") from None
    if not (math.isfinite(value) and ok(value)):
        raise InputError(f"PETSc option -{name} {raw}: must be {text}")


def choose_preconditioner(n_global: int, n_ranks: int, cell_type: str, poisson: float | None = None) -> str:
    """The preconditioner that ``pc = "auto"`` stands for, chosen from the measurements in docs/pc-auto.

    GAMG (on A, with the rigid-body near-nullspace) kept every linear solve of every measured case within one
    GMRES restart cycle (at most 18 iterations per Newton step; hexahedral cuboid lev 2-7, tetrahedral hemisphere
    and roller 2 058-63 900 unknowns, ν 0.3 and 0.45, 1, 2 and 4 ranks). ILU's counts grow with the mesh size, the
    rank count and ν, and on tetrahedra they are several times larger from the smallest meshes on (roller, 7 617
    unknowns, ν = 0.45: up to 81 per step on 1 rank against GAMG's 17, and GAMG the faster) and exceed a restart
    cycle in 9 of the 58 measured groups, all tetrahedral (up to 466 per step); with ν = 0.3 and 25 000
    unknowns a tetrahedral hemisphere runs into the 2000-iteration limit with ILU. So ILU is
    kept only where it is measured robust and at least as fast: hexahedra below AUTO_GAMG_UNKNOWNS unknowns on
    at most AUTO_ILU_MAX_RANKS ranks.

    Args:
        n_global: Global number of unknowns (>= 1).
        n_ranks: Number of MPI ranks (>= 1).
        cell_type: The mesh's cell type name (``"hexahedron"``, ``"tetrahedron"``, ...).
        poisson: The body's largest Poisson ratio when known: GAMG from NEARLY_INCOMPRESSIBLE_POISSON on.

    Returns:
        ``"ilu"`` or ``"gamg"``.
    """
    if n_global < 1 or n_ranks < 1:
        raise ValueError(f"choose_preconditioner: n_global = {n_global}, n_ranks = {n_ranks} must be >= 1")
    if cell_type == "hexahedron" and n_global < AUTO_GAMG_UNKNOWNS and n_ranks <= AUTO_ILU_MAX_RANKS and (
            poisson is None or poisson < NEARLY_INCOMPRESSIBLE_POISSON):
        return "ilu"
    return "gamg"


def auto_ladder(first: str, n_global: int) -> list[str]:
    """The preconditioners ``pc = "auto"`` tries after ``first`` when a linear solve stagnates, in order.

    ILU → GAMG on A (ILU stagnates for ν → 0.5 and on tetrahedra; GAMG did not on any measured case) → BoomerAMG
    on the Newton matrix with elasticity options (:func:`default_options`; set up every Newton step, so it reads
    the contact rows that GAMG on A does not) → a direct solver below AUTO_LU_MAX_UNKNOWNS.
    """
    ladder = {"ilu": ["gamg", "hypre", "lu"], "gamg": ["hypre", "lu"]}.get(first, [])
    return [pc for pc in ladder if pc != "lu" or n_global <= AUTO_LU_MAX_UNKNOWNS]


def resolve_pc(pc: str, n_global: int, n_ranks: int, cell_type: str, poisson: float | None = None) -> str:
    """The preconditioner to use: ``auto`` resolved by :func:`choose_preconditioner`."""
    return pc if pc != "auto" else choose_preconditioner(n_global, n_ranks, cell_type, poisson)


def default_options(pc: str, cell_type: str, poisson: float | None = None) -> dict[str, object]:
    """Options (without prefix) the preconditioner ``pc`` sets on a mesh of ``cell_type`` unless the user gave
    them: one Chebyshev sweep per level for GAMG, and unsmoothed aggregation on UNSMOOTHED_CELL_TYPES unless the
    body is nearly incompressible (``poisson`` >= NEARLY_INCOMPRESSIBLE_POISSON); BoomerAMG's elasticity options."""
    if pc == "gamg":
        options: dict[str, object] = {"mg_levels_ksp_max_it": GAMG_SMOOTHER_SWEEPS}
        if cell_type in UNSMOOTHED_CELL_TYPES and (poisson is None or poisson < NEARLY_INCOMPRESSIBLE_POISSON):
            options["pc_gamg_agg_nsmooths"] = GAMG_PROLONGATOR_SMOOTHS
        return options
    if pc == "hypre":
        return dict(HYPRE_ELASTICITY)
    return {}


def create_ksp(
    comm: MPI.Comm,
    M: PETSc.Mat,
    A: PETSc.Mat,
    V: dolfinx.fem.FunctionSpace,
    pc_name: str,
    prefix: str,
    tol: float,
    restart: int,
    max_it: int,
    near_nullspace: Callable[[], PETSc.NullSpace] | None = None,
    physical: PhysicalGAMG | None = None,
) -> tuple[PETSc.KSP, PETSc.NullSpace | None]:
    """Create the KSP of the Newton matrix M (stiffness A) with the preconditioner ``pc_name``.

    ``gamg`` preconditions with A, which never changes: PETSc sets the AMG hierarchy up at the first solve
    and reuses it for every Newton matrix (only the contact rows differ from A), with the rigid-body near-nullspace
    of V, or ``near_nullspace()`` (e.g. the modes of two
    bodies in the variables of :mod:`fenics_coulomb.model.pairs.two_body`). ``gamg`` with ``physical`` (contact
    pairs) is GAMG on the bodies' physical stiffness between the changes of variables, a ``python`` PC
    (:mod:`fenics_coulomb.scd.physical_preconditioner`; the caller owns it). Call ``ksp.setFromOptions()`` afterwards.

    Returns:
        The KSP and the near-nullspace it uses (the caller destroys both), or None.
    """
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(M, A if pc_name == "gamg" else M)
    ksp.setType(PETSc.KSP.Type.GMRES)
    ksp.setGMRESRestart(restart)
    ksp.setPCSide(PETSc.PC.Side.RIGHT)
    ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
    ksp.setTolerances(rtol=tol, atol=0.0, max_it=max_it)
    pc = ksp.getPC()
    parallel = comm.size > 1
    nullspace = None
    if pc_name == "ilu":
        pc.setType("bjacobi" if parallel else "ilu")
    elif pc_name == "lu":
        pc.setType("lu")
        if parallel:
            pc.setFactorSolverType("mumps")
    elif pc_name == "gamg" and physical is not None:
        pc.setType("python")
        pc.setPythonContext(physical)
    elif pc_name == "gamg":
        pc.setType("gamg")
        nullspace = near_nullspace() if near_nullspace is not None else rigid_body_modes(V)
        A.setNearNullSpace(nullspace)
    elif pc_name == "hypre":
        pc.setType("hypre")
        pc.setHYPREType("boomeramg")
    else:
        pc.setType(pc_name)
    return ksp, nullspace
