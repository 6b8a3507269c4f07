"""Figures of the positioning-time search (seed 000, Figs. 9 and 10), matplotlib Agg.

* ``plot_time_vs_s``: positioning time against the S factor at fixed Amaxu, Amaxd,
  Vmax (the paper's Fig. 9 uses all maxima; it normalises both axes to [0, 1], we
  plot seconds against S and give the normalised scale on the top/right axes).
* ``plot_time_over_av``: for symmetric inputs (Amaxu = |Amaxd| = A), the shortest
  positioning time over S at each (A, Vmax) (the paper's Fig. 10 surface, drawn as a
  filled contour map with the optimum marked).
* ``plot_contour_map``: the predicted contour error of the finishing programs on the
  blade, per NC block in the meridional plane (issue 26).

PNG files are written atomically.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.motion.optimise import OptimisationResult
from impeller_cam.atomic import write_bytes_atomic


def _save(fig: object, path: str | Path) -> Path:
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120, metadata={"Software": None})  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return write_bytes_atomic(path, buffer.getvalue())


def plot_time_vs_s(result: OptimisationResult, path: str | Path) -> Path:
    """Fig. 9: positioning time vs S at the grid's maxima of Amaxu, |Amaxd|, Vmax."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grid = result.grid
    times = result.times[:, -1, -1, -1]
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(grid.s_factor, times, "o-", ms=3)
    ax.set_xlabel("S factor")
    ax.set_ylabel("positioning time, s")
    ax.set_title(
        f"Amaxu = {grid.amax_up[-1]:.0f}, |Amaxd| = {grid.amax_down[-1]:.0f} mm/s$^2$, "
        f"Vmax = {grid.vmax[-1]:.0f} mm/s, stroke {result.stroke:g} mm", fontsize=9)
    ax.grid(True, alpha=0.3)
    lo, hi = float(np.min(times)), float(np.max(times))
    if hi > lo:
        s0 = float(grid.s_factor[0])
        s_span = max(float(np.ptp(grid.s_factor)), 1e-12)

        def to_unit_s(s: Any) -> Any:
            return (np.asarray(s) - s0) / s_span

        def from_unit_s(u: Any) -> Any:
            return s0 + np.asarray(u) * s_span

        def to_unit_t(t: Any) -> Any:
            return (np.asarray(t) - lo) / (hi - lo)

        def from_unit_t(u: Any) -> Any:
            return lo + np.asarray(u) * (hi - lo)

        top = ax.secondary_xaxis("top", functions=(to_unit_s, from_unit_s))
        top.set_xlabel("normalised S", fontsize=8)
        right = ax.secondary_yaxis("right", functions=(to_unit_t, from_unit_t))
        right.set_ylabel("normalised time", fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def plot_time_over_av(result: OptimisationResult, path: str | Path) -> Path:
    """Fig. 10: shortest positioning time over S for symmetric inputs, over (A, V)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grid = result.grid
    common, iu, idn = np.intersect1d(grid.amax_up, grid.amax_down, return_indices=True)
    surface = result.times[:, iu, idn, :].min(axis=0)  # (na, nv)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    if len(common) > 1 and len(grid.vmax) > 1:
        filled = ax.contourf(common, grid.vmax, surface.T, levels=20, cmap="viridis")
        fig.colorbar(filled, ax=ax, label="positioning time, s")
    else:
        ax.scatter(np.repeat(common, len(grid.vmax)), np.tile(grid.vmax, len(common)),
                   c=surface.ravel(), cmap="viridis")
    best = result.best_symmetric
    ax.plot([best.amax_up], [best.vmax], "r*", ms=12,
            label=f"best symmetric {best.positioning_time:.4f} s (S = {best.s_factor:g})")
    ax.set_xlabel("Amaxu = |Amaxd|, mm/s$^2$")
    ax.set_ylabel("Vmax, mm/s")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def plot_contour_map(
    tips: list[NDArray[np.float64]], errors: list[NDArray[np.float64]],
    tuned: list[NDArray[np.float64]] | None, hub: NDArray[np.float64],
    shroud: NDArray[np.float64], path: str | Path, title: str,
    quantity: str = "contour error",
) -> Path:
    """Contour error on the blade: feed blocks' tips in the meridional plane (r, z).

    Parameters
    ----------
    tips : list of (n_i, 3) float64
        Commanded tool tip of each feed block in the workpiece frame, mm (z the
        impeller axis), one array per program.
    errors, tuned : list of (n_i,) float64
        Contour error per block with the machine's K_FFP and with the Best K_FFP, mm.
    hub, shroud : (m, 2) float64
        Meridional contours ``(z, r)``, mm, drawn for orientation.
    quantity : str
        What the colour shows (the colour bar's label).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("machine K_FFP", errors)] + ([("Best K_FFP", tuned)] if tuned else [])
    tip = np.concatenate(tips)
    r, z = np.hypot(tip[:, 0], tip[:, 1]), tip[:, 2]
    top = max(float(np.percentile(1000.0 * np.concatenate(errors), 99)), 1e-3)
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.4),
                             squeeze=False, sharey=True)
    for ax, (label, values) in zip(axes[0], panels, strict=True):
        micron = 1000.0 * np.concatenate(values)
        order = np.argsort(micron)  # the largest errors drawn last, on top
        dots = ax.scatter(r[order], z[order], c=micron[order], s=2, cmap="viridis",
                          vmin=0.0, vmax=top)
        for contour, name in ((hub, "hub"), (shroud, "shroud")):
            ax.plot(contour[:, 1], contour[:, 0], "k-", lw=0.8, label=name)
        ax.set_xlabel("radius r, mm")
        ax.set_title(f"{label}: max {micron.max():.1f} um")
        ax.set_aspect("equal", adjustable="datalim")
        fig.colorbar(dots, ax=ax, label=f"{quantity}, um (scale: 99th pct of machine)")
    axes[0][0].set_ylabel("axial z, mm")
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


def plot_circle_sweep(points: list[Any], path: str | Path) -> Path:
    """Fig. 26's comparison: half-amplitude shape error vs omega, machine vs Best K_FFP.

    Parameters
    ----------
    points : list of synchronisation.CirclePoint
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for inertia in sorted({p.total_inertia for p in points}):
        row = [p for p in points if p.total_inertia == inertia]
        w = [p.omega / np.pi for p in row]
        ax.plot(w, [1000.0 * p.machine_amplitude for p in row], "o-",
                label=f"machine K_FFP, J+J1 = {inertia:.1f}")
        ax.plot(w, [1000.0 * p.best_amplitude for p in row], "s--",
                label=f"Best K_FFP, J+J1 = {inertia:.1f}")
    ax.set_yscale("log")
    ax.set_xlabel("omega / pi (rad/s)")
    ax.set_ylabel("half-amplitude of the shape error, um")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)
