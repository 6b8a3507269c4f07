"""A small synthetic impeller spec written from closed-form curves, for core tests.

Hub contour: quarter ellipse centred at (z, r) = (40, 40), from the nose (40, 12) to
the rim (8, 40). Shroud: quarter ellipse centred at (52, 40), from (52, 30) to (14, 40).
Camber lines lie exactly on these contours; theta follows a wrap law.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HUB_CENTRE = (40.0, 40.0)
HUB_AXES = (32.0, 28.0)  # z, r semi-axes
SHROUD_CENTRE = (52.0, 40.0)
SHROUD_AXES = (38.0, 10.0)


def ellipse(centre: tuple[float, float], axes: tuple[float, float], t: np.ndarray) -> np.ndarray:
    """(z, r) points of the quarter ellipse at parameter ``t`` in [0, pi/2]."""
    return np.column_stack([centre[0] - axes[0] * np.sin(t), centre[1] - axes[1] * np.cos(t)])


def write_synthetic_spec(
    folder: Path,
    *,
    blades: int = 6,
    points: int = 12,
    thickness: str = "thickness_mm = 1.5",
    wrap_deg: float = 40.0,
    fillet: float = 1.0,
    splitters: int = 0,
    midspan: bool = False,
    extra: str = "",
) -> Path:
    """Write spec.toml + camber CSVs into ``folder``; return the spec path."""
    folder.mkdir(parents=True, exist_ok=True)
    t_contour = np.linspace(0.0, np.pi / 2, 25)
    t_camber = np.linspace(0.08, 1.5, points)
    theta = -wrap_deg * ((t_camber - t_camber[0]) / (t_camber[-1] - t_camber[0])) ** 1.3

    def write(name: str, zr: np.ndarray, th: np.ndarray) -> None:
        rows = ["r,theta_deg,z"] + [
            f"{float(r)!r},{float(a)!r},{float(z)!r}" for (z, r), a in zip(zr, th, strict=True)
        ]
        (folder / name).write_text("\n".join(rows) + "\n")

    write("hub.csv", ellipse(HUB_CENTRE, HUB_AXES, t_camber), theta)
    write("shroud.csv", ellipse(SHROUD_CENTRE, SHROUD_AXES, t_camber), theta)
    mid_line = ""
    if midspan:
        zr_h = ellipse(HUB_CENTRE, HUB_AXES, t_camber)
        zr_s = ellipse(SHROUD_CENTRE, SHROUD_AXES, t_camber)
        write("mid.csv", 0.5 * (zr_h + zr_s), theta + 3.0)
        mid_line = 'midspan = "mid.csv"'
    hub = ellipse(HUB_CENTRE, HUB_AXES, t_contour).tolist()
    shroud = ellipse(SHROUD_CENTRE, SHROUD_AXES, t_contour).tolist()
    text = f"""[impeller]
name = "synthetic"
blades = {blades}

[camber]
shroud = "shroud.csv"
hub = "hub.csv"
{mid_line}

[meridional]
hub = {hub!r}
shroud = {shroud!r}

[hub]
bore_radius_mm = 6.0

[blade]
{thickness}
leading_edge = "round"
trailing_edge = "cut"
fillet_radius_mm = {fillet}

[splitters]
count = {splitters}
start_fraction = 0.4

[allowances]
stock_mm = 2.0
finishing_mm = 0.5
{extra}
"""
    path = folder / "spec.toml"
    path.write_text(text)
    return path
