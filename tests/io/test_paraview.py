"""The real client: ParaView (trixie's paraview/python3-paraview, under a private Xvfb) opens solution.xdmf of a
2-rank run as docs/outputs.md says: File ▸ Open (the default reader for .xdmf) ▸ Apply ▸ Warp By
Vector ▸ colour by contact_state. Every ParaView session is a subprocess, so a reader that crashes fails the
test instead of killing pytest."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np
import pytest

from fenics_coulomb.cli import main
from fenics_coulomb.io.display import virtual_display

pytestmark = pytest.mark.serial

PROBE = Path(__file__).resolve().parents[1] / "paraview_probe.py"
FIELDS = {"displacement": 3, "contact_state": 1, "contact_pressure": 1, "contact_force": 3, "tangential_force": 3,
          "contact_traction": 3, "gap": 1, "contact_normal": 3, "stress": 9, "von_mises": 1}
ARGS = ["--lev", "2", "--gap", "d3", "--load", "L2"]


def clean_env() -> dict[str, str]:
    """The environment without the MPI singleton's variables (a child mpirun must start afresh)."""
    return {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_COMM", "PMIX", "PRTE_"))}


@pytest.fixture(scope="module")
def two_rank_run(tmp_path_factory) -> Path:
    """``mpirun -n 2 python3 -m fenics_coulomb --lev 2 --out DIR`` as a user runs it."""
    out = tmp_path_factory.mktemp("paraview") / "run"
    mpirun = shutil.which("mpirun")
    assert mpirun is not None
    cmd = [mpirun, "-n", "2", sys.executable, "-m", "fenics_coulomb", *ARGS, "--out", str(out), "--quiet",
           "--no-plots"]
    done = subprocess.run(cmd, env=clean_env(), capture_output=True, text=True, timeout=300,
                          cwd=Path(__file__).parents[2])
    assert done.returncode == 0, done.stderr
    return out


def probe(path: Path, reader: str, screenshot: Path | None = None) -> dict:
    """Open ``path`` in a pvpython subprocess; return its report (fails on a crash or an error)."""
    cmd = ["pvpython", "--force-offscreen-rendering", str(PROBE), str(path), reader]
    if screenshot is not None:
        cmd.append(str(screenshot))
    with virtual_display():
        done = subprocess.run(cmd, env=clean_env(), capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, f"{reader}: exit {done.returncode}\n{done.stderr[-3000:]}"
    lines = [line for line in done.stdout.splitlines() if line.startswith("PROBE ")]
    assert len(lines) == 1, done.stdout + done.stderr
    return json.loads(lines[0][len("PROBE "):])


def h5_fields(out: Path) -> dict[str, np.ndarray]:
    with h5py.File(out / "solution.h5", "r") as h5:
        data = {name: h5[f"Function/{name}/0"][:] for name in FIELDS}
        data["x"] = h5["Mesh/mesh/geometry"][:]
        data["cells"] = h5["Mesh/mesh/topology"][:]
    return data


def check_block(block: dict, data: dict[str, np.ndarray]) -> None:
    """One unstructured grid with all fields as point data, float64 (int for the categorical contact_state),
    with the ranges of the written data."""
    assert block["class"] == "vtkUnstructuredGrid"
    assert block["points"] == data["x"].shape[0] and block["cells"] == data["cells"].shape[0]
    assert block["point_type"] == "double"
    assert set(block["arrays"]) == set(FIELDS)
    for name, components in FIELDS.items():
        array = block["arrays"][name]
        assert array["components"] == components and array["tuples"] == data["x"].shape[0]
        assert array["type"] == ("int" if name == "contact_state" else "double"), (name, array["type"])
        values = data[name].reshape(data[name].shape[0], -1)
        for c in range(components):
            assert array["component_ranges"][c] == pytest.approx([values[:, c].min(), values[:, c].max()],
                                                                 rel=1e-15, abs=1e-300)


@pytest.mark.multirank  # the first to ask starts two_rank_run
def test_default_reader_shows_all_fields_on_the_deformed_body(two_rank_run, tmp_path):
    """File ▸ Open ▸ Apply ▸ Warp By Vector ▸ colour by contact_state, on the output of a 2-rank run."""
    summary = json.loads((two_rank_run / "summary.json").read_text())
    assert summary["ranks"] == 2 and summary["converged"]
    data = h5_fields(two_rank_run)
    png = tmp_path / "paraview.png"
    report = probe(two_rank_run / "solution.xdmf", "default", png)
    (block,) = report["blocks"]
    check_block(block, data)
    # the ranges agree with the run's summary: the contact states and their counts
    states = data["contact_state"]
    present = [-1] + [code for code, name in enumerate(("open", "stick", "slip")) if summary["state_counts"][name]]
    assert block["arrays"]["contact_state"]["range"] == [min(present), max(present)]
    assert int(np.sum(states >= 0)) == summary["p"]
    # Warp By Vector moves the body: its bounds are those of x + u, the bottom ends on the obstacle x3 = 0
    assert report["warp_vectors"] == ["POINTS", "displacement"]
    (warped,) = report["warped"]
    deformed = data["x"] + data["displacement"]
    bounds = np.ravel(np.column_stack([deformed.min(axis=0), deformed.max(axis=0)]))
    assert np.allclose(warped["bounds"], bounds, atol=1e-12)
    assert warped["bounds"][4] == pytest.approx(0.0, abs=1e-9)
    assert not np.allclose(warped["bounds"], block["bounds"], atol=1e-3)
    assert report["colour_array"] == "contact_state" and report["lut_range"] == [min(present), max(present)]
    # the screenshot shows the body in several colours over the background
    import matplotlib.image

    image = matplotlib.image.imread(png)[..., :3]
    background = image[0, 0]
    body = np.any(np.abs(image - background) > 0.02, axis=-1)
    assert 0.05 < body.mean() < 0.95
    assert len(np.unique(np.round(image[body] * 255).astype(int), axis=0)) > 20


@pytest.mark.multirank  # the first to ask starts two_rank_run
@pytest.mark.parametrize("reader", ["XDMFReader", "Xdmf3ReaderS"])
def test_other_readers(two_rank_run, reader):
    """The legacy XDMF reader (which crashes on an https XInclude namespace) and Xdmf3ReaderS read the same."""
    report = probe(two_rank_run / "solution.xdmf", reader)
    (block,) = report["blocks"]
    check_block(block, h5_fields(two_rank_run))


@pytest.mark.multirank  # the first to ask starts two_rank_run
def test_one_rank_equals_two_ranks(two_rank_run, tmp_path):
    """The same scene on 1 rank writes the same mesh and fields, up to the vertex numbering."""
    one = tmp_path / "one"
    assert MPI.COMM_WORLD.size == 1
    assert main([*ARGS, "--out", str(one), "--quiet", "--no-plots"]) == 0
    a, b = h5_fields(one), h5_fields(two_rank_run)

    def canonical(d: dict[str, np.ndarray]) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
        key = np.round(d["x"], 9)
        order = np.lexsort(key.T[::-1])
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        cells = np.sort(rank[d["cells"]], axis=1)
        cells = cells[np.lexsort(cells.T[::-1])]
        return key[order], {name: d[name][order] for name in FIELDS}, cells

    xa, fa, ca = canonical(a)
    xb, fb, cb = canonical(b)
    assert np.array_equal(xa, xb) and np.array_equal(ca, cb)
    assert np.array_equal(fa["contact_state"], fb["contact_state"])
    for name in ("displacement", "contact_pressure", "tangential_force", "stress", "von_mises"):
        scale = np.abs(fa[name]).max()
        assert np.abs(fa[name] - fb[name]).max() <= 1e-6 * scale, name


def test_view_script_of_a_load_path_in_pvpython(tmp_path):
    """Each result set carries view.py (issue 26): `pvpython view.py` in the real ParaView opens the load path's
    solution.xdmf warped by the displacement, coloured by contact_state as categories labelled open/stick/slip,
    with the time slider over t = 0 and every solve, the camera on the contact side (the cylinder presses
    from above: it looks down)."""
    out = tmp_path / "path"
    scene = Path(__file__).resolve().parents[2] / "demos" / "scenes" / "cylinder_drag_path.toml"
    assert main(["--scene", str(scene), "--lev", "1", "--out", str(out), "--quiet", "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert "view.py" in summary["files"]
    shot = tmp_path / "view.png"
    with virtual_display():
        done = subprocess.run(["pvpython", "--force-offscreen-rendering", "view.py", "--screenshot", str(shot)],
                              cwd=out, env=clean_env(), capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    (line,) = [line for line in done.stdout.splitlines() if line.startswith("VIEW ")]
    report = json.loads(line[len("VIEW "):])
    assert set(FIELDS) <= set(report["arrays"]) and report["colored_by"] == ["POINTS", "contact_state"]
    assert report["categorical"] == 1
    assert dict(zip(report["annotations"][::2], report["annotations"][1::2])) == {
        "-1": "not a contact node", "0": "open", "1": "stick", "2": "slip"}
    times = [s["time"] for s in summary["steps"]]
    assert report["times"] == pytest.approx([0.0, *times])
    assert report["view"][2] > 0  # above the plate: the cylinder's side
    assert shot.stat().st_size > 10_000


def view_report(out: Path, shot: Path) -> dict:
    """`pvpython view.py --screenshot` in the result directory as a user runs it, without a display (the script
    starts its own Xvfb); its JSON report of the pipeline."""
    env = {k: v for k, v in clean_env().items() if k != "DISPLAY"}
    done = subprocess.run(["pvpython", "view.py", "--screenshot", str(shot)], cwd=out, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    (line,) = [line for line in done.stdout.splitlines() if line.startswith("VIEW ")]
    assert shot.stat().st_size > 10_000
    return json.loads(line[len("VIEW "):])


def test_view_script_shows_the_body_and_the_rolling_ball(tmp_path):
    """The rolling ball in the real ParaView, headless: the body and the ball are both in the pipeline and shown,
    with the same times; at the last time the ball's points in the pipeline are its rest points turned about its
    centre by the last step's angle and moved by its δ (scipy's rotation), not the first step's placement."""
    from scipy.spatial.transform import Rotation

    out = tmp_path / "rolling"
    scene = Path(__file__).resolve().parents[2] / "demos" / "scenes" / "ball_rolling_path.toml"
    assert main(["--scene", str(scene), "--lev", "2", "--out", str(out), "--quiet", "--no-plots"]) == 0
    steps = json.loads((out / "summary.json").read_text())["steps"]
    report = view_report(out, tmp_path / "rolling.png")
    assert report["sources"] == ["WarpByVector1", "obstacles.xdmf", "solution.xdmf"]
    assert report["scale"] == 1.0 and report["colored_by"] == ["POINTS", "contact_state"]
    ball = report["obstacles"]
    assert ball["visible"] == 1 and ball["times"] == report["times"] == [0.0, *(s["time"] for s in steps)]
    assert report["time"] == steps[-1]["time"] and set(ball["obstacle"]) == {1}
    points, rest = np.array(ball["points"]), np.array(ball["rest_position"])

    def placement(step: dict) -> np.ndarray:
        angle, axis, centre = step["obstacle_rotations"]["ball"]
        turn = Rotation.from_rotvec(np.radians(angle) * np.asarray(axis))
        return turn.apply(rest - centre) + centre + step["obstacle_displacements"]["ball"]

    assert np.abs(points - placement(steps[-1])).max() < 1e-12
    assert np.abs(points - placement(steps[-2])).max() > 0.1  # it moved and turned since
    centre = np.array([0.9, 0.5, 1.5]) + steps[-1]["obstacle_displacements"]["ball"]
    assert np.allclose(np.linalg.norm(points - centre, axis=1), 0.5, rtol=1e-12)
    # the same script in ParaView's window (paraview --script, from the result directory) runs to the end
    with virtual_display():
        done = subprocess.run(["paraview", "--script=view.py", "--exit"], cwd=out, env=clean_env(),
                              capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "Traceback" not in done.stdout + done.stderr, done.stderr[-3000:]


def test_view_script_shows_the_two_body_interface_by_state(tmp_path, capsys):
    """The two-body demo in the real ParaView: one part per body; the hemisphere (the slave side) coloured by
    contact_state with the run's open/stick/slip counts on its points, the block translucent and uncoloured. The
    command's force lines name the pair's sides; deformed.png (the master translucent) is written."""
    out = tmp_path / "two"
    scene = Path(__file__).resolve().parents[2] / "demos" / "scenes" / "two_bodies.toml"
    assert main(["--scene", str(scene), "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert "deformed.png" in summary["files"] and "contact_states.png" in summary["files"]
    assert "total contact force on the body" not in printed
    (pair,) = summary["contact_pairs"]
    slave, master = (", ".join(f"{c:.6g}" for c in pair[key])
                     for key in ("force_on_slave_body", "force_on_master_body"))
    assert f"pair 1: contact force on the slave side 'curved' ({slave}), on the master side 'block_top' ({master})" \
        in printed
    assert "reactions: block_bottom (" in printed
    report = view_report(out, tmp_path / "two.png")
    assert "obstacles" not in report and report["sources"] == ["WarpByVector1", "body 1", "body 2", "solution.xdmf"]
    block, hemisphere = report["bodies"]["1"], report["bodies"]["2"]
    assert hemisphere["colored_by"] == ["POINTS", "contact_state"] and hemisphere["opacity"] == 1.0
    assert block["colored_by"][1] == "" and block["opacity"] < 1.0 and block["state_range"] == [-1.0, -1.0]
    counts = summary["state_counts"]
    assert hemisphere["state_counts"] == {"-1": hemisphere["points"] - summary["p"], "0": counts["open"],
                                          "1": counts["stick"], "2": counts["slip"]}
    assert counts["stick"] > 0 and counts["slip"] > 0
    # the pair's own history entries: all of the contact nodes are its
    assert (pair["stick"], pair["slip"], pair["open"]) == (counts["stick"], counts["slip"], counts["open"])
    assert 0 < pair["tangential_force"] <= 0.3 * pair["normal_force"]
