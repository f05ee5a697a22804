"""The surface obstacles' closest-point search (:func:`fenics_coulomb.model.surface.closest_on_surface`) gives the
numbers of the pairing's search (:func:`fenics_coulomb.model.pairs.projection.project`, whose candidate bound goes
through every triangle's centroid radius) on random points and on the hard places: near and exactly on vertices
and edges, on a prism's axis (equidistant from all its sides: every side tied) and at a cap's centre (the fan's
vertex, shared by every cap triangle), so the tie rule, the normal cone and the point-obstacle fallback beside
open edges all run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fenics_coulomb.model import surface as surface_module
from fenics_coulomb.model.pairs.projection import project as _pair_nodes
from fenics_coulomb.model.surface import _box_candidates, closest_on_surface, surface_index
from fenics_coulomb.model.triangulation import file_source

ROOT = Path(__file__).resolve().parents[2]
from meshes.surfaces import icosphere, rectangle, write_stl  # noqa: E402

pytestmark = pytest.mark.serial


def hard_points(T: np.ndarray, rng: np.random.Generator, scale: float) -> np.ndarray:
    """Random points in the surface's widened box, and points near and exactly on its vertices and edge midpoints."""
    P = T.reshape(-1, 3)
    lo, hi = P.min(axis=0), P.max(axis=0)
    box = rng.uniform(lo - 0.3 * (hi - lo), hi + 0.3 * (hi - lo), size=(300, 3))
    vertices = P[rng.choice(P.shape[0], 60)]
    edges = 0.5 * (T[:, 0] + T[:, 1])[rng.choice(T.shape[0], 60)]
    near = np.concatenate([vertices, edges]) + rng.normal(scale=1e-3 * scale, size=(120, 3))
    return np.concatenate([box, vertices, edges, near])


def compare(path: Path, x: np.ndarray, side: str = "outward") -> None:
    """Assert that the two searches agree on every output."""
    index = surface_index(str(path), file_source(str(path)), side)
    new = closest_on_surface(x, index)
    old = _pair_nodes(x, index.surface, index.size, index.rank)
    assert np.array_equal(new["facet"], old["facet"])
    assert np.array_equal(new["paired"], old["paired"])
    for key in ("closest", "weights", "normal"):
        assert np.max(np.abs(new[key] - old[key]), initial=0.0) <= 1e-14, key


def test_the_prism_roller(monkeypatch):
    """The demo's 360-sided STL roller (long thin side triangles, fans on the caps), its axis and cap centres."""
    path = ROOT / "meshes" / "roller.stl"
    index = surface_index(str(path), file_source(str(path)), "outward")
    T = index.surface.X
    rng = np.random.default_rng(5)
    axis = np.stack([np.full(40, 0.6), np.linspace(-0.5, 1.5, 40), np.full(40, 1.5)], axis=1)  # every side tied
    caps = np.array([[0.6, -0.25, 1.5], [0.6, 1.25, 1.5], [0.6, -0.3, 1.5], [0.6, 1.3, 1.5]])
    x = np.concatenate([hard_points(T, rng, 0.5), axis, caps])
    compare(path, x)
    compare(path, x, "inward")
    monkeypatch.setattr(surface_module, "SEARCH_ENTRIES", 500)  # blocks halved down to single points
    compare(path, x)
    # a point 0.5 below the roller: its centroid bound reaches every side triangle (they are 1.5 long), its boxes
    # only the few beneath it
    below = np.array([[0.6, 0.5, 0.5]])
    point, _ = _box_candidates(below, np.array([0.5 + 1e-9]), index)
    assert 0 < point.size <= 8


@pytest.mark.parametrize("shape", ["ball", "sheet"])
def test_closed_and_open_surfaces(tmp_path, shape):
    """A closed icosphere and an open, finely split rectangle (points beside its outer edges are not paired)."""
    T = icosphere(0.5, (1.0, 0.5, 1.5), level=2) if shape == "ball" else rectangle((0.0, 0.0), (1.0, 0.5), 0.2, n=6)
    path = write_stl(tmp_path / f"{shape}.stl", T)
    rng = np.random.default_rng(11)
    x = hard_points(T, rng, 0.5)
    compare(path, x)
    if shape == "sheet":
        index = surface_index(str(path), file_source(str(path)), "outward")
        beside = closest_on_surface(np.array([[1.5, 0.25, 0.2], [0.5, 0.25, 0.5]]), index)
        assert not beside["paired"][0] and beside["paired"][1]
