"""The result set of a run: the XDMF time-series writer and reader, atomic output, figures that never cost a
result (1 and 2 ranks)."""

from __future__ import annotations

import json
import uuid
import xml.etree.ElementTree as ET
from pathlib import Path

from mpi4py import MPI

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import h5py
import numpy as np
import pytest

from fenics_coulomb import cli
from fenics_coulomb.io import figures
from fenics_coulomb.cli import EXIT_DIVERGED, EXIT_INPUT, main
from fenics_coulomb.errors import InputError
from fenics_coulomb.io.xdmf import XDMFTimeSeries
from fenics_coulomb.io.xdmf_read import read_displacement

ROOT = Path(__file__).resolve().parents[2]

A = np.array([[0.3, -0.2, 0.1], [0.05, 0.4, -0.3], [-0.1, 0.2, 0.25]])


def linear_field(x: np.ndarray, t: float) -> np.ndarray:
    """u(x, t) = A x + t (1, 2, 3): exactly representable in P1 on any mesh."""
    return (A @ x) + t * np.array([1.0, 2.0, 3.0])[:, None]


def parse(path: Path) -> ET.Element:
    text = path.read_text()
    assert "XInclude" not in text and "https" not in text
    return ET.fromstring(text)


def grids(root: ET.Element) -> list[ET.Element]:
    series = root.findall("Domain/Grid")
    assert len(series) == 1 and series[0].get("CollectionType") == "Temporal"
    return series[0].findall("Grid")


def snapshot(directory: Path) -> dict[str, bytes]:
    """All entries of a result directory with their contents."""
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


def leftovers(directory: Path) -> list[str]:
    """Temporary siblings of an output directory left behind."""
    return [p.name for p in directory.parent.iterdir() if p.name.startswith(f".{directory.name}.")]


@pytest.mark.parametrize("cell", [dolfinx.mesh.CellType.hexahedron, dolfinx.mesh.CellType.tetrahedron])
def test_time_series_roundtrip(cell, mpi_tmp_path):
    """A three-time series on hexahedra and tetrahedra: one grid per time with every field, float64 and int32
    data at the global vertices, and --start's reader returns the LAST time interpolated onto another mesh."""
    comm = MPI.COMM_WORLD
    msh = dolfinx.mesh.create_box(comm, [[0, 0, 0], [2, 1, 1]], [4, 3, 2], cell)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1, (3,)))
    S = dolfinx.fem.functionspace(msh, ("Lagrange", 1))
    u = dolfinx.fem.Function(V, name="displacement")
    k = dolfinx.fem.Function(S, name="category")
    times = [0.0, 0.5, 1.25]
    path = mpi_tmp_path / "series.xdmf"
    with XDMFTimeSeries(path, msh) as xdmf:
        for i, t in enumerate(times):
            u.interpolate(lambda x, t=t: linear_field(x, t))
            k.interpolate(lambda x, i=i: np.rint(2 * x[0]) - i + 0.3)
            xdmf.write(t, [u, k], dtypes={"category": np.int32})
        assert xdmf.times == times
    comm.barrier()
    root = parse(path)
    written = grids(root)
    assert [float(g.find("Time").get("Value")) for g in written] == times
    ncells = msh.topology.index_map(3).size_global
    nverts = msh.topology.index_map(0).size_global
    for i, grid in enumerate(written):
        topology = grid.find("Topology")
        assert topology.get("TopologyType") == {"hexahedron": "Hexahedron", "tetrahedron": "Tetrahedron"}[
            msh.topology.cell_name()]
        attributes = {a.get("Name"): a.find("DataItem") for a in grid.findall("Attribute")}
        assert set(attributes) == {"displacement", "category"}
        assert (attributes["displacement"].get("NumberType"), attributes["displacement"].get("Precision")) == (
            "Float", "8")
        assert (attributes["category"].get("NumberType"), attributes["category"].get("Precision")) == ("Int", "4")
        assert grid.find("Geometry/DataItem").get("Precision") == "8"
        with h5py.File(path.with_suffix(".h5"), "r") as h5:
            x = h5["Mesh/mesh/geometry"][:]
            cells = h5["Mesh/mesh/topology"][:]
            ui = h5[attributes["displacement"].text.split(":")[1]][:]
            ki = h5[attributes["category"].text.split(":")[1]][:]
        assert x.shape == (nverts, 3) and cells.shape[0] == ncells and x.dtype == ui.dtype == np.float64
        assert ki.dtype == np.int32 and ki.shape == (nverts,)
        assert np.array_equal(np.unique(cells), np.arange(nverts))  # every vertex once, global numbering
        assert np.allclose(ui, linear_field(x.T, times[i]).T, atol=1e-13)
        assert np.array_equal(ki, np.rint(2 * x[:, 0]).astype(np.int32) - i)  # rounded
        # cells in VTK order: a hexahedron's vertices 0-3 run around its bottom face (0 and 2 are opposite,
        # 0-4 is an edge); a tetrahedron is not degenerate
        p = x[cells]
        edge = np.linalg.norm(p[:, 1] - p[:, 0], axis=1)
        if cells.shape[1] == 8:
            assert np.all(np.linalg.norm(p[:, 2] - p[:, 0], axis=1) > 1.1 * edge)
            assert np.all(np.linalg.norm(p[:, 2] - p[:, 1], axis=1) < np.linalg.norm(p[:, 3] - p[:, 1], axis=1))
            assert np.allclose(np.linalg.norm(p[:, 4] - p[:, 0], axis=1), 0.5)
        else:
            vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
            assert np.all(np.abs(vol) > 1e-6)
    # the reader: the last time, onto a non-matching mesh of the other cell type
    other = dolfinx.mesh.create_box(comm, [[0, 0, 0], [2, 1, 1]], [3, 2, 3],
                                    dolfinx.mesh.CellType.tetrahedron if cell == dolfinx.mesh.CellType.hexahedron
                                    else dolfinx.mesh.CellType.hexahedron)
    W = dolfinx.fem.functionspace(other, ("Lagrange", 1, (3,)))
    values = read_displacement(path, W).reshape(-1, 3)
    xw = W.tabulate_dof_coordinates()[: W.dofmap.index_map.size_local]
    assert np.allclose(values, linear_field(xw.T, times[-1]).T, atol=1e-12)


def test_time_series_refuses_what_it_cannot_write(mpi_tmp_path):
    """XDMFTimeSeries.write checks its arguments on every rank before it writes (a review found each of these
    written silently, or hanging on 2 ranks): a field on a mesh built alike (another vertex numbering on several
    ranks: its values landed on the wrong vertices, 7.25 off), two fields of one name (the first was lost), a name
    with '/' or none, a non-finite or earlier time, non-finite values stored as integers. A valid write follows."""
    comm = MPI.COMM_WORLD
    box = [np.zeros(3), np.ones(3)]
    msh = dolfinx.mesh.create_box(comm, box, [4, 4, 2], dolfinx.mesh.CellType.hexahedron)
    alike = dolfinx.mesh.create_box(comm, box, [4, 4, 2], dolfinx.mesh.CellType.hexahedron)
    V = dolfinx.fem.functionspace(msh, ("Lagrange", 1))
    f, g = dolfinx.fem.Function(V, name="f"), dolfinx.fem.Function(V, name="f")
    g.x.array[:] = np.inf
    other = dolfinx.fem.Function(dolfinx.fem.functionspace(alike, ("Lagrange", 1)), name="other")
    with pytest.raises(InputError, match="XDMFTimeSeries: mesh = str"):
        XDMFTimeSeries(mpi_tmp_path / "x.xdmf", "mesh")
    with pytest.raises(InputError, match="XDMFTimeSeries: path = ''"):
        XDMFTimeSeries("", msh)
    with XDMFTimeSeries(mpi_tmp_path / "checked.xdmf", msh) as xdmf:
        xdmf.write(1.0, [f])
        for t, fields, dtypes, match in [
            (2.0, [other], None, "field 'other' lives on another mesh"),
            (2.0, [f, g], None, "two fields named 'f'"),
            (2.0, {"a/b": f}, None, "field name 'a/b'"),
            (2.0, {"": f}, None, "field name ''"),
            (float("nan"), [f], None, "t = nan"),
            (0.5, [f], None, "t = 0.5 comes before the last time written, 1"),
            (2.0, {"state": g}, {"state": np.int32}, "field 'state' holds non-finite values"),
        ]:
            with pytest.raises(InputError, match=match):
                xdmf.write(t, fields, dtypes=dtypes)
        xdmf.write(1.0, {"f": f, "g": g})  # the same time again, non-finite floats: written
        assert xdmf.times == [1.0, 1.0]


def test_solution_file(mpi_tmp_path):
    """solution.xdmf of a run: ONE grid with all ten fields, float64 except the categorical contact_state;
    the fields agree with summary.json and with the default plane's frame (n = e3, tangential force ⊥ n,
    gap ≥ 0, traction along the pressure)."""
    out = mpi_tmp_path / "run"
    assert main(["--lev", "1", "--out", str(out), "--quiet", "--no-plots"]) == 0
    MPI.COMM_WORLD.barrier()
    (grid,) = grids(parse(out / "solution.xdmf"))
    assert grid.get("Name") == "solution"
    info = {i.get("Name"): i.get("Value") for i in grid.findall("Information")}
    assert info["converged"] == "true" and "1 stick" in info["contact_state"]
    items = {a.get("Name"): a.find("DataItem") for a in grid.findall("Attribute")}
    assert list(items) == ["displacement", "contact_state", "contact_pressure", "contact_force", "tangential_force",
                           "contact_traction", "gap", "contact_normal", "stress", "von_mises"]
    for name, item in items.items():
        expected = ("Int", "4") if name == "contact_state" else ("Float", "8")
        assert (item.get("NumberType"), item.get("Precision")) == expected
    summary = json.loads((out / "summary.json").read_text())
    with h5py.File(out / "solution.h5", "r") as h5:
        state = h5["Function/contact_state/0"][:]
        fields = {name: h5[f"Function/{name}/0"][:] for name in
                  ("contact_pressure", "contact_force", "tangential_force", "contact_traction", "gap",
                   "contact_normal")}
    contact = state >= 0
    assert np.array_equal(fields["contact_normal"][contact], np.tile([0.0, 0.0, 1.0], (contact.sum(), 1)))
    assert not fields["contact_normal"][~contact].any() and not fields["gap"][~contact].any()
    assert np.all(fields["tangential_force"][:, 2] == 0.0) and fields["tangential_force"][contact, :2].any()
    assert np.all(fields["gap"][contact] >= -1e-10) and np.any(fields["gap"][contact] > 0.0)
    pressed = fields["contact_pressure"] > 0.0
    assert np.all(fields["contact_traction"][pressed, 2] > 0.0)
    assert not fields["contact_traction"][~pressed, 2].any()
    # one meaning per name: contact_pressure = the traction's normal component (force per area); contact_force
    # = the nodal force vector, summing to summary.json's total; the units as the grid's metadata
    assert np.allclose(fields["contact_traction"][:, 2], fields["contact_pressure"], rtol=1e-12, atol=0)
    assert np.allclose(fields["contact_force"].sum(axis=0), summary["contact_force"], rtol=1e-10)
    assert "contact_pressure GPa" in info["units"] and "contact_force GPa*L^2" in info["units"]
    counts = {name: int(np.sum(state == code)) for code, name in enumerate(("open", "stick", "slip"))}
    assert counts == summary["state_counts"] and np.sum(state == -1) == state.size - summary["p"]
    assert summary["files"] == ["solution.xdmf", "solution.h5", "convergence.csv", "view.py", "obstacles.xdmf",
                                "obstacles.h5", "summary.json"]


def test_not_converged_is_marked(mpi_tmp_path):
    """A solve stopped by the iteration limit (exit 3) writes its last iterate, marked as such."""
    out = mpi_tmp_path / "stopped"
    assert main(["--lev", "1", "--max-it", "2", "--out", str(out), "--quiet", "--no-plots"]) == EXIT_DIVERGED
    MPI.COMM_WORLD.barrier()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False and summary["reason"] == "max_iterations"
    (grid,) = grids(parse(out / "solution.xdmf"))
    assert "NOT converged" in grid.get("Name") and "max_iterations" in grid.get("Name")
    info = {i.get("Name"): i.get("Value") for i in grid.findall("Information")}
    assert info["converged"] == "false" and info["reason"] == "max_iterations"


def run_args(argv: list[str]):
    args, petsc = cli.build_parser().parse_known_args(argv)
    assert not petsc
    return args


def test_failure_while_writing_keeps_previous_results(mpi_tmp_path, monkeypatch):
    """A failure while the result set is written (after the new solution.* exist) leaves the previous set
    byte for byte and no temporary directory behind."""
    comm = MPI.COMM_WORLD
    out = mpi_tmp_path / "atomic"
    assert main(["--lev", "0", "--out", str(out), "--quiet", "--no-plots"]) == 0
    comm.barrier()
    before = snapshot(out)

    def broken(*args, **kwargs):
        raise RuntimeError("disk full (simulated)")

    import fenics_coulomb.io.writer as writer

    monkeypatch.setattr(writer, "write_convergence_csv", broken)  # the one result writer of the CLI and the API
    with pytest.raises(RuntimeError, match="simulated"):
        cli.run(run_args(["--lev", "1", "--friction", "0.1", "--out", str(out), "--quiet", "--no-plots"]), comm)
    comm.barrier()
    assert snapshot(out) == before
    assert leftovers(out) == []


def xvfb_with(marker: str) -> list[int]:
    """Xvfb processes that inherited the environment marker (started by this test's processes)."""
    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            if (proc / "comm").read_text().strip() == "Xvfb" and marker.encode() in (proc / "environ").read_bytes():
                found.append(int(proc.name))
        except OSError:
            continue
    return found


def test_plots_never_cost_results(mpi_tmp_path, monkeypatch, capsys):
    """A scene name that is not valid math text is drawn literally; a figure that fails is a warning (exit 0,
    all other files written); a --no-plots rerun leaves no stale PNG; files the previous run did not write
    survive; no Xvfb is left running."""
    comm = MPI.COMM_WORLD
    marker = f"FENICS_COULOMB_TEST_{uuid.uuid4().hex}"
    monkeypatch.setenv(marker, "1")
    monkeypatch.delenv("DISPLAY", raising=False)
    scene = mpi_tmp_path / "math.toml"
    if comm.rank == 0:
        scene.write_text('[body]\nlev = 0\nname = "$\\\\foo{ 50% $x_1"\n')
    comm.barrier()
    out = mpi_tmp_path / "plots"
    assert main(["--scene", str(scene), "--out", str(out), "--quiet"]) == 0
    comm.barrier()
    pngs = {"convergence.png", "contact_states.png", "deformed.png"}
    assert pngs <= {p.name for p in out.iterdir()}
    assert json.loads((out / "summary.json").read_text())["scene"]["name"] == "$\\foo{ 50% $x_1"
    assert xvfb_with(marker) == []
    # a user's file in the result directory is carried over; the PNGs of the previous run are not
    if comm.rank == 0:
        (out / "notes.txt").write_text("mine")
    comm.barrier()
    assert main(["--scene", str(scene), "--out", str(out), "--quiet", "--no-plots"]) == 0
    comm.barrier()
    assert not list(out.glob("*.png")) and (out / "notes.txt").read_text() == "mine"
    # a figure that cannot be drawn: a warning, the rest of the results are there
    capsys.readouterr()

    def broken(*args, **kwargs):
        raise RuntimeError("no renderer (simulated)")

    monkeypatch.setattr(figures, "render_deformed", broken)
    assert main(["--scene", str(scene), "--out", str(out)]) == 0
    comm.barrier()
    names = {p.name for p in out.iterdir()}
    assert {"convergence.png", "contact_states.png", "solution.h5", "summary.json"} <= names
    assert "deformed.png" not in names
    assert "deformed.png" not in json.loads((out / "summary.json").read_text())["files"]
    if comm.rank == 0:
        assert "deformed.png not written" in capsys.readouterr().err
    assert leftovers(out) == []


def test_refuses_a_foreign_directory(mpi_tmp_path, capsys):
    """An existing non-empty directory that is not a result set is never replaced (exit 2, untouched)."""
    comm = MPI.COMM_WORLD
    target = mpi_tmp_path / "mine"
    if comm.rank == 0:
        target.mkdir()
        (target / "thesis.tex").write_text("precious")
    comm.barrier()
    assert main(["--lev", "0", "--out", str(target), "--no-plots"]) == EXIT_INPUT
    assert (target / "thesis.tex").read_text() == "precious" and len(list(target.iterdir())) == 1
    if comm.rank == 0:
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "not a fenics-coulomb result set" in err[0]


def test_the_deformed_figure_looks_at_the_contact_side(mpi_tmp_path, monkeypatch):
    """deformed.png's camera sits on the obstacle's side of the contact with the largest force (issue 26): below
    the paper's cuboid on its plane, above a block a sphere presses from above."""
    from fenics_coulomb.io.figures import contact_view

    below, _ = contact_view((0.0, 0.0, 1.0))  # the plane's normal points up into the body
    above, _ = contact_view((0.0, 0.0, -1.0))  # the sphere's normal points down into the block
    assert below[2] < -0.7 and above[2] > 0.7
    seen = []
    def render(parts, contact, path, title="", normal=None, slaves=()):  # the figure, as an empty file
        seen.append(normal)
        Path(path).write_bytes(b"")

    monkeypatch.setattr(figures, "render_deformed", render)
    scene = ROOT / "demos" / "scenes" / "sphere_indentation.toml"
    assert main(["--scene", str(scene), "--lev", "1", "--out", str(mpi_tmp_path / "s"), "--quiet"]) == 0
    if MPI.COMM_WORLD.rank == 0:
        (normal,) = seen
        assert contact_view(normal)[0][2] > 0  # the camera is above the indented top, looking down


def test_the_state_legend_survives_a_round_patch(tmp_path):
    """contact_states.png of a round patch (as tall as wide) keeps its whole legend below the axes: with no
    sliding node the gold of "sliding" can only come from the legend's marker, and no row at the figure's lower
    edge is drawn on (the legend was cut there)."""
    import matplotlib.image

    if MPI.COMM_WORLD.rank:
        return
    angle = np.linspace(0.0, 2 * np.pi, 200, endpoint=False)
    radius = np.sqrt(np.linspace(0.0, 1.0, 200))
    xy = np.column_stack([radius * np.cos(7 * angle), radius * np.sin(7 * angle)])
    states = np.where(radius < 0.5, 1, 0).astype(np.int8)  # stick inside, open outside, no slip
    png = tmp_path / "states.png"
    figures.plot_contact_states(xy, states, png, "round")
    image = matplotlib.image.imread(png)[..., :3]
    gold = np.all(np.abs(image - np.array([1.0, 0.843, 0.0])) < 0.03, axis=-1)
    assert gold.sum() > 20
    rows = np.flatnonzero(gold.any(axis=1))
    assert rows.min() > 0.8 * image.shape[0]  # below the patch
    assert rows.max() < image.shape[0] - 10  # and whole: not cut by the figure's edge
    assert np.all(image[-5:] > 0.95)  # nothing drawn on the last rows


@pytest.mark.parametrize("axis", [0, 1])
def test_the_states_of_nodes_on_a_line_are_drawn(tmp_path, axis):
    """Contact nodes on one line (a body's edge on a cylinder): the equal aspect made a 960 x 270 919 285 pixel
    figure, and contact_states.png was not written. Now a figure of ordinary size with every node."""
    import matplotlib.image

    if MPI.COMM_WORLD.rank:
        return
    xy = np.zeros((11, 2))
    xy[:, axis] = np.linspace(0.0, 1.0, 11)
    png = tmp_path / "line.png"
    figures.plot_contact_states(xy, np.ones(11, dtype=np.int8), png, "line")
    image = matplotlib.image.imread(png)
    assert 100 < image.shape[0] < 2000 and 100 < image.shape[1] < 2000


def test_the_pressure_map_zooms_onto_the_patch(tmp_path):
    """contact_pressure.png of a small round patch on a large contact surface shows the patch: a square window
    holding every node in contact, a fraction of the surface wide; without contact the whole surface."""
    if MPI.COMM_WORLD.rank:
        return
    x1, x2 = np.meshgrid(np.linspace(0.0, 2.0, 81), np.linspace(0.0, 1.0, 41), indexing="ij")
    xy = np.column_stack([x1.ravel(), x2.ravel()])
    r = np.hypot(xy[:, 0] - 1.2, xy[:, 1] - 0.4)
    pressure = np.where(r < 0.1, 5.0 * np.sqrt(np.clip(1 - (r / 0.1) ** 2, 0, 1)), 0.0)  # Hertz-like
    states = np.where(pressure > 0, 1, 0).astype(np.int8)
    x0, x1_, y0, y1 = figures.plot_contact_pressure(xy, pressure, states, tmp_path / "p.png", "patch")
    assert (tmp_path / "p.png").stat().st_size > 10_000
    inside = xy[pressure > 0]
    assert np.all((inside[:, 0] > x0) & (inside[:, 0] < x1_) & (inside[:, 1] > y0) & (inside[:, 1] < y1))
    assert x1_ - x0 == pytest.approx(y1 - y0) and 0.2 < x1_ - x0 < 0.5  # the patch is 0.2 wide, the surface 2
    x0, x1_, y0, y1 = figures.plot_contact_pressure(xy, 0 * pressure, 0 * states, tmp_path / "q.png")
    assert x0 < 0.0 and x1_ > 2.0
