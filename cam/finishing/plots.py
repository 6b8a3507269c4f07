"""Angular displacement plots of A and C along a path, before and after smoothing.

The papers' Figs. 12-13 (seed 001; "velocity curves" in seed 000): the increment of
each rotary axis between consecutive points along the tool path, in degrees. A
reverse movement is a zero crossing of this curve. PNG files, matplotlib Agg,
written atomically and without a timestamp (same input, same bytes).

A run writes one plot per path of passage 0 (about a hundred on nine_blade), so
``plot_angular_displacements`` shares them out over forked processes
(``impeller_cam.processes``), and each process draws its share on one figure,
replacing the curves' data between files (a new figure per file cost about a fifth
more). Every plot has the same fixed layout (``LAYOUT``), so a file's bytes do not
depend on which plots were drawn before it.
"""

from __future__ import annotations

import io
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from impeller_cam.atomic import write_bytes_atomic

__all__ = ["PER_SHARE", "plot_angular_displacement", "plot_angular_displacements"]

#: Plots a forked process draws at least (a fork costs about as much as a few plots).
PER_SHARE = 8
#: The axes' place in the figure (fractions of its width and height), the same for
#: every plot, so a file's bytes do not depend on the plot drawn before it.
LAYOUT = {"left": 0.14, "right": 0.98, "bottom": 0.09, "top": 0.94, "hspace": 0.1}

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


def plot_angular_displacements(plots: Iterable[Plot], workers: int | None = None
                               ) -> list[Path]:
    """Write several paths' plots (``plot_angular_displacement``), each share of them on
    one figure, the shares on forked processes.

    Parameters
    ----------
    plots : iterable of (before, after, path, title)
        As ``plot_angular_displacement``'s arguments: joints ``(n, 5)`` (X Y Z mm,
        A C rad) of the initial and final postures, the PNG file, the title.
    workers : int, optional
        Processes at most (``impeller_cam.processes.map_forked``; default: the CPUs);
        a file's bytes do not depend on which figure drew it.

    Returns
    -------
    list of Path
        The files written, in order.
    """
    from impeller_cam.processes import map_forked
    from impeller_cam.threads import default_threads

    todo = list(plots)
    count = max(1, min(len(todo) // PER_SHARE,
                       default_threads() if workers is None else int(workers)))
    shares = [todo[k::count] for k in range(count)]
    drawn = map_forked(lambda k: _draw(shares[k]), count, count)
    written: list[Path] = [Path()] * len(todo)
    for k, files in enumerate(drawn):
        written[k::count] = files
    return written


def _draw(plots: list[Plot]) -> list[Path]:
    """``plot_angular_displacements`` on one figure, in this process."""
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
    # fixed margins (room for tick labels of up to about six characters): measuring
    # the text of every plot (``tight_layout``) cost more than a third of its drawing
    fig.subplots_adjust(**LAYOUT)
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
            buffer = io.BytesIO()
            fig.savefig(buffer, format="png", dpi=100, metadata={"Software": None})
            written.append(write_bytes_atomic(path, buffer.getvalue()))
    finally:
        plt.close(fig)
    return written
