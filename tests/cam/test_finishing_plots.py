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


def test_a_plots_bytes_do_not_depend_on_the_plots_drawn_before_it(tmp_path: Path) -> None:
    """Shared out over processes (each share on one figure) or drawn alone, every file
    has the same bytes: the layout starts afresh for each plot. Curves of very
    different sizes give tick labels of different widths, which moved the next plot's
    layout before."""
    from cam.finishing.plots import PER_SHARE

    rng = np.random.default_rng(3)
    count = 2 * PER_SHARE + 1
    plots = []
    for k in range(count):
        scale = 10.0 ** rng.uniform(-3, 2)
        joints = np.cumsum(rng.normal(size=(int(rng.integers(5, 120)), 5)) * scale, axis=0)
        plots.append((joints, 0.5 * joints, f"{k}.png", f"p0.blade.{k:02d}"))
    files = {}
    for workers in (1, 2):
        folder = tmp_path / str(workers)
        files[workers] = plot_angular_displacements(
            [(b, a, folder / name, title) for b, a, name, title in plots], workers)
        assert [p.name for p in files[workers]] == [f"{k}.png" for k in range(count)]
    for one, two in zip(files[1], files[2], strict=True):
        assert one.read_bytes() == two.read_bytes(), one.name
    last = plots[-1]
    alone = plot_angular_displacement(last[0], last[1], tmp_path / "alone.png", last[3])
    assert alone.read_bytes() == files[1][-1].read_bytes()
