"""The Python API misused as a hostile review did (2026-11-27): each case raises InputError on every rank with one
message (no segfault, no hang, no exception from deep inside), and a result is reported, checked and written only
in the state that made it. On 1 and 2 ranks."""

from __future__ import annotations

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem, InputError, Sphere, write_results
from fenics_coulomb.model.pairs import ContactPair


def block(comm=MPI.COMM_WORLD, load=(0.0, 0.0, 0.0)):
    """A 1 × 1 × 0.5 block of 6 × 6 × 3 hexahedra clamped at its bottom, its top the contact boundary, a body force
    ``load`` (a Constant): (a, L, bcs, contact, the load Constant)."""
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], [1, 1, 0.5]], [6, 6, 3], dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(top).astype(np.int32), np.ones(top.size, np.int32))
    clamp = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, bottom), V)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def eps(w):
        return ufl.sym(ufl.grad(w))

    a = ufl.inner(53.8 * eps(u) + 40.4 * ufl.tr(eps(u)) * ufl.Identity(3), eps(v)) * ufl.dx
    force = dolfinx.fem.Constant(msh, np.asarray(load, dtype=np.float64))
    return a, ufl.inner(force, v) * ufl.dx, [clamp], (tags, [1]), force


def ball() -> Sphere:
    return Sphere(center=[0.5, 0.5, 1.0], radius=0.5, displacement=[0.0, 0.0, -0.01], name="ball")


def problem(prefix="misuse_", **kwargs) -> ContactProblem:
    a, L, bcs, contact, _ = block()
    return ContactProblem(a, L, bcs, contact, 0.3, [ball()], petsc_options_prefix=prefix, **kwargs)


def test_a_pair_on_another_meshs_tags_is_refused():
    """A ContactPair built on the facet tags of another mesh crashed PETSc (SEGV)."""
    a, L, bcs, contact, _ = block()
    other = dolfinx.mesh.create_unit_cube(MPI.COMM_WORLD, 2, 2, 2)
    facets = dolfinx.mesh.locate_entities_boundary(other, 2, lambda x: np.isclose(x[2], 1.0))
    tags = dolfinx.mesh.meshtags(other, 2, np.sort(facets).astype(np.int32), np.ones(facets.size, np.int32))
    with pytest.raises(InputError, match=r"contact_pairs\[0\]: its facet tags belong to another mesh"):
        ContactProblem(a, L, bcs, None, 0.3, contact_pairs=[ContactPair(tags, slave=1, master=1)],
                       petsc_options_prefix="other_")


@pytest.mark.parametrize("kwargs, fragment", [
    ({"settings": {1: 2, "foo": 3}}, "unknown solver setting"),  # a TypeError from sorting the keys
    ({"contact_pairs": 5}, "contact_pairs = int: give a list"),  # a TypeError: not iterable
    ({"petsc_options_prefix": "-x_"}, "petsc_options_prefix = '-x_'"),  # petsc4py.Error from MatSetOptionsPrefix
])
def test_wrong_kinds_are_input_errors(kwargs, fragment):
    a, L, bcs, contact, _ = block()
    kwargs = {"petsc_options_prefix": "kinds_", **kwargs}
    with pytest.raises(InputError, match=fragment):
        ContactProblem(a, L, bcs, contact, 0.3, [ball()], **kwargs)


def test_obstacles_from_a_generator_are_the_list():
    """A generator of obstacles was consumed by the first look at it (ValueError: needs at least one obstacle)."""
    a, L, bcs, contact, _ = block()
    with ContactProblem(a, L, bcs, contact, 0.3, (o for o in [ball()]), petsc_options_prefix="gen_") as p:
        assert [o.name for o in p.obstacles] == ["ball"]


def test_a_non_finite_load_is_an_input_error():
    """A NaN body force came back as a diverging solve (SolverError non_finite)."""
    a, L, bcs, contact, force = block(load=(0.0, 0.0, np.nan))
    with ContactProblem(a, L, bcs, contact, 0.3, [ball()], petsc_options_prefix="nan_") as p:
        with pytest.raises(InputError, match="solve: the load is not finite"):
            p.solve()
        force.value[:] = (0.0, 0.0, -1.0)
        _, result = p.solve()  # usable afterwards
        assert result.converged


def test_an_earlier_result_is_refused_after_a_move(mpi_tmp_path):
    """checks() and report() of a result after the ball moved used the new placement: a converged result showed
    penetration 0.025 and cone 0.159. Now refused, as are checks(None) and a result of another problem."""
    with problem(settings={"rtol": 1e-10}) as p, problem(prefix="other_") as q:
        _, first = p.solve()
        assert p.checks(first)["penetration"] < 1e-8 and p.report(first).total_force[2] < 0  # the ball presses down
        _, theirs = q.solve()
        p.move("ball", [0.2, 0.1, -0.02])
        for call in (lambda: p.checks(first), lambda: p.report(first),
                     lambda: write_results(mpi_tmp_path / "first", p, first)):
            with pytest.raises(InputError, match="the result of an earlier solve"):
                call()
        with pytest.raises(InputError, match="result = None: give the SolveResult"):
            p.checks(None)
        with pytest.raises(InputError, match="not one of this problem's solve"):
            p.report(theirs)
        _, second = p.solve()
        assert p.checks(second)["penetration"] < 1e-6


def test_set_solver_keeps_the_old_solver_on_a_refused_value():
    """set_solver({"gamma": 1e30}) destroyed the solver before refusing, and the next solve raised RuntimeError."""
    with problem() as p:
        with pytest.raises(InputError, match="gamma = 1e\\+30"):
            p.set_solver({"gamma": 1e30})
        _, result = p.solve()
        assert result.converged


def test_write_results_refuses_on_every_rank_before_writing(mpi_tmp_path):
    """A NUL in the path and a NumPy array in extra raised on rank 0 only (the other ranks hung); extra could
    overwrite "converged"."""
    with problem() as p:
        _, result = p.solve()
        for path, extra, fragment in ((mpi_tmp_path / "x\0y", None, "NUL"),
                                      (mpi_tmp_path / "e", {"a": np.arange(3)}, "extra is not JSON data"),
                                      (mpi_tmp_path / "e", {"converged": True}, "would replace summary.json's "
                                                                              "'converged'"),
                                      (mpi_tmp_path / "e", [1, 2], "extra = list")):
            with pytest.raises(InputError, match=fragment):
                write_results(path, p, result, extra=extra)
        assert not (mpi_tmp_path / "e").exists()
        write_results(mpi_tmp_path / "ok", p, result, extra={"a": [0, 1, 2]})  # and a good one is written


def test_reaction_names_must_be_every_ranks():
    """Node blocks are this rank's; a name given on one rank only hung the others in the gather."""
    with problem() as p:
        _, result = p.solve()
        comm = MPI.COMM_WORLD
        reactions = {"x": np.zeros(0, dtype=np.int32)} if comm.rank == 0 else {}
        if comm.size == 1:
            reactions = {"x": np.zeros(0, dtype=np.int32)}
            assert "x" in p.report(result, reactions=reactions).reactions
            return
        with pytest.raises(InputError, match="reactions: the names differ between ranks"):
            p.report(result, reactions=reactions)


def test_options_a_parallel_solve_cannot_use_are_refused_there():
    """pc_type ilu passed the serial check of the options and failed on 2 ranks as a solve error ("Could not locate
    a solver type for factorization type ILU and matrix type mpiaij", per rank): the check now sets the parallel
    matrix type up on several ranks. On 1 rank ILU is the solver's own preconditioner."""
    a, L, bcs, contact, _ = block()
    kwargs = {"petsc_options_prefix": "ilu_", "petsc_options": {"pc_type": "ilu"}}
    if MPI.COMM_WORLD.size > 1:
        with pytest.raises(InputError, match="factorization type ILU and matrix type mpiaij"):
            ContactProblem(a, L, bcs, contact, 0.3, [ball()], **kwargs)
    else:
        with ContactProblem(a, L, bcs, contact, 0.3, [ball()], **kwargs) as p:
            assert p.solve()[1].converged
