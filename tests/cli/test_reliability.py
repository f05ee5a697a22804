"""Never a wrong answer with exit 0, never a hang, one line for every bad input (issue 24), class by class.

Each test failed on the code before issue 24 (the interrupts of class 1 are in tests/cli/test_interrupts.py). The
in-process tests run on 1 rank (pytest) and 2 ranks (mpirun -n 2 ... pytest); the subprocess tests start the
real command.
"""

from __future__ import annotations

import errno
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from fenics_coulomb import ContactProblem, InputError
from fenics_coulomb.cli import EXIT_DIVERGED, EXIT_INPUT, EXIT_OUTPUT, main
from fenics_coulomb.io.results import _owner

ROOT = Path(__file__).resolve().parents[2]
PROG = "python3 -m fenics_coulomb: error:"


def shared_file(path: Path, content: str) -> Path:
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(content)
    MPI.COMM_WORLD.barrier()
    return path


def one_line(capsys, *fragments: str) -> str:
    """Rank 0 printed exactly one line naming every fragment; the other ranks nothing."""
    lines = capsys.readouterr().err.strip().splitlines()
    if MPI.COMM_WORLD.rank == 0:
        assert len(lines) == 1 and lines[0].startswith(PROG), lines
        for fragment in fragments:
            assert fragment in lines[0], (fragment, lines)
        return lines[0]
    assert lines == [], lines
    return ""


def run(*args: str) -> int:
    status = main([*args, "--no-plots", "--quiet"])
    MPI.COMM_WORLD.barrier()
    return status


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX", "PRTE_", "OMPI_MCA_orte"))}
    env["PYTHONPATH"] = str(ROOT)
    return env


# -- class 2: wrong answers with exit 0 -----------------------------------------------------------------------
@pytest.mark.parametrize("expression, shown", [("-1e300*x1", "-1e300*x1"), ("1/0", "inf"), ("0*x1/0", "nan")])
def test_expression_loads_are_evaluated_and_bounded(mpi_tmp_path, capsys, expression, shown):
    """A traction expression that overflows or is not finite on its boundary used to give |y0| = inf and
    "converged: 0 Newton" with a reaction of 1e298 (exit 0); now exit 2 naming the value and the node."""
    scene = shared_file(mpi_tmp_path / "t.toml", f'[body]\nlev = 1\n[tractions]\ntop = [0, 0, "{expression}"]\n')
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "out")) == EXIT_INPUT
    one_line(capsys, "traction on 'top'", expression, shown, "boundary node")
    assert not (mpi_tmp_path / "out").exists()


def _box(comm: MPI.Comm, cell: dolfinx.mesh.CellType = dolfinx.mesh.CellType.tetrahedron):
    msh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array([1.0, 1.0, 0.5])], [3, 3, 2], cell)
    msh.topology.create_connectivity(2, 3)
    return msh


def _problem(msh, **kwargs) -> ContactProblem:
    given = kwargs.get("a")  # the supports on the given form's own space
    V = given.arguments()[-1].ufl_function_space() if isinstance(given, ufl.Form) and len(given.arguments()) == 2 \
        else dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = ufl.inner(ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))) * ufl.dx
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    facets = np.concatenate([bottom, top])
    order = np.argsort(facets)
    markers = np.concatenate([np.full(bottom.size, 1), np.full(top.size, 2)])
    tags = dolfinx.mesh.meshtags(msh, 2, facets[order].astype(np.int32), markers[order].astype(np.int32))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, top), V)
    args = dict(a=a, L=None, bcs=[bc], contact=(tags, [1]), friction=0.3)
    args.update(kwargs)
    return ContactProblem(args["a"], args["L"], bcs=args["bcs"], contact=args["contact"], friction=args["friction"],
                          petsc_options_prefix="rel_")


@pytest.mark.parametrize("cell", [dolfinx.mesh.CellType.tetrahedron, dolfinx.mesh.CellType.hexahedron])
def test_zero_volume_cell_is_named_before_assembly(cell):
    """A zero-volume cell used to solve to u = 0 with the equilibrium 87.5 % off and exit 0."""
    msh = _box(MPI.COMM_WORLD, cell)
    if MPI.COMM_WORLD.rank == 0 and msh.topology.index_map(3).size_local:
        nodes = msh.geometry.dofmap[0]
        msh.geometry.x[nodes[1]] = msh.geometry.x[nodes[0]]  # collapse an edge of the first cell
    with pytest.raises(InputError, match=r"mesh cell \d+ \((tetrahedron|hexahedron), vertices .*zero volume"):
        _problem(msh)


def test_non_finite_node_coordinate_is_named():
    msh = _box(MPI.COMM_WORLD)
    if MPI.COMM_WORLD.rank == 0:
        msh.geometry.x[0, 1] = np.nan
    with pytest.raises(InputError, match="non-finite coordinates"):
        _problem(msh)


def test_the_physics_checks_decide_a_converged_solve(mpi_tmp_path, capsys, monkeypatch):
    """A solve that met its stopping target but whose solution fails the physics checks is not converged:
    exit 3 with the check named, summary.json says so."""
    import fenics_coulomb.problem as problem_module

    real = problem_module.physics_residuals

    def broken(model, displacement, balance=True, **kwargs):
        checks = real(model, displacement, balance, **kwargs)
        checks["equilibrium"] = 0.875
        return checks

    monkeypatch.setattr(problem_module, "physics_residuals", broken)
    out = mpi_tmp_path / "out"
    assert run("--lev", "1", "--out", str(out)) == EXIT_DIVERGED
    summary = json.loads((out / "summary.json").read_text())
    assert not summary["converged"] and summary["reason"] == "physics_check"
    assert summary["physics_checks"]["equilibrium"] == 0.875


# -- class 3: non-finite input ------------------------------------------------------------------------------
def test_nan_in_a_start_file_is_named(mpi_tmp_path, capsys):
    first, second = mpi_tmp_path / "first", mpi_tmp_path / "second"
    assert run("--lev", "1", "--out", str(first)) == 0
    if MPI.COMM_WORLD.rank == 0:
        import h5py

        with h5py.File(first / "solution.h5", "r+") as h5:
            data = h5["Function/displacement/0"]
            values = data[:]
            values[5, 1] = np.nan
            data[...] = values
    MPI.COMM_WORLD.barrier()
    capsys.readouterr()
    assert run("--lev", "1", "--out", str(second), "--start", str(first / "solution.xdmf")) == EXIT_INPUT
    one_line(capsys, "--start", "the displacement of node 5", "nan", "not finite")
    assert not second.exists()


# -- class 4: tracebacks ------------------------------------------------------------------------------------
def test_deeply_nested_toml_is_one_line(mpi_tmp_path, capsys):
    scene = shared_file(mpi_tmp_path / "deep.toml", "a = " + "[" * 3000 + "]" * 3000 + "\n")
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "o")) == EXIT_INPUT
    one_line(capsys, "nested too deeply")


def test_an_output_name_too_long_is_one_line(mpi_tmp_path, capsys):
    assert run("--lev", "0", "--out", str(mpi_tmp_path / ("a" * 300))) == EXIT_INPUT
    one_line(capsys, "--out", "300 bytes")


@pytest.mark.serial
def test_a_file_size_limit_while_writing_is_exit_4_in_one_line(tmp_path):
    """RLIMIT_FSIZE stops the HDF5 write (it used to end in an h5py traceback, and at exit in a crash of HDF5
    closing the broken file): exit 4, one line, the earlier result set byte for byte, no partial set."""
    out = tmp_path / "out"
    subprocess.run([sys.executable, "-m", "fenics_coulomb", "--lev", "1", "--out", str(out), "--quiet",
                    "--no-plots"], env=_env(), check=True)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (1_000_000, 1_000_000))

    env = dict(_env(), OMPI_MCA_btl="self")  # no shared-memory segment, which the limit would refuse as well
    proc = subprocess.run([sys.executable, "-m", "fenics_coulomb", "--lev", "6", "--out", str(out), "--quiet",
                           "--no-plots"], env=env, capture_output=True, text=True, preexec_fn=limit, timeout=300)
    assert proc.returncode == EXIT_OUTPUT, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "File too large" in lines[0] and "earlier results are kept" in lines[0], lines
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_file_that_fails_on_rank_0_alone_fails_the_set_on_every_rank(mpi_tmp_path, capsys, monkeypatch):
    """summary.json is written by rank 0 alone: a full disk there used to raise on rank 0 while the others waited
    in the next collective call. Now every rank ends with exit 4 and one line, and the earlier set stays."""
    import fenics_coulomb.io.summary as output

    out = mpi_tmp_path / "out"
    assert run("--lev", "0", "--out", str(out)) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()} if MPI.COMM_WORLD.rank == 0 else None

    class FullDisk:  # the output module's json, whose dumps (summary.json, rank 0) meets a full disk
        loads = staticmethod(json.loads)

        @staticmethod
        def dumps(*args, **kwargs):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(output, "json", FullDisk)
    capsys.readouterr()
    assert run("--lev", "1", "--out", str(out)) == EXIT_OUTPUT
    one_line(capsys, "summary.json: No space left on device", "earlier results are kept")
    if MPI.COMM_WORLD.rank == 0:
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before
        assert [p.name for p in mpi_tmp_path.iterdir()] == ["out"]


# -- class 5: leftovers -------------------------------------------------------------------------------------
def test_the_next_run_removes_what_a_killed_run_left(mpi_tmp_path):
    """A run killed while writing leaves .NAME.partial-HOST-PID-*: the next run into the same parent removes it when
    no process holds its lock (results._hold: a writer holds one as long as it lives), and leaves a live writer's
    alone — whatever process number the name carries (a dead run in another sandbox may carry a live one here)."""
    import fcntl

    host = _owner().rsplit("-", 1)[0]
    dead = 2**22 + 12345
    while True:
        try:
            os.kill(dead, 0)
            dead += 1
        except ProcessLookupError:
            break
    stale = mpi_tmp_path / f".out.partial-{host}-{dead}-deadbeef"
    reused = mpi_tmp_path / f".out.partial-{host}-{os.getppid()}-0badf00d"  # a live number, a dead writer
    alive = mpi_tmp_path / f".out.partial-{host}-{dead}-cafecafe"  # a dead number, a live writer (another sandbox)
    holder = None
    if MPI.COMM_WORLD.rank == 0:
        for entry in (stale, reused, alive):
            entry.mkdir()
            (entry / "solution.h5").write_bytes(b"half")
        holder = os.open(alive, os.O_RDONLY | os.O_DIRECTORY)
        fcntl.flock(holder, fcntl.LOCK_SH | fcntl.LOCK_NB)
    MPI.COMM_WORLD.barrier()
    try:
        assert run("--lev", "0", "--out", str(mpi_tmp_path / "out")) == 0
        assert not stale.exists() and not reused.exists() and alive.exists()
    finally:
        if holder is not None:
            os.close(holder)


# -- class 6: nonsense accepted ------------------------------------------------------------------------------
@pytest.mark.parametrize("obstacle, fragment", [
    ('type = "sphere"\ncenter = [1.0, 0.5, 0.5]\nradius = 0.1', "lies inside the body"),
    ('type = "cylinder"\npoint = [1.0, 0.5, 1.5]\naxis = [0, 1, 0]\nradius = 0.5\ndisplacement = [0, 0, -2.0]',
     "would pass through the body"),
])
def test_buried_or_teleported_obstacles_are_rejected(mpi_tmp_path, capsys, obstacle, fragment):
    """A sphere buried inside the body (every node open, exit 0) and a cylinder moved across a plate within one
    step (ending on the far side: u = 0, exit 0) are rejected with exit 2."""
    scene = shared_file(mpi_tmp_path / "o.toml", "[body]\nlev = 2\ngap = '0.0*x1'\nclamped = ['bottom']\n"
                        f"contact = ['top']\n[tractions]\n[[obstacle]]\n{obstacle}\n[solver]\nstart = 'undeformed'\n")
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "o")) == EXIT_INPUT
    one_line(capsys, "obstacle 1", fragment)


@pytest.mark.parametrize("args, fragment", [
    (["-coulomb_ksp_max_it", "-3"], "-coulomb_ksp_max_it -3: must be an integer >= 1"),
    (["-coulomb_ksp_rtol", "-1"], "-coulomb_ksp_rtol -1: must be a number in (0, 1)"),
    (["-coulomb_"], "has no name after the prefix"),
    (["--scene", ""], "--scene '': give a scene file"),
])
def test_nonsense_options_exit_2(mpi_tmp_path, capsys, args, fragment):
    assert run("--lev", "0", "--out", str(mpi_tmp_path / "n"), *args) == EXIT_INPUT
    one_line(capsys, fragment)
    assert not [k for k in PETSc.Options().getAll() if k.startswith("coulomb_")]


def test_the_command_line_petsc_options_end_with_the_command(mpi_tmp_path):
    """main() in-process (the API user's or a notebook's second call) used to leave -coulomb_pc_type jacobi in
    PETSc's database, which the next problem with the prefix coulomb_ then silently used."""
    assert run("--lev", "0", "--out", str(mpi_tmp_path / "o"), "-coulomb_pc_type", "jacobi",
               "-coulomb_ksp_gmres_restart", "50") == 0
    assert not [k for k in PETSc.Options().getAll() if k.startswith("coulomb_")]


def test_unbounded_integer_settings_exit_2(mpi_tmp_path, capsys):
    scene = shared_file(mpi_tmp_path / "p.toml", "[solver]\npower_iterations = 100000000\n")
    assert run("--scene", str(scene), "--out", str(mpi_tmp_path / "p")) == EXIT_INPUT
    one_line(capsys, "power_iterations = 100000000: must be at most 1000")


def test_petsc_options_of_the_api_are_checked():
    with pytest.raises(InputError, match="ksp_max_it -3"):
        _problem_with_options({"ksp_max_it": -3})
    with pytest.raises(InputError, match="without '-'"):
        _problem_with_options({"-ksp_monitor": ""})


def _problem_with_options(options: dict) -> None:
    msh = _box(MPI.COMM_WORLD)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 1, np.int32))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, top), V)
    ContactProblem(ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx, None, [bc], (tags, [1]),
                   petsc_options_prefix="opts_", petsc_options=options).destroy()


# -- class 7: API misuse ------------------------------------------------------------------------------------
def test_api_arguments_are_validated():
    """Each used to crash (a friction Function on another mesh: SIGSEGV) or build a wrong model silently."""
    comm = MPI.COMM_WORLD
    msh, other = _box(comm), _box(comm)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    problem = _problem(msh)
    tags, markers = problem.model.facet_tags, problem.model.markers
    problem.destroy()
    foreign = dolfinx.fem.Function(dolfinx.fem.functionspace(other, ("Lagrange", 1)))
    with pytest.raises(InputError, match="friction: the friction Function lives on another mesh"):
        _problem(msh, friction=foreign)
    V_other = dolfinx.fem.functionspace(other, ("Lagrange", 1, (3,)))
    other_tags = _problem(other).model.facet_tags
    with pytest.raises(InputError, match="contact: the facet tags belong to another mesh"):
        _problem(msh, contact=(other_tags, [1]))
    cells = dolfinx.mesh.meshtags(msh, 3, np.arange(msh.topology.index_map(3).size_local, dtype=np.int32),
                                  np.ones(msh.topology.index_map(3).size_local, dtype=np.int32))
    with pytest.raises(InputError, match="dimension 3"):
        _problem(msh, contact=(cells, [1]))
    collapsed, _ = V.sub(0).collapse()
    bc = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), np.zeros(1, dtype=np.int32), collapsed)
    with pytest.raises(InputError, match=r"bcs\[0\]: a boundary condition of another function space"):
        _problem(msh, bcs=[bc])
    bc_other = dolfinx.fem.dirichletbc(np.zeros(3), np.zeros(1, dtype=np.int32), V_other)
    with pytest.raises(InputError, match=r"bcs\[0\]"):
        _problem(msh, bcs=[bc_other])
    with pytest.raises(InputError, match="marker 9 is carried by no facet"):
        _problem(msh, contact=(tags, [9]))
    with pytest.raises(InputError, match="markers"):
        _problem(msh, contact=(tags, ["top"]))
    with pytest.raises(InputError, match=r"bcs\[0\]: int is not a dolfinx.fem.DirichletBC"):
        _problem(msh, bcs=[1])
    with pytest.raises(InputError, match="a: NoneType is not a bilinear UFL form"):
        _problem(msh, a=None)
    assert markers == [1]


def test_api_forms_spaces_and_facets_are_validated():
    """Found by a hostile review of the API, each a silent wrong answer or a raw PETSc crash before: a DG or CR vector
    space (the same DOFs per cell as P1: 0 contact nodes, u = inf returned without an error), a test space built
    like the trial space but another object (100 Newton steps), L on another space (PETSc error 75), a form over
    part of the cells (PETSc error 63), contact facets inside the body (40 contact nodes inside, converged), a
    one-component vector friction field (a DOLFINx RuntimeError), a friction Constant (its repr as the "value")."""
    comm = MPI.COMM_WORLD
    msh = _box(comm, dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    for family in ("DG",):
        W = dolfinx.fem.functionspace(msh, (family, 1, (3,)))
        w, y = ufl.TrialFunction(W), ufl.TestFunction(W)
        with pytest.raises(InputError, match="continuous vector Lagrange space of degree 1.*discontinuous P"):
            _problem(msh, a=ufl.inner(ufl.grad(w), ufl.grad(y)) * ufl.dx, bcs=[])
    tets = _box(comm)
    CR = dolfinx.fem.functionspace(tets, ("CR", 1, (3,)))
    w, y = ufl.TrialFunction(CR), ufl.TestFunction(CR)
    with pytest.raises(InputError, match="got a CR space"):
        _problem(tets, a=ufl.inner(ufl.grad(w), ufl.grad(y)) * ufl.dx, bcs=[])
    twin = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    with pytest.raises(InputError, match="test and trial functions must be on the same function space"):
        _problem(msh, a=ufl.inner(ufl.grad(u), ufl.grad(ufl.TestFunction(twin))) * ufl.dx)
    scalar = ufl.TestFunction(dolfinx.fem.functionspace(msh, ("Lagrange", 1)))
    with pytest.raises(InputError, match="L: its test function must be on the bilinear form's function space"):
        _problem(msh, a=ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx, L=scalar * ufl.dx)
    half = dolfinx.mesh.locate_entities(msh, 3, lambda x: x[0] <= 0.34)
    cells = dolfinx.mesh.meshtags(msh, 3, half.astype(np.int32), np.ones(half.size, np.int32))
    dx = ufl.Measure("dx", domain=msh, subdomain_data=cells)
    with pytest.raises(InputError, match=r"does not integrate over the cell at \(0.5, .*every cell needs"):
        _problem(msh, a=ufl.inner(ufl.grad(u), ufl.grad(v)) * dx(1))
    stiffness = dolfinx.fem.Function(dolfinx.fem.functionspace(msh, ("DG", 0)))  # a material of modulus 0 there
    stiffness.interpolate(lambda x: (x[0] <= 0.34).astype(float))
    with pytest.raises(InputError, match="gives the DOF at .* no stiffness"):
        _problem(msh, a=stiffness * ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx)
    inner = dolfinx.mesh.locate_entities(msh, 2, lambda x: np.isclose(x[2], 0.25))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(inner).astype(np.int32), np.full(inner.size, 7, np.int32))
    with pytest.raises(InputError, match=r"markers \[7\] tag an interior facet"):
        _problem(msh, contact=(tags, [7]))
    vector = dolfinx.fem.Function(dolfinx.fem.functionspace(msh, ("Lagrange", 1, (1,))))
    with pytest.raises(InputError, match=r"must be scalar \(its shape is \(1,\)\)"):
        _problem(msh, friction=vector)
    with pytest.raises(InputError, match="friction: a dolfinx Constant: give a number"):
        _problem(msh, friction=dolfinx.fem.Constant(msh, 0.2))


def test_what_the_problem_reads_once_may_not_change_silently():
    """The stiffness is assembled and the friction field evaluated once: a Young's modulus Constant of the form or the
    friction Function changed between solves gave the old model's answer (max |u| 2.817e-2 for E 70 → 35, where a new
    problem gives 4.577e-2; F 0 → 0.5 bit for bit F = 0's), the checks passing on the old matrix. Now the next solve
    is an InputError naming what changed. A failed linear solve of a body without contact nodes returned
    ``converged=False`` instead of raising."""
    from fenics_coulomb import SolverError

    comm = MPI.COMM_WORLD
    msh = _box(comm, dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    E = dolfinx.fem.Constant(msh, 70.0)
    F = dolfinx.fem.Function(dolfinx.fem.functionspace(msh, ("Lagrange", 1)))
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 1, np.int32))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, top), V)
    load = ufl.inner(dolfinx.fem.Constant(msh, np.array([0.0, 0.0, -0.01])), v) * ufl.dx
    problem = ContactProblem(E * ufl.inner(ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(v))) * ufl.dx, load, [bc],
                             (tags, [1]), friction=F, petsc_options_prefix="frozen_")
    try:
        problem.solve()
        F.x.array[:] = 0.5
        with pytest.raises(InputError, match="the friction field changed after the problem was built"):
            problem.solve()
        F.x.array[:] = -0.0
        problem.solve()  # as built again (−0.0 is 0.0)
        E.value = 35.0
        with pytest.raises(InputError, match="the bilinear form's Constant 1 changed after the problem was built"):
            problem.solve()
    finally:
        problem.destroy()
    msh = _box(comm)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(top).astype(np.int32), np.full(top.size, 1, np.int32))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, top), V)
    with ContactProblem(ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx,
                        ufl.inner(ufl.as_vector((0, 0, -1.0)), v) * ufl.dx, [bc], (tags, []),
                        petsc_options_prefix="nc_", petsc_options={"pc_type": "jacobi", "ksp_max_it": 1}) as nothing:
        with pytest.raises(SolverError, match="no contact boundary: the linear solve failed"):
            nothing.solve()


def test_api_messages_name_the_argument(mpi_tmp_path):
    """write_results named the command's flag (--out) and reset's NaN said "of shape (2, 3): need ... (2, 3)"."""
    from fenics_coulomb import Sphere
    from fenics_coulomb.io.writer import write_results

    msh = _box(MPI.COMM_WORLD)
    problem = _problem(msh)
    try:
        _, result = problem.solve()
        taken = mpi_tmp_path / "a_file"
        if MPI.COMM_WORLD.rank == 0:
            taken.write_text("")
        MPI.COMM_WORLD.barrier()
        with pytest.raises(InputError, match="^write_results: path '.*a_file': exists and is not a directory"):
            write_results(taken, problem, result)
    finally:
        problem.destroy()
    with ContactProblem(*_forms(msh), obstacles=[Sphere((0.5, 0.5, -1.0), 0.9), Sphere((0.5, 0.5, 2.0), 0.9)],
                        petsc_options_prefix="msg_") as two:
        with pytest.raises(InputError, match=r"obstacle_displacements\[1\] = \[0.0, nan, 0.0\]: must be finite"):
            two.reset(obstacle_displacements=[[0.0, 0.0, 0.0], [0.0, np.nan, 0.0]])


def _forms(msh) -> tuple:
    """(a, L, bcs, contact) of a block on the plane, clamped on its top: the arguments of ContactProblem."""
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    bottom = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.0))
    top = dolfinx.mesh.locate_entities_boundary(msh, 2, lambda x: np.isclose(x[2], 0.5))
    tags = dolfinx.mesh.meshtags(msh, 2, np.sort(bottom).astype(np.int32), np.full(bottom.size, 1, np.int32))
    bc = dolfinx.fem.dirichletbc(np.zeros(3), dolfinx.fem.locate_dofs_topological(V, 2, top), V)
    return ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx, None, [bc], (tags, [1])


def test_the_settings_change_through_set_solver_only():
    """``problem.settings = SolverSettings(rtol=1e-3, max_it=2)`` reached the start rule and the checks' bound but
    not the solver (rtol 1e-7, 9 iterations): half applied. The attribute is read-only; set_solver replaces both."""
    from fenics_coulomb import SolverSettings

    with _problem(_box(MPI.COMM_WORLD)) as problem:
        with pytest.raises(AttributeError):
            problem.settings = SolverSettings(rtol=1e-3)
        problem.set_solver(SolverSettings(rtol=1e-3))
        assert problem.settings.rtol == 1e-3 and problem.solver.settings.rtol == 1e-3


def test_numpy_scalars_are_the_numbers_they_hold():
    """np.int64(5) is an integer: it was "must be an integer >= 1" (np.float32 "must be a finite number")."""
    from fenics_coulomb import SolverSettings

    settings = SolverSettings(max_it=np.int64(5), tol=np.float32(0.25), rtol=np.float64(1e-6), predictor=np.True_,
                              pc=np.str_("lu"))
    assert (settings.max_it, settings.tol, settings.rtol, settings.predictor) == (5, 0.25, 1e-6, True)
    assert type(settings.max_it) is int and type(settings.pc) is str and settings.pc == "lu"
    with pytest.raises(InputError, match="max_it = 0: must be an integer >= 1"):
        SolverSettings(max_it=np.int64(0))


# -- class 8: the launcher stays quiet ---------------------------------------------------------------------
@pytest.mark.serial
@pytest.mark.multirank
def test_mpirun_prints_only_our_line_on_bad_input(tmp_path):
    """OpenMPI printed its "exited with non-zero status" block (and sometimes a PMIX_ERR_UNREACH line) after our
    line whenever rank 0 ended non-zero: the ranks now finalize together, the others end 0 and rank 0 alone with
    the status."""
    for args in (["--lev", "-1"], ["--lev", "0", "-coulomb_ksp_rtol", "2"], ["--scene", str(tmp_path / "none.toml")]):
        proc = subprocess.run(["mpirun", "-n", "2", sys.executable, "-m", "fenics_coulomb", *args, "--out",
                               str(tmp_path / "o")], capture_output=True, text=True, env=_env(), cwd=tmp_path,
                              timeout=120)
        assert proc.returncode == EXIT_INPUT, proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1 and proc.stderr.startswith(PROG), proc.stderr
