"""MPI-safe pytest fixtures: run serially or as ``mpirun -n 2 python3 -m mpi4py -m pytest``."""

from __future__ import annotations

import gc
import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mpi4py import MPI

import numpy as np
import pytest

from fenics_coulomb import ContactProblem
from fenics_coulomb.model.checks import physics_residuals
from fenics_coulomb.scenes.builder import build_problem
from fenics_coulomb.scenes.scene import Scene
from fenics_coulomb.scenes.cuboid import paper_tractions  # noqa: F401  (re-exported for the tests)
from cores import CoresLock, ranks_of
from one_rank import References, compute_references, registered


def pytest_collection_finish(session: pytest.Session) -> None:
    """Freeze what exists once the tests are collected (the imported modules, DOLFINx, UFL, the test items):
    ~110 000 objects that every full collection would otherwise traverse again, ~70 ms of CPU per test
    (docs/testing.md). Everything a test creates stays in the collected generations, so the cleanup below
    still frees it at the same point on every rank; the same on every rank, no MPI call."""
    gc.collect()
    gc.freeze()


@pytest.fixture(autouse=True)
def _collective_cleanup() -> Iterator[None]:
    """Collect garbage and synchronize after each test, so collective PETSc destructors run in step (the
    objects frozen after collection, :func:`pytest_collection_finish`, are not traversed: none is a test's)."""
    yield
    gc.collect()
    MPI.COMM_WORLD.barrier()


@pytest.fixture(scope="session")
def one_rank(request: pytest.FixtureRequest) -> References:
    """The one-rank references (tests/one_rank.py) registered by the modules of the session's tests that ask for
    this fixture, computed side by side on the ranks the first time a test asks (collective)."""
    modules = {item.module.__name__ for item in request.session.items
               if "one_rank" in getattr(item, "fixturenames", ()) and getattr(item, "module", None) is not None}
    return compute_references(MPI.COMM_WORLD, registered(modules))


@pytest.fixture
def mpi_tmp_path() -> Iterator[Path]:
    """A temporary directory shared by all ranks (created on rank 0 and broadcast)."""
    comm = MPI.COMM_WORLD
    path = tempfile.mkdtemp(prefix="fenics-coulomb-") if comm.rank == 0 else None
    path = comm.bcast(path, root=0)
    yield Path(path)
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


def make_problem(lev: int = 1, gap: str = "d3", load: str = "L2", comm: MPI.Comm = MPI.COMM_WORLD,
                 scene: Scene | None = None, petsc_options: dict | None = None, **overrides) -> ContactProblem:
    """A Section 7 case (or ``scene``) as a ContactProblem; ``overrides`` are scene settings (config.FLAGS),
    ``petsc_options`` the problem's PETSc options (without prefix)."""
    scene = (scene or Scene()).override(**({"lev": lev, "gap": gap, "load": load} if scene is None else {}),
                                        **overrides)
    return build_problem(scene, comm, petsc_options=petsc_options).problem


def assembled(problem: ContactProblem) -> dict[str, np.ndarray]:
    """The discrete problem a ContactProblem holds, on a serial communicator: the stiffness matrix K (scipy CSR,
    Dirichlet rows scaled as the solver has them), the load l̃, the contact DOFs (p, 3), the contact nodes'
    coordinates and gaps, and the Dirichlet rows (for independent solvers such as tests/brute_force.py)."""
    import scipy.sparse as sp

    model = problem.model
    assert model.comm.size == 1, "assembled() needs a problem on one rank (comm=MPI.COMM_SELF)"
    indptr, indices, values = model.A.getValuesCSR()
    return dict(K=sp.csr_matrix((values, indices, indptr), shape=model.A.getSize()),
                load=model.load.getArray(readonly=True).copy(), cdofs=model.contact.local_dofs.copy(),
                x=model.contact.coordinates.copy(), gap=model.contact.gap.copy(),
                dirichlet=model.dirichlet_rows.copy())


@pytest.fixture
def problem_factory() -> Iterator:
    """Build problems (make_problem's arguments) and destroy them after the test."""
    created: list[ContactProblem] = []

    def factory(*args, **kwargs) -> ContactProblem:
        problem = make_problem(*args, **kwargs)
        created.append(problem)
        return problem

    yield factory
    for problem in created:
        problem.destroy()


def matrix_difference(a, b, norm=None) -> float:
    """‖a − b‖ / ‖b‖ of two PETSc matrices of one layout (any nonzero patterns; ``norm``: a PETSc.NormType,
    default the Frobenius norm; collective)."""
    from petsc4py import PETSc

    norm = PETSc.NormType.FROBENIUS if norm is None else norm
    d = a.copy()
    d.axpy(-1.0, b, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    value = d.norm(norm) / b.norm(norm)
    d.destroy()
    return value


def global_norm(x: np.ndarray, comm: MPI.Comm = MPI.COMM_WORLD) -> float:
    """‖x‖ over the owned entries of all ranks."""
    return float(np.sqrt(comm.allreduce(float(np.dot(np.ravel(x), np.ravel(x))), op=MPI.SUM)))


def sort_by_coordinates(x: np.ndarray, vals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sort nodes by their coordinates, rounded so that round-off does not change the order."""
    key = np.round(x, 9)
    order = np.lexsort((key[:, 2], key[:, 1], key[:, 0]))
    return x[order], vals[order]


def gather_by_coordinates(V, values: np.ndarray, comm: MPI.Comm | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(coordinates, values) of all owned blocks of V on all ranks, sorted by coordinates."""
    comm = comm or V.mesh.comm
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    vals = np.asarray(values)[: 3 * n].reshape(n, 3)
    return sort_by_coordinates(np.concatenate(comm.allgather(x)), np.concatenate(comm.allgather(vals)))


def read_solution(out: Path) -> tuple[np.ndarray, np.ndarray]:
    """(coordinates, displacement) of a command-line run's solution.h5, sorted by coordinates."""
    import h5py

    with h5py.File(out / "solution.h5", "r") as h5:
        x = h5["Mesh/mesh/geometry"][:]
        u = h5["Function/displacement/0"][:]
    return sort_by_coordinates(x, u)


def solve_each(factory, setting: str, values, *args, tol: float = 1e-8, **kwargs) -> list:
    """Solve one case (``factory(*args, **kwargs)``) once per value of ``setting``; assert that every solve
    converged and that the solutions agree with the last one to ``tol`` (relative, nodes matched by
    coordinates). Returns the (problem, result) pairs."""
    solved, solutions = [], []
    for value in values:
        problem = factory(*args, **{setting: value}, **kwargs)
        _, result = problem.solve()
        assert result.converged, (setting, value)
        solved.append((problem, result))
        solutions.append(gather_by_coordinates(problem.V, result.displacement))
    x_ref, u_ref = solutions[-1]
    for x, u in solutions[:-1]:
        assert np.allclose(x, x_ref)
        assert np.linalg.norm(u - u_ref) <= tol * np.linalg.norm(u_ref)
    return solved


#: The physics checks of a converged solve (:func:`fenics_coulomb.model.checks.physics_residuals`).
PHYSICS = ("equilibrium", "penetration", "negative_pressure", "complementarity", "cone", "slip_direction",
           "reaction_balance")


def assert_physics(model, relative_displacement: np.ndarray, tol: float = 1e-8,
                   keys: tuple[str, ...] = PHYSICS) -> dict[str, float]:
    """Assert every check in ``keys`` below ``tol`` (naming the failing one); return all the residuals."""
    checks = physics_residuals(model, relative_displacement)
    for key in keys:
        assert checks[key] < tol, (key, checks[key])
    return checks


# -- shards: `make test-serial` runs the serial pass as SHARDS processes side by side ----------------------------
def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--shard", default=None, metavar="I/N",
                     help="run only shard I of N (1-based) of the collected tests: whole test modules, the same "
                          "split in every process given the same arguments")
    parser.addoption("--cores-lock", default=None, metavar="FILE",
                     help="the lock file the shards side by side share (tests/cores.py): a test marked multirank "
                          "runs alone, and a test that starts a job of several ranks without the mark fails")


_CORES_LOCK = pytest.StashKey["CoresLock"]()
_RUNNING = pytest.StashKey["list[pytest.Item]"]()


def pytest_configure(config: pytest.Config) -> None:
    """With ``--cores-lock``: open the shards' lock and refuse, from here on, a job of several ranks started by a
    test not marked multirank (it would wait for cores the other shards hold)."""
    path = config.getoption("--cores-lock")
    if not path:
        return
    config.stash[_CORES_LOCK] = CoresLock(Path(path))
    running: list[pytest.Item] = []
    config.stash[_RUNNING] = running
    original = subprocess.Popen.__init__

    def checked(self: subprocess.Popen, args: Any, *rest: Any, **kwargs: Any) -> None:
        ranks = ranks_of(args)
        if ranks > 1 and running and running[-1].get_closest_marker("multirank") is None:
            raise RuntimeError(f"{running[-1].nodeid} starts a job of {ranks} ranks but is not marked multirank: "
                               "beside the other shards its ranks would wait for cores (tests/cores.py)")
        original(self, args, *rest, **kwargs)

    subprocess.Popen.__init__ = checked  # type: ignore[method-assign]


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    """With ``--cores-lock``: hold the cores for the test's setup, call and teardown — alone when it is marked
    multirank (tests/cores.py)."""
    lock = item.config.stash.get(_CORES_LOCK, None)
    if lock is None:
        yield
        return
    running = item.config.stash[_RUNNING]
    with lock.hold(alone=item.get_closest_marker("multirank") is not None):
        running.append(item)
        try:
            yield
        finally:
            running.pop()


#: Each module's measured share of the serial pass: the seconds of its tests' setup, call and teardown (pytest
#: --durations=0 of `make test-serial`, the children they wait for included), summed per module over the tests not
#: marked multirank (those run alone and lengthen both shards alike), 2026-11-27; a module not listed counts 0.74 s a
#: test. Stale weights only unbalance the shards, they never change what runs.
SHARD_WEIGHTS = Path(__file__).with_name("shard_weights.json")
SHARD_DEFAULT = 0.74


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Keep the modules of shard I of N: every module whole and in its own order (module-level state — a shared
    random generator, cached meshes, module-scoped fixtures — evolves as in an unsharded run), the modules given
    out heaviest first (:data:`SHARD_WEIGHTS`), each to the shard with the least weight so far. With
    ``--cores-lock`` a module of multirank tests only weighs nothing (it runs alone, the other shards waiting), and
    every module with a multirank test runs first in its shard."""
    shard = config.getoption("--shard")
    if not shard:
        return
    try:
        index, count = (int(part) for part in shard.split("/"))
    except ValueError:
        raise pytest.UsageError(f"--shard {shard}: give I/N, e.g. 1/2") from None
    if not 1 <= index <= count:
        raise pytest.UsageError(f"--shard {shard}: need 1 <= I <= N")
    import json

    measured = json.loads(SHARD_WEIGHTS.read_text()) if SHARD_WEIGHTS.is_file() else {}
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        modules.setdefault(item.path.relative_to(config.rootpath).as_posix(), []).append(item)
    # a module whose every test runs alone (multirank, with --cores-lock) lengthens every shard alike: not split
    alone = {name for name, tests in modules.items()
             if config.getoption("--cores-lock") and all(t.get_closest_marker("multirank") for t in tests)}
    weight = {name: 0.0 if name in alone else float(measured.get(name, SHARD_DEFAULT * len(tests)))
              for name, tests in modules.items()}
    loads, kept = [0.0] * count, set()
    for name in sorted(modules, key=lambda m: (-weight[m], m)):
        target = loads.index(min(loads))
        loads[target] += weight[name]
        if target == index - 1:
            kept.add(name)
    inside = [item.path.relative_to(config.rootpath).as_posix() in kept for item in items]
    config.hook.pytest_deselected(items=[item for item, keep in zip(items, inside) if not keep])
    items[:] = [item for item, keep in zip(items, inside) if keep]
    if config.getoption("--cores-lock"):
        # the modules with multirank tests first (each whole, in its own order): the shards wait for each other's
        # while both still have work, and their other work, split evenly, ends together
        early = {name for name, tests in modules.items() if any(t.get_closest_marker("multirank") for t in tests)}
        items.sort(key=lambda item: item.path.relative_to(config.rootpath).as_posix() not in early)
