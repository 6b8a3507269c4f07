"""Angular displacement plots of A and C along a path, before and after smoothing.

The papers' Figs. 12-13 (seed 001; "velocity curves" in seed 000): the increment of
each rotary axis between consecutive points along the tool path, in degrees. A
reverse movement is a zero crossing of this curve. PNG files, matplotlib Agg,
written atomically and without a timestamp (same input, same bytes).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from impeller_cam.atomic import write_bytes_atomic

__all__ = ["plot_angular_displacement"]


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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(7.0, 5.0), sharex=True)
    index = np.arange(1, len(before))
    for row, (column, name) in enumerate(((3, "A"), (4, "C"))):
        ax = axes[row]
        ax.plot(index, np.degrees(np.diff(before[:, column])), color="tab:red", lw=1.0,
                label="before (initial postures)")
        ax.plot(index, np.degrees(np.diff(after[:, column])), color="tab:blue", lw=1.2,
                label="after (smoothed, remedied)")
        ax.axhline(0.0, color="black", lw=0.6)
        ax.set_ylabel(f"{name} displacement (deg)")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[0].set_title(title, fontsize=10)
    axes[1].set_xlabel("tool path point")
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    return write_bytes_atomic(path, buffer.getvalue())
