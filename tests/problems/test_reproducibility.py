"""Reproducible parallel runs: the same command on the same ranks gives the same bits (issue 17).

Each case runs the real command (``mpirun -n R python3 -m fenics_coulomb ... --no-plots``, oversubscribed,
from a directory outside the repository) twice on 2 ranks, on 3 ranks (twice for the gmsh body, whose distributed
read orders its cells by rank) and once on 1 rank, at rtol 1e-12:

* same ranks: identical summary.json histories and counts, solution.h5/.xdmf byte for byte identical;
* 1 vs 2 vs 3 ranks: the displacements, matched by vertex coordinates, agree to 1e-8 (relative).

The cases: the cuboid with ILU (block Jacobi) and with GAMG, and a gmsh body (a coarse roller mesh made with
meshes/roller.py, read in parallel through the scene file).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
RTOL = "1e-12"

pytestmark = [pytest.mark.serial, pytest.mark.multirank]  # starts its own mpirun jobs


def run_cli(args: list[str], ranks: int, out: Path) -> Path:
    """Run the CLI on ``ranks`` ranks (oversubscribed) from outside the repository; return the output dir."""
    cmd = ["mpirun", "--oversubscribe", "-n", str(ranks), sys.executable, "-m", "fenics_coulomb", *args,
           "--rtol", RTOL, "--out", str(out), "--no-plots", "--quiet"]
    proc = subprocess.run(cmd, cwd=out.parent, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def datasets(path: Path) -> dict[str, np.ndarray]:
    """Every dataset of an HDF5 file by its path."""
    found: dict[str, np.ndarray] = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: found.__setitem__(name, obj[...]) if isinstance(obj, h5py.Dataset)
                     else None)
    return found


def point_data(path: Path, field: str = "displacement") -> tuple[np.ndarray, np.ndarray]:
    """(vertex coordinates, values) of the point field ``field`` in solution.h5, in a canonical vertex order
    (lexicographic in the coordinates), robust to where the writer puts the geometry and the field: the
    geometry is the dataset whose path ends in 'geometry' with as many rows as the field's last time."""
    data = datasets(path)
    fields = sorted(name for name in data if field in name.lower())
    assert fields, f"no {field} dataset in {path}: {sorted(data)}"
    values = data[fields[-1]].reshape(data[fields[-1]].shape[0], -1)
    geometry = [name for name in data if name.lower().endswith("geometry") and data[name].shape[0] == len(values)]
    assert geometry, f"no geometry matching {fields[-1]} in {path}: {sorted(data)}"
    x = data[sorted(geometry)[-1]]
    order = np.lexsort(np.round(x, 10).T[::-1])
    return x[order], values[order]


def roller_scene(tmp: Path) -> list[str]:
    """A coarse roller mesh (gmsh, tetrahedra) and demos/scenes/roller.toml pointing at it."""
    msh = tmp / "roller.msh"
    proc = subprocess.run([sys.executable, str(ROOT / "meshes" / "roller.py"), "--size", "0.2", "--out", str(msh)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    text = (ROOT / "demos" / "scenes" / "roller.toml").read_text()
    scene = tmp / "roller.toml"
    scene.write_text(text.replace('"../../meshes/roller.msh"', json.dumps(str(msh))))
    return ["--scene", str(scene)]


CASES = {
    "cuboid-ilu": ["--lev", "3", "--gap", "d2", "--load", "L1", "--pc", "ilu"],
    "cuboid-gamg": ["--lev", "3", "--gap", "d3", "--load", "L2", "--pc", "gamg"],
    "gmsh-roller": None,  # made in the test
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_same_ranks_same_bits(case: str, tmp_path: Path) -> None:
    args = CASES[case] if CASES[case] is not None else roller_scene(tmp_path)
    outputs: dict[int, list[Path]] = {}
    reruns = (2, 3) if case == "gmsh-roller" else (2,)
    for ranks in (1, 2, 3):
        outputs[ranks] = [run_cli(args, ranks, tmp_path / f"n{ranks}-{k}") for k in range(2 if ranks in reruns else 1)]

    for ranks in reruns:
        first, second = outputs[ranks]
        s1 = json.loads((first / "summary.json").read_text())
        s2 = json.loads((second / "summary.json").read_text())
        assert s1["converged"] and s1["ranks"] == ranks
        for key in ("newton_iterations", "krylov_iterations", "residual_history", "krylov_history",
                    "step_lengths", "forcing_history", "state_counts", "gamma"):
            assert s1[key] == s2[key], f"{case}, {ranks} ranks: {key} differs between two runs"
        d1, d2 = datasets(first / "solution.h5"), datasets(second / "solution.h5")
        assert sorted(d1) == sorted(d2)
        for name in d1:
            assert d1[name].dtype == d2[name].dtype and d1[name].tobytes() == d2[name].tobytes(), \
                f"{case}, {ranks} ranks: dataset {name} differs between two runs"
        assert (first / "convergence.csv").read_bytes() == (second / "convergence.csv").read_bytes()
        for name in ("solution.h5", "solution.xdmf"):  # the files themselves, byte for byte (no timestamps)
            assert (first / name).read_bytes() == (second / name).read_bytes(), f"{case}, {ranks} ranks: {name}"

    # Different rank counts: different partitions, so equal only to the solver's accuracy.
    x1, u1 = point_data(outputs[1][0] / "solution.h5")
    scale = np.abs(u1).max()
    assert scale > 0.0
    for ranks in (2, 3):
        x, u = point_data(outputs[ranks][0] / "solution.h5")
        assert x.shape == x1.shape and np.allclose(x, x1, rtol=0.0, atol=1e-12)
        assert np.abs(u - u1).max() <= 1e-8 * scale, f"{case}: 1 vs {ranks} ranks differ"
