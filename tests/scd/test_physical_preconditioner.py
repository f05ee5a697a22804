"""GAMG for contact pairs in the physical displacement (scd/physical_preconditioner.py): the identity it rests on,
Ã = Mᵀ B M, checked by applying M⁻¹ B⁻¹ M⁻ᵀ with an exact B⁻¹ (LU in place of GAMG) to Ã x — it gives x back —
in the reference and in a slid configuration (a new pairing, M of another pattern); B the same matrix in both.
On any number of ranks."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from benchmarks.sliding import SlidingBlocks
from fenics_coulomb.model.dof_values import owned_values
from fenics_coulomb.scd.physical_preconditioner import PhysicalGAMG


def roundtrip(model, physical: PhysicalGAMG, seed: int) -> float:
    """max |P⁻¹ Ã x − x| / max |x| for a random x that is zero on the supports (their rows and columns are s I in
    both Ã and B, with s the mean free diagonal of the Ã of the geometry they were built in)."""
    x, y = model.A.createVecs()
    z = model.A.createVecLeft()
    rng = np.random.default_rng(seed + MPI.COMM_WORLD.rank)
    x.array[:] = rng.standard_normal(x.array.size)
    x.array[model.dirichlet_rows] = 0.0
    model.A.mult(x, y)
    physical.apply(None, y, z)
    scale = MPI.COMM_WORLD.allreduce(float(np.abs(x.array).max()), op=MPI.MAX)
    error = MPI.COMM_WORLD.allreduce(float(np.abs(z.array - x.array).max()), op=MPI.MAX)
    for vec in (x, y, z):
        vec.destroy()
    return error / scale


@pytest.mark.parametrize("method", ["mortar", "node-to-surface"])
def test_physical_preconditioner_with_an_exact_inverse_inverts_the_pair_stiffness(method):
    blocks = SlidingBlocks(MPI.COMM_WORLD, 0.5, method=method, rtol=1e-10, prefix=f"physical_{method[0]}_",
                           n_lower=(8, 4, 2), n_upper=(6, 3, 2))
    physical = None
    try:
        model = blocks.problem.model
        B = model.physical_stiffness()
        assert B is not None and model.physical_stiffness() is B  # built once
        physical = PhysicalGAMG(B, model.variables, model.V, f"physical_{method[0]}_exact_")
        physical.gamg.setType("lu")
        if MPI.COMM_WORLD.size > 1:
            physical.gamg.setFactorSolverType("mumps")
        assert roundtrip(model, physical, 0) < 1e-10

        # slid 0.3: the pairing, M and Ã change; B does not
        blocks.solve(0.3)
        M = model.variables()
        assert model.physical_stiffness() is B and M is not None
        assert roundtrip(model, physical, 1) < 1e-10

        # the control: without the change of variables, B⁻¹ does not invert Ã
        identity = M.duplicate(copy=False)
        identity.shift(1.0)  # M = I + Φ holds its diagonal
        control = PhysicalGAMG(B, lambda: identity, model.V, f"physical_{method[0]}_control_")
        control.gamg.setType("lu")
        if MPI.COMM_WORLD.size > 1:
            control.gamg.setFactorSolverType("mumps")
        try:
            assert roundtrip(model, control, 2) > 1e-3
        finally:
            control.destroy()
            identity.destroy()
        assert np.isfinite(owned_values(blocks.problem.u)).all()
    finally:
        if physical is not None:
            physical.destroy()
        blocks.destroy()


def test_a_pair_escalates_from_gamg_on_b_and_releases_it():
    """pc = auto on the tetrahedral blocks starts with GAMG on B; with ksp_max_it = 2 it counts as stagnated, the
    ladder hands the solve to BoomerAMG (and LU where needed), the context of GAMG on B is destroyed at once, and
    the answer is the direct solver's."""
    blocks = SlidingBlocks(MPI.COMM_WORLD, 0.5, rtol=1e-10, prefix="physical_ladder_", n_lower=(8, 4, 2),
                           n_upper=(6, 3, 2), settings={"pc": "auto", "ksp_max_it": 2, "max_it": 80})
    direct = SlidingBlocks(MPI.COMM_WORLD, 0.5, rtol=1e-10, prefix="physical_direct_", n_lower=(8, 4, 2),
                           n_upper=(6, 3, 2), settings={"pc": "lu"})
    try:
        solver = blocks.problem.solver
        assert isinstance(solver._physical, PhysicalGAMG)
        row, reference = blocks.solve(0.2), direct.solve(0.2)
        result = row["result"]
        assert [h["from"] for h in result.pc_history][:1] == ["gamg"] and result.pc in ("hypre", "lu")
        assert solver._physical is None
        assert row["nodes"] == reference["nodes"]
        assert np.abs(row["force"] - reference["force"]).max() <= 1e-6 * abs(reference["force"][2])
    finally:
        blocks.destroy()
        direct.destroy()
