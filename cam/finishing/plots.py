"""Angular displacement plots of A and C along a path, before and after smoothing.

The papers' Figs. 12-13 (seed 001; "velocity curves" in seed 000): the increment of
each rotary axis between consecutive points along the tool path, in degrees. A
reverse movement is a zero crossing of this curve. PNG files, matplotlib Agg,
written atomically and without a timestamp (same input, same bytes).

A run writes one plot per path of passage 0 (about a hundred on nine_blade), so
``plot_angular_displacements`` draws them all on one figure, replacing the curves'
data between files (a new figure per file cost about a fifth more).
"""

from __future__ import annotations

import io
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from impeller_cam.atomic import write_bytes_atomic

__all__ = ["plot_angular_displacement", "plot_angular_displacements"]

Plot = tuple[NDArray[np.float64], NDArray[np.float64], "str | Path", str]


def plot_angular_displacement(before: NDArray[np.float64], after: NDArray[np.float64],
                              path: str | Path, title: str) -> Path:
    """Write the A and C angular displacement curves of one path.

    Parameters
    ----------
    before, after : (n, 5) float64
        Joints (X Y Z mm, A C rad) of the initial and the final postures.
    path : str or Path
        PNG file to write.
    title : str
        Figure title (the path name).
    """
    return plot_angular_displacements([(before, after, path, title)])[0]


def plot_angular_displacements(plots: Iterable[Plot]) -> list[Path]:
    """Write several paths' plots (``plot_angular_displacement``) on one figure.

    Parameters
    ----------
    plots : iterable of (before, after, path, title)
        As ``plot_angular_displacement``'s arguments: joints ``(n, 5)`` (X Y Z mm,
        A C rad) of the initial and final postures, the PNG file, the title.

    Returns
    -------
    list of Path
        The files written, in order.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(7.0, 5.0), sharex=True)
    lines = []
    for row, name in enumerate(("A", "C")):
        ax = axes[row]
        red, = ax.plot([], [], color="tab:red", lw=1.0, label="before (initial postures)")
        blue, = ax.plot([], [], color="tab:blue", lw=1.2, label="after (smoothed, remedied)")
        lines.append((red, blue))
        ax.axhline(0.0, color="black", lw=0.6)
        ax.set_ylabel(f"{name} displacement (deg)")
        ax.grid(alpha=0.3)
    axes[1].set_xlabel("tool path point")
    written = []
    try:
        for before, after, path, title in plots:
            index = np.arange(1, len(before))
            for (red, blue), column, ax in zip(lines, (3, 4), axes, strict=True):
                red.set_data(index, np.degrees(np.diff(before[:, column])))
                blue.set_data(index, np.degrees(np.diff(after[:, column])))
                ax.relim()
                ax.autoscale_view()
            axes[0].legend(loc="best", fontsize=8)
            axes[0].set_title(title, fontsize=10)
            fig.tight_layout()
            buffer = io.BytesIO()
            fig.savefig(buffer, format="png", dpi=100, metadata={"Software": None})
            written.append(write_bytes_atomic(path, buffer.getvalue()))
    finally:
        plt.close(fig)
    return written
