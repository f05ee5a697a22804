"""Figures of a solve (matplotlib, no display needed): convergence history and contact states.

``convergence.png``  ‖ŷ⁽ᵏ⁾‖/‖ŷ⁽⁰⁾‖ against the Newton iteration (like the paper's Fig. 3);
``contact_states.png``  the contact nodes over the bottom (x1, x2), coloured as in the paper's Fig. 2:
no contact blue, sliding yellow, sticking red.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.resolvent import OPEN, SLIP, STICK

STATE_COLOURS = {OPEN: ("no contact", "tab:blue"), SLIP: ("sliding", "gold"), STICK: ("sticking", "tab:red")}


def _pyplot():  # type: ignore[no-untyped-def]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_convergence(histories: dict[str, list[float]], path: Path, title: str = "") -> None:
    """Plot relative residual histories (one curve per label) to ``path``."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    for label, history in histories.items():
        h = np.asarray(history)
        ax.semilogy(np.arange(h.size), h / h[0], marker="o", ms=3, label=label)
    ax.set_xlabel("Newton iteration k")
    ax.set_ylabel(r"$\|\hat y^{(k)}\| / \|\hat y^{(0)}\|$")
    ax.grid(True, which="both", alpha=0.3)
    if title:
        ax.set_title(title)
    if len(histories) > 1:
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def gather_contact(
    comm: MPI.Comm, coordinates: npt.NDArray[np.float64], states: npt.NDArray[np.int8]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]] | None:
    """Gather contact-node coordinates and states on rank 0 (None elsewhere)."""
    xs = comm.gather(coordinates, root=0)
    ss = comm.gather(states, root=0)
    if comm.rank != 0:
        return None
    return np.concatenate(xs), np.concatenate(ss)


def plot_contact_states(
    coordinates: npt.NDArray[np.float64], states: npt.NDArray[np.int8], path: Path, title: str = "",
    labels: tuple[str, str] = ("$x_1$", "$x_2$"),
) -> None:
    """Scatter the contact nodes over their first two coordinates (x1, x2, or a projection's axes named by
    ``labels``) coloured by state to ``path``."""
    plt = _pyplot()
    extent = np.ptp(coordinates[:, :2], axis=0) if coordinates.size else np.ones(2)
    aspect = extent[1] / max(extent[0], 1e-12)
    fig, ax = plt.subplots(figsize=(8, max(2.5, 8 * aspect) + 0.8))
    size = float(np.clip(20000.0 / max(states.size, 1), 2.0, 60.0))
    for state, (label, colour) in STATE_COLOURS.items():
        mask = states == state
        ax.scatter(coordinates[mask, 0], coordinates[mask, 1], s=size, c=colour, marker="s",
                   label=f"{label} ({int(mask.sum())})", edgecolors="none")
    ax.set_aspect("equal")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=3, frameon=False)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_deformed(
    V: object,
    displacement: npt.NDArray[np.float64],
    contact_coordinates: npt.NDArray[np.float64],
    contact_displacement: npt.NDArray[np.float64],
    states: npt.NDArray[np.int8],
    path: Path,
    title: str = "",
) -> None:
    """Render the deformed body (pyvista, off screen) coloured by |ũ|, with the contact nodes coloured
    by state, to ``path`` (collective: every rank sends its part to rank 0).

    The displacement is magnified so that the largest one is 10 % of the body's size.
    """
    import dolfinx.fem
    import dolfinx.plot

    comm: MPI.Comm = V.mesh.comm  # type: ignore[attr-defined]
    u = dolfinx.fem.Function(V)
    u.x.petsc_vec.array[:] = displacement
    u.x.scatter_forward()
    topology, cell_types, x = dolfinx.plot.vtk_mesh(V)
    values = u.x.array.reshape(-1, 3)[: x.shape[0]]
    parts = comm.gather((topology, cell_types, x, values), root=0)
    contact = gather_contact(comm, np.hstack([contact_coordinates, contact_displacement]), states)
    if comm.rank != 0:
        return
    import os

    import pyvista

    pyvista.OFF_SCREEN = True
    if not os.environ.get("DISPLAY"):
        try:
            pyvista.start_xvfb(wait=0.3)
        except Exception:  # no Xvfb: VTK may still render off screen (EGL/OSMesa builds)
            pass
    grids = []
    for top, types, pts, vals in parts:
        grid = pyvista.UnstructuredGrid(top, types, pts)
        grid.point_data["u"] = vals
        grids.append(grid)
    grid = grids[0].merge(grids[1:]) if len(grids) > 1 else grids[0]
    size = float(np.max(np.ptp(grid.points, axis=0)))
    umax = float(np.max(np.linalg.norm(grid.point_data["u"], axis=1), initial=0.0))
    factor = 0.1 * size / umax if umax > 0 else 1.0
    warped = grid.warp_by_vector("u", factor=factor)
    warped.point_data["|u|"] = np.linalg.norm(grid.point_data["u"], axis=1)
    plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 800))
    plotter.add_mesh(warped, scalars="|u|", cmap="viridis", show_edges=True, edge_color="grey",
                     line_width=0.5, scalar_bar_args={"title": "|displacement|"})
    assert contact is not None
    data, st = contact
    if st.size:
        points = data[:, :3] + factor * data[:, 3:]
        for state, (label, colour) in STATE_COLOURS.items():
            mask = st == state
            if np.any(mask):
                plotter.add_points(points[mask], color=colour, point_size=8, render_points_as_spheres=True,
                                   label=label)
        plotter.add_legend(bcolor="white", size=(0.15, 0.1), loc="upper left")
    if title:
        plotter.add_title(f"{title} (displacement x{factor:.3g})", font_size=10)
    # from below and in front, so that the contact boundary is seen
    plotter.view_vector((0.55, -1.0, -0.75), viewup=(0.0, 0.0, 1.0))
    plotter.screenshot(str(path))
    plotter.close()
