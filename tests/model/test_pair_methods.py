"""The registry of pair methods (fenics_coulomb.model.pairs.registry): a new discretization of a contact pair is one
module and one registry line. A toy method registered at run time — node-to-surface's stencils under another name,
counting its calls — solves a pair through the whole model (its stencils are the ones used; the solve obeys the
physics and equals node-to-surface's bit for bit); unregistered, the name is refused again. 1 and 2 ranks.
"""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb import ContactProblem
from fenics_coulomb.errors import InputError
from fenics_coulomb.model.pairs import (ContactPair, PairInput, Stencils, pair_methods, register_pair_method,
                                        unregister_pair_method)
from fenics_coulomb.model.pairs import node_to_surface

from test_two_body import MASTER, SLAVE, TIGHT, assert_physics, owned, pressed_blocks  # noqa: E402


class _Toy:
    """node-to-surface's stencils under another name, counting the candidate nodes it is asked for."""

    def __init__(self) -> None:
        self.nodes = 0

    def __call__(self, pair: PairInput) -> Stencils:
        self.nodes += int(pair.nodes.size)
        return node_to_surface.stencils(pair)


def _solve(method: str) -> tuple[np.ndarray, np.ndarray]:
    V, ft, a, bcs, _ = pressed_blocks(MPI.COMM_WORLD)
    pair = ContactPair(ft, slave=SLAVE, master=MASTER, friction=0.3, method=method)
    with ContactProblem(a, None, bcs, contact_pairs=[pair], settings=TIGHT, sliding="small",
                        petsc_options_prefix=f"toy_{method.replace('-', '_')}_") as problem:
        _, result = problem.solve()
        assert result.converged
        assert_physics(problem, result, method)
        return owned(problem), problem.model.pairing.weights.copy()


def test_a_registered_method_solves_a_pair_and_is_refused_once_unregistered():
    toy = _Toy()
    register_pair_method("toy", toy)
    try:
        assert pair_methods() == ("mortar", "node-to-surface", "toy")
        u_toy, weights_toy = _solve("toy")
    finally:
        unregister_pair_method("toy")
    assert MPI.COMM_WORLD.allreduce(toy.nodes, op=MPI.SUM) > 0  # the pairing asked the toy method
    u_nts, weights_nts = _solve("node-to-surface")
    assert np.array_equal(u_toy, u_nts) and np.array_equal(weights_toy, weights_nts)
    assert pair_methods() == ("mortar", "node-to-surface")
    V, ft, *_ = pressed_blocks(MPI.COMM_WORLD)
    with pytest.raises(InputError, match="method = 'toy': must be one of 'mortar', 'node-to-surface'"):
        ContactPair(ft, slave=SLAVE, master=MASTER, method="toy")


@pytest.mark.parametrize("name", ["mortar", "", 3])
def test_a_taken_or_invalid_name_is_refused(name):
    with pytest.raises(InputError, match="pair method"):
        register_pair_method(name, node_to_surface.stencils)  # type: ignore[arg-type]
    assert pair_methods() == ("mortar", "node-to-surface")


def test_unregistering_an_unknown_method_is_refused():
    with pytest.raises(InputError, match="method = 'nitsche'"):
        unregister_pair_method("nitsche")


@pytest.mark.parametrize("method", [None, "node_to_surface", 3.0])
def test_a_method_that_is_not_callable_is_refused(method):
    """register_pair_method refuses a non-callable method with a message naming it, and registers nothing."""
    with pytest.raises(InputError, match="not callable"):
        register_pair_method("not_a_method", method)
    assert "not_a_method" not in pair_methods()
