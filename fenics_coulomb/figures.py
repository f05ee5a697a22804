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
    coordinates: npt.NDArray[np.float64], states: npt.NDArray[np.int8], path: Path, title: str = ""
) -> None:
    """Scatter the contact nodes over (x1, x2) coloured by state to ``path``."""
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
    ax.set_xlabel("$x_1$")
    ax.set_ylabel("$x_2$")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=3, frameon=False)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
