"""Finite sliding's geometry updates keep the solver (docs/sliding/cost.md): the KSP, the shell Newton operator and
GAMG's hierarchy (set up once, in the physical displacement: scd/physical_preconditioner.py) stay across the
updates of a solve and the steps of a path, Ã = Mᵀ A_free M is overwritten in place when the coupling's pattern
stays, and the answers are those of a direct solver. On 1 and 2 ranks."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from benchmarks.sliding import SlidingBlocks
from fenics_coulomb.model.contact_model import ContactModel
from fenics_coulomb.model.dof_values import owned_values
from fenics_coulomb.scd.newton import SCDNewtonSolver
from fenics_coulomb.scd.physical_preconditioner import PhysicalGAMG

SMALL = {"n_lower": (8, 4, 2), "n_upper": (6, 3, 2)}
SHIFTS = (0.0, 0.1, 0.2, 0.3)
RTOL = 1e-9
CONFIGURE = ContactModel.configure


def hierarchy(solver: SCDNewtonSolver) -> tuple[int, ...]:
    """The ids of GAMG's interpolations (new objects whenever GAMG is set up again)."""
    physical = solver._physical
    assert isinstance(physical, PhysicalGAMG) and solver.ksp.getPC().getType() == "python"
    gamg = physical.gamg
    return tuple(gamg.getMGInterpolation(level).getId() for level in range(1, gamg.getMGLevels()))


def slide(pc: str, monkeypatch: pytest.MonkeyPatch) -> dict:
    """Press, then slide 0.3 in three steps with the preconditioner ``pc``: the final state, the pair force,
    whether the solver's PETSc objects stayed, GAMG's interpolations after the press and at the end."""
    paired: list[bool] = []  # per configuration: whether the pairing of X + u came with it (no new pairing)

    def configure(model: ContactModel, u: object, pairing: object = None, resolution: float = 0.0) -> bool:
        paired.append(pairing is not None)
        return CONFIGURE(model, u, pairing, resolution)

    monkeypatch.setattr(ContactModel, "configure", configure)
    blocks = SlidingBlocks(MPI.COMM_WORLD, 0.5, rtol=RTOL, prefix=f"updates_{pc}_", settings={"pc": pc}, **SMALL)
    solver = blocks.problem.solver
    handles = (solver.ksp.handle, solver.M.handle, solver.u.handle)
    rows = [blocks.solve(SHIFTS[0])]
    pressed = hierarchy(solver) if pc == "gamg" else ()
    rows += [blocks.solve(shift) for shift in SHIFTS[1:]]
    kept = blocks.problem.solver is solver and (solver.ksp.handle, solver.M.handle, solver.u.handle) == handles
    out = {"state": blocks.state(SHIFTS[-1]), "force": rows[-1]["force"], "kept": kept, "pressed": pressed,
           "end": hierarchy(solver) if pc == "gamg" else (), "updates": sum(r["updates"] for r in rows),
           "nodes": rows[-1]["nodes"], "blocks": blocks, "paired": paired}
    return out


def test_the_solver_and_its_hierarchy_stay_and_answer_as_a_direct_solver(monkeypatch):
    gamg = slide("gamg", monkeypatch)
    direct = slide("lu", monkeypatch)
    try:
        assert gamg["kept"]
        assert gamg["updates"] >= 2
        # GAMG set up once: the interpolations of the press are those at the end of the slide
        assert len(gamg["pressed"]) >= 1 and gamg["end"] == gamg["pressed"]
        assert gamg["nodes"] == direct["nodes"]
        # every configuration, the steps' first ones included, adopted a pairing the geometry check had computed
        assert len(gamg["paired"]) > gamg["updates"] and all(gamg["paired"])
        # both are solutions to the geometry's accuracy ε = 8·rtol·|u|∞ (model/sliding.py): within 2ε of each other
        u_scale = float(np.abs(direct["state"][:, 3:]).max())
        assert np.abs(gamg["state"] - direct["state"]).max() <= 2 * 8 * RTOL * max(u_scale, SHIFTS[-1])
        assert np.abs(gamg["force"] - direct["force"]).max() <= 1e-6 * abs(direct["force"][2])

        # Ã overwritten in place (PtAP's numeric phase) has the bits of Ã built anew: the slid model configured again
        # in its own configuration keeps its coupling's pattern; the other model is configured there from X
        model, other = gamg["blocks"].problem.model, direct["blocks"].problem.model
        u = owned_values(gamg["blocks"].problem.u)
        A = model.A
        model.configure(u)
        assert model.coupling.reused and model.A is A
        other.configure(None)
        other.configure(u)
        assert not other.coupling.reused
        mine, theirs = model.A.getValuesCSR(), other.A.getValuesCSR()
        assert all(np.array_equal(a, b) for a, b in zip(mine, theirs, strict=True))
    finally:
        gamg["blocks"].destroy()
        direct["blocks"].destroy()


@pytest.mark.parametrize("changes, decisions", [
    ((4e-11, 3.9e-11), ["update", "settled"]),  # stagnant below the round-off cap: settled
    ((4e-11, 1e-12), ["update", "update"]),  # still contracting: another update
    ((4e-6, 3.9e-6), ["update", "update"]),  # stagnant but far above the round-off: a real change, update
])
def test_a_change_that_stops_shrinking_at_round_off_settles(monkeypatch: pytest.MonkeyPatch, changes, decisions):
    """GeometryIteration: at full accuracy, with the same nodes and supports, a largest change that no longer
    shrinks (≥ ROUND_OFF_STAGNATION × the previous one) and lies below ROUND_OFF_CAP × the mesh's extent is the
    geometry's round-off and settles; a contracting or a large one updates (the changes scripted, ε below all)."""
    from fenics_coulomb.model import sliding

    blocks = SlidingBlocks(MPI.COMM_WORLD, 0.5, rtol=RTOL, prefix="roundoff_", **SMALL)
    try:
        model = blocks.problem.model
        script = iter(changes)
        monkeypatch.setattr(sliding, "geometry_change", lambda *args, **kwargs: sliding.GeometryChange(
            settled=False, changed=0, discrepancy=next(script), tolerance=1e-14))
        iteration = sliding.GeometryIteration(model, RTOL, 8.0, None)
        assert 4e-11 < iteration.extent * sliding.ROUND_OFF_CAP < 4e-6  # the scripted changes on both sides
        u = np.zeros(3 * model.V.dofmap.index_map.size_local)
        taken = [iteration.after(u, u, RTOL, iterations=3).action for _ in changes]
        assert taken == decisions
    finally:
        blocks.destroy()
