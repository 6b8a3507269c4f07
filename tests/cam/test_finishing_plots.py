"""Angle plots of the finishing paths (``cam.finishing.plots``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cam.finishing.plots import plot_angular_displacement, plot_angular_displacements


def test_angle_plots_on_one_figure_are_written(tmp_path: Path) -> None:
    """The batched plots write one PNG per path, as the single-path function does."""
    rng = np.random.default_rng(7)
    joints = [np.cumsum(rng.normal(size=(40 + 10 * k, 5)), axis=0) for k in range(3)]
    written = plot_angular_displacements(
        [(j, 0.9 * j, tmp_path / "plots" / f"p{k}.png", f"p{k}") for k, j in enumerate(joints)])
    single = plot_angular_displacement(joints[0], 0.9 * joints[0], tmp_path / "one.png", "p0")
    assert [p.name for p in written] == ["p0.png", "p1.png", "p2.png"]
    for png in [*written, single]:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert single.read_bytes() == written[0].read_bytes()  # same figure, same bytes
