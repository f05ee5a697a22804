"""Figures of a solve (matplotlib, no display needed): convergence history and contact states.

``convergence.png``  ‖ŷ⁽ᵏ⁾‖/‖ŷ⁽⁰⁾‖ against the Newton iteration (like the paper's Fig. 3);
``contact_states.png``  the contact nodes over the bottom (x1, x2), coloured as in the paper's Fig. 2:
no contact blue, sliding yellow, sticking red;
``deformed.png``  the deformed body (pyvista, off screen) with the contact nodes in the same categorical colours;
``contact_pressure.png``  the contact pressure (force per area) of the contact nodes seen along the mean contact
normal, zoomed onto the patch in contact.

``contact_state`` is categorical: the figures colour it with :data:`STATE_COLOURS` (one colour per state, never a
continuous map). User text (scene names) is shown literally: matplotlib's math text is not parsed in it. A
figure that cannot be drawn is a logged warning (:func:`write_figures`), never a lost result; a virtual X
server started for pyvista is stopped again (:func:`fenics_coulomb.io.display.virtual_display`).
"""

from __future__ import annotations

import logging
from pathlib import Path

from mpi4py import MPI

import numpy as np
import numpy.typing as npt

from fenics_coulomb.io.display import virtual_display
from fenics_coulomb.io.units import Units
from fenics_coulomb.scd.resolvent import OPEN, SLIP, STICK

__all__ = ["STATE_COLOURS", "contact_view", "plot_convergence", "gather_contact", "plot_contact_states",
           "plot_contact_pressure", "gather_deformed",
           "render_deformed", "write_figures", "plot_path", "write_path_figure"]

logger = logging.getLogger(__name__)

#: Categorical colours of the contact states (label, matplotlib colour), as in the paper's Fig. 2.
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
        ax.set_title(title, parse_math=False)
    if len(histories) > 1:
        for text in ax.legend().get_texts():
            text.set_parse_math(False)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def gather_contact(
    comm: MPI.Comm, coordinates: npt.NDArray[np.float64], states: npt.NDArray[np.int8]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]] | None:
    """Gather contact-node coordinates and states on rank 0 (None elsewhere)."""
    xs = comm.gather(coordinates, root=0)
    ss = comm.gather(states, root=0)
    if comm.rank != 0 or xs is None or ss is None:
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
    longest = max(float(extent.max()), np.finfo(float).tiny)
    # nodes on a line (one extent ~0) are drawn along it unscaled: their aspect made a 960 x 270 919 285 figure
    flat = float(extent.min()) < 1e-3 * longest
    aspect = 0.3 if flat else float(np.clip(extent[1] / extent[0], 0.05, 4.0))
    fig, ax = plt.subplots(figsize=(8, max(2.5, 8 * aspect) + 0.8))
    size = float(np.clip(20000.0 / max(states.size, 1), 2.0, 60.0))
    for state, (label, colour) in STATE_COLOURS.items():
        mask = states == state
        ax.scatter(coordinates[mask, 0], coordinates[mask, 1], s=size, c=colour, marker="s",
                   label=f"{label} ({int(mask.sum())})", edgecolors="none")
    if not flat:
        ax.set_aspect("equal")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3, frameon=False)
    if title:
        ax.set_title(title, parse_math=False)
    fig.savefig(path, dpi=120, bbox_inches="tight", pad_inches=0.2)  # the legend below the axes included
    plt.close(fig)


def plot_contact_pressure(
    coordinates: npt.NDArray[np.float64], pressure: npt.NDArray[np.float64], states: npt.NDArray[np.int8],
    path: Path, title: str = "", labels: tuple[str, str] = ("$x_1$", "$x_2$"), unit: str = "GPa",
) -> tuple[float, float, float, float]:
    """Draw the contact pressure of the contact nodes over their first two (projected) coordinates to ``path``,
    zoomed onto the nodes in contact (their box, widened by half its size and by the node spacing around it; the
    whole surface without contact): a pressure map seen along the contact normal, the open nodes hollow.

    Returns:
        The window shown (x₀, x₁, y₀, y₁), a square.
    """
    plt = _pyplot()
    xy = np.asarray(coordinates, dtype=np.float64)[:, :2]
    pressure = np.asarray(pressure, dtype=np.float64).reshape(-1)
    closed = (np.asarray(states) != OPEN) & (pressure > 0)
    inside = xy[closed] if closed.any() else xy
    lo, hi = inside.min(axis=0, initial=np.inf), inside.max(axis=0, initial=-np.inf)
    if not np.all(np.isfinite(hi - lo)):
        lo, hi = np.zeros(2), np.ones(2)
    spacing = 0.0
    if xy.shape[0] > 1:  # the median distance to the nearest node
        from scipy.spatial import cKDTree

        spacing = float(np.median(cKDTree(xy).query(xy, k=2)[0][:, 1]))
    pad = 0.5 * (hi - lo) + spacing
    lo, hi = lo - pad, hi + pad
    half = 0.5 * float(np.max(hi - lo))
    centre = 0.5 * (lo + hi)
    fig, ax = plt.subplots(figsize=(7, 6))
    near = np.all(np.abs(xy - centre) <= half * 1.05, axis=1)
    size = float(np.clip(2.0e4 / max(int(near.sum()), 1), 8.0, 200.0))
    ax.scatter(*xy[near & ~closed].T, s=size, facecolors="none", edgecolors="grey", linewidths=0.6,
               label="open or no pressure")
    shown = ax.scatter(*xy[closed].T, c=pressure[closed], s=size, cmap="viridis", marker="s", edgecolors="none")
    if closed.any():
        fig.colorbar(shown, ax=ax, label=f"contact pressure ({unit})")
        peak = int(np.argmax(np.where(closed, pressure, -np.inf)))
        ax.plot(*xy[peak], marker="+", color="red", ms=14, mew=2, ls="none",
                label=f"peak {pressure[peak]:.4g} {unit} ({int(closed.sum())} nodes in contact)")
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_aspect("equal")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    for text in ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, frameon=False).get_texts():
        text.set_parse_math(False)
    if title:
        ax.set_title(title, parse_math=False)
    fig.savefig(path, dpi=120, bbox_inches="tight", pad_inches=0.2)
    plt.close(fig)
    return (float(centre[0] - half), float(centre[0] + half), float(centre[1] - half), float(centre[1] + half))


def gather_deformed(
    V: object,
    displacement: npt.NDArray[np.float64],
    contact_coordinates: npt.NDArray[np.float64],
    contact_displacement: npt.NDArray[np.float64],
    states: npt.NDArray[np.int8],
    body: npt.NDArray[np.int64] | None = None,
) -> tuple[list, tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]]] | None:
    """Gather the VTK pieces of the displaced body (with ``body``, the body number of each local DOF block, as a
    fifth item) and the contact nodes on rank 0 (collective; None elsewhere)."""
    import dolfinx.fem
    import dolfinx.plot

    from fenics_coulomb.model.dof_values import set_owned_values

    comm: MPI.Comm = V.mesh.comm  # type: ignore[attr-defined]
    u = set_owned_values(dolfinx.fem.Function(V), displacement)
    topology, cell_types, x = dolfinx.plot.vtk_mesh(V)
    values = u.x.array.reshape(-1, 3)[: x.shape[0]]
    piece = (topology, cell_types, x, values) if body is None else (
        topology, cell_types, x, values, np.asarray(body, dtype=np.int64)[: x.shape[0]])
    parts = comm.gather(piece, root=0)
    contact = gather_contact(comm, np.hstack([contact_coordinates, contact_displacement]), states)
    if comm.rank != 0:
        return None
    assert parts is not None and contact is not None
    return parts, contact


def contact_view(normal: npt.ArrayLike | None) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The camera of deformed.png: (view vector from the focal point to the camera, view-up).

    The camera looks at the contact side of the body: along the contact normal n of the node with the largest
    contact force, from the obstacle's side (n points from the obstacle into the body, so the camera sits
    at −n), tilted by about 30° so that the body's depth shows. Without contact: from below and in front."""
    n = np.asarray(normal, dtype=np.float64) if normal is not None else np.array([0.0, 0.0, 1.0])
    length = float(np.linalg.norm(n))
    n = np.asarray(n / length if np.isfinite(length) and length > 0 else np.array([0.0, 0.0, 1.0]), dtype=np.float64)
    tilt = np.array([0.55, -1.0, 0.0])
    tilt = tilt - (tilt @ n) * n
    if np.linalg.norm(tilt) < 1e-6:
        tilt = np.array([1.0, 0.0, 0.0]) - n[0] * n
    view = -n + 0.6 * tilt / np.linalg.norm(tilt)
    up = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    return view / np.linalg.norm(view), up


def render_deformed(parts: list, contact: tuple[npt.NDArray[np.float64], npt.NDArray[np.int8]], path: Path,
                    title: str = "", normal: npt.ArrayLike | None = None, slaves: tuple[int, ...] = ()) -> None:
    """Render the pieces gathered by :func:`gather_deformed` to ``path`` (one process), seen from the contact
    side: :func:`contact_view` of ``normal`` (the contact normal of the node with the largest force). With the
    pieces' body numbers and the ``slaves`` (the bodies with contact nodes), the other bodies are drawn
    translucent: the camera, on the master side, sees the slave surface through them."""
    import pyvista

    pyvista.OFF_SCREEN = True
    grids = []
    for top, types, pts, vals, *body in parts:
        grid = pyvista.UnstructuredGrid(top, types, pts)
        grid.point_data["u"] = vals
        if body:
            grid.point_data["body"] = body[0]
        grids.append(grid)
    grid = grids[0].merge(grids[1:]) if len(grids) > 1 else grids[0]
    size = float(np.max(np.ptp(grid.points, axis=0)))
    umax = float(np.max(np.linalg.norm(grid.point_data["u"], axis=1), initial=0.0))
    factor = 0.1 * size / umax if umax > 0 else 1.0
    warped = grid.warp_by_vector("u", factor=factor)
    warped.point_data["|u|"] = np.linalg.norm(grid.point_data["u"], axis=1)
    with virtual_display():
        plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 800))
        try:
            others = np.zeros(warped.n_points, dtype=bool)
            if slaves and "body" in warped.point_data:
                others = ~np.isin(warped.point_data["body"], slaves)
            shown = warped.extract_points(~others, adjacent_cells=False) if others.any() else warped
            plotter.add_mesh(shown, scalars="|u|", cmap="viridis", show_edges=True, edge_color="grey",
                             line_width=0.5, scalar_bar_args={"title": "|displacement|"})
            if others.any():  # the master sides, translucent
                plotter.add_mesh(warped.extract_points(others, adjacent_cells=False), color="lightgrey",
                                 opacity=0.25, show_edges=False)
            data, st = contact
            if st.size:
                points = data[:, :3] + factor * data[:, 3:]
                for state, (label, colour) in STATE_COLOURS.items():
                    mask = st == state
                    if np.any(mask):
                        plotter.add_points(points[mask], color=colour, point_size=8,
                                           render_points_as_spheres=True, label=label)
                plotter.add_legend(bcolor="white", size=(0.15, 0.1), loc="lower left")
            if title:
                # VTK renders $...$ as math text: escape user text so it is shown literally
                plotter.add_title(f"{title} (displacement x{factor:.3g})".replace("$", "\\$"), font_size=10)
            view, up = contact_view(normal)
            plotter.view_vector(tuple(view), viewup=tuple(up))
            plotter.screenshot(str(path))
        finally:
            plotter.close()
            plotter.deep_clean()
            del plotter


def write_figures(directory: Path, model: object, result: object, label: str, units: Units | None = None) -> list[str]:
    """Write convergence.png, contact_states.png and deformed.png of a solve into ``directory`` (collective).

    The data are gathered on rank 0 by all ranks; each figure is then drawn on rank 0 alone and a figure that
    fails is a logged warning, not an error.

    Returns:
        The names of the figures written (the same list on every rank).
    """
    comm: MPI.Comm = model.V.mesh.comm  # type: ignore[attr-defined]
    contact = model.contact  # type: ignore[attr-defined]
    displacement = result.displacement  # type: ignore[attr-defined]
    from fenics_coulomb.io.view import contact_bodies

    bodies, slaves = contact_bodies(model)  # type: ignore[arg-type]
    deformed = gather_deformed(model.V, displacement, contact.coordinates,  # type: ignore[attr-defined]
                               displacement[contact.local_dofs], result.states,  # type: ignore[attr-defined]
                               np.asarray(model.body_of_block) + 1 if bodies else None)  # type: ignore[attr-defined]
    # the contact surface in its own projection: onto the plane ⊥ the mean contact normal (x1, x2 for the
    # paper's plane)
    from fenics_coulomb.model.frames import frames_from_normals, to_local

    normal = np.asarray(comm.allreduce(contact.normals.sum(axis=0), op=MPI.SUM))
    normal = normal / np.linalg.norm(normal) if np.linalg.norm(normal) > 0 else np.array([0.0, 0.0, 1.0])
    frame = frames_from_normals(normal)
    axes = ("$x_1$", "$x_2$") if np.allclose(frame[0], np.eye(3)) else ("$t_1$", "$t_2$")
    projected = to_local(np.broadcast_to(frame, (contact.size, 3, 3)), contact.coordinates)
    states = gather_contact(comm, projected, result.states)  # type: ignore[attr-defined]
    from fenics_coulomb.model.forces import contact_areas
    from fenics_coulomb.report import nodal_pressure

    pressure = nodal_pressure(result.normal_force, contact_areas(model))  # type: ignore[arg-type, attr-defined]
    pressures = gather_contact(comm, np.column_stack([projected[:, :2], pressure]), result.states)  # type: ignore
    # the camera's normal: that of the node with the largest contact force (on every rank, then rank 0 draws)
    from fenics_coulomb.io.view import largest_force_normal

    view_normal = largest_force_normal(model, result.contact_force)  # type: ignore[arg-type, attr-defined]
    written: list[str] = []
    if comm.rank == 0:
        assert deformed is not None and states is not None and pressures is not None
        jobs = [
            ("convergence.png", lambda p: plot_convergence({label: result.residual_history}, p,  # type: ignore
                                                           f"Convergence, {label}")),
            ("contact_states.png", lambda p: plot_contact_states(*states, p, f"Contact states, {label}", axes)),
            ("contact_pressure.png", lambda p: plot_contact_pressure(
                pressures[0][:, :2], pressures[0][:, 2], pressures[1], p, f"Contact pressure, {label}", axes,
                (units or Units()).stress)),
            ("deformed.png", lambda p: render_deformed(
                *deformed, p, f"Deformed bodies, {label} (master translucent)" if bodies else f"Deformed body, {label}",
                view_normal, tuple(slaves))),
        ]
        for name, draw in jobs:
            try:
                draw(directory / name)
                written.append(name)
            except Exception as err:  # a figure never costs the results
                logger.warning("fenics-coulomb: warning: %s not written (%s: %s)", name, type(err).__name__, err)
                (directory / name).unlink(missing_ok=True)
    return comm.bcast(written, root=0)


def plot_path(steps: list[dict], path: Path, title: str = "") -> None:
    """Force–displacement curves of a load path (``steps``: summary.json's "steps") to ``path``.

    When an obstacle moves, the total contact force component along each of its varying displacement
    components is drawn against that component (the tangential force against the tangential displacement
    traces a friction hysteresis loop); otherwise the contact force components against the path's time (the
    step number; the load factor for ``--steps``). Both start at the unloaded state 0. With the steps' "groups"
    a second row shows per obstacle and contact pair the normal and tangential force, the peak pressure and the
    stick/slip nodes against the step.
    """
    plt = _pyplot()
    # the obstacles' force on the body, or without obstacles the contact pairs' force on their slave bodies
    pairs_only = bool(steps) and not steps[0]["obstacle_displacements"] and bool(steps[0].get("pair_forces"))
    force = np.array([[0.0, 0.0, 0.0]] + [np.sum(s["pair_forces"], axis=0) if pairs_only else s["contact_force"]
                                          for s in steps])
    names = list(steps[0]["obstacle_displacements"]) if steps else []
    deltas = {n: np.array([[0.0, 0.0, 0.0]] + [s["obstacle_displacements"][n] for s in steps]) for n in names}
    ranges = {(n, c): float(np.ptp(d[:, c])) for n, d in deltas.items() for c in range(3)}
    moving = [key for key, r in ranges.items() if r > 0]
    marker = {"marker": "o", "ms": 3}
    groups = list(steps[0].get("groups", {})) if steps else []
    top = max(ranges.values(), default=0.0)
    moving = [key for key in moving if ranges[key] >= 1e-3 * top]
    columns = max(len(moving), 1, 3 if groups else 1)
    fig = plt.figure(figsize=(5.5 * columns, 4.5 * (2 if groups else 1)))
    rows = fig.subfigures(2, 1) if groups else [fig]
    if moving:
        axes = rows[0].subplots(1, len(moving), squeeze=False)
        for ax, (name, c) in zip(axes[0], moving, strict=True):
            ax.plot(deltas[name][:, c], force[:, c], **marker)
            ax.set_xlabel(f"displacement δ{c + 1} of obstacle {name} (L)")
            ax.set_ylabel(f"total contact force F{c + 1} on the body (GPa·L²)")
        ax = axes[0][0]
    else:
        ax = rows[0].subplots()
        ramp = all(s["substeps"] == 1 for s in steps) and all(
            abs(s["load_factor"] - s["time"] / steps[-1]["time"]) < 1e-12 for s in steps)
        x = np.array([0.0] + [s["load_factor"] if ramp else s["time"] for s in steps])
        for c in range(3):
            ax.plot(x, force[:, c], label=f"F{c + 1}", **marker)
        ax.set_xlabel("load factor" if ramp else "step")
        ax.set_ylabel("contact pairs' force on their slave bodies (GPa·L²)" if pairs_only
                      else "total contact force on the body (GPa·L²)")
    if groups:  # per obstacle and contact pair against the path's time
        t = np.array([0.0] + [s["time"] for s in steps])

        def history(name: str, key: str) -> npt.NDArray[np.float64]:
            return np.array([0.0] + [float(s["groups"][name][key]) for s in steps])

        forces, peaks, states = rows[1].subplots(1, 3)
        for name in groups:
            line, = forces.plot(t, history(name, "normal_force"), label=f"{name}: normal", **marker)
            forces.plot(t, history(name, "tangential_force"), ls="--", color=line.get_color(),
                        label=f"{name}: tangential", **marker)
            peaks.plot(t, history(name, "peak_pressure"), label=name, **marker)
            line, = states.plot(t, history(name, "stick"), label=f"{name}: stick", **marker)
            states.plot(t, history(name, "slip"), ls="--", color=line.get_color(), label=f"{name}: slip", **marker)
        forces.set_ylabel("contact force per obstacle / pair (GPa·L²)")
        peaks.set_ylabel("peak contact pressure (GPa)")
        states.set_ylabel("nodes")
        for axis in (forces, peaks, states):
            axis.set_xlabel("step")
            for text in axis.legend(fontsize=7).get_texts():
                text.set_parse_math(False)
    for axis in fig.axes:
        axis.grid(True, alpha=0.3)
    if not steps[-1]["converged"]:
        ax.plot([], [], " ", label=f"last point NOT converged (t = {steps[-1]['time']:g})")
    if ax.get_legend_handles_labels()[0]:
        for text in ax.legend(fontsize=8).get_texts():
            text.set_parse_math(False)
    if title:
        fig.suptitle(title, parse_math=False)
    if not groups:
        fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_path_figure(directory: Path, steps: list[dict], label: str, comm: MPI.Comm) -> list[str]:
    """Draw path.png on rank 0 (a failure is a logged warning); return ["path.png"] or [] on every rank."""
    written: list[str] = []
    if comm.rank == 0 and steps:
        try:
            plot_path(steps, directory / "path.png", f"Load path, {label}")
            written.append("path.png")
        except Exception as err:  # a figure never costs the results
            logger.warning("fenics-coulomb: warning: path.png not written (%s: %s)", type(err).__name__, err)
            (directory / "path.png").unlink(missing_ok=True)
    return comm.bcast(written, root=0)
