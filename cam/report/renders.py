"""Offscreen pictures the report makes itself: tool paths over the impeller, stock.

pyvista (VTK) renders off screen, no display needed. Tool paths are the tool tips
of the APT files drawn as polylines (feed moves; rapids, plunges and retracts are
left out), decimated to at most ``MAX_POINTS`` points per picture so a large job
still renders in seconds. The stock picture is the one ``cam.verify`` draws
(``cam.verify.report.render_mesh`` of ``cam.verify.surface.stock_surface``).
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_POINTS", "PathLayer", "cutting_runs", "decimate_runs", "stock_png",
           "toolpath_png"]

#: Largest number of tool-tip points drawn in one picture.
MAX_POINTS = 60_000
#: Colour of the impeller under the tool paths.
PART_COLOUR = "#c9ced4"
IMAGE_SIZE = (900, 720)


@dataclass
class PathLayer:
    """Tool-tip polylines of one operation, drawn in one colour.

    Attributes
    ----------
    label : str
        Legend text.
    colour : str
        ``#rrggbb``.
    runs : list of (k, 3) float64
        Polylines, mm, workpiece frame.
    """

    label: str
    colour: str
    runs: list[NDArray[np.float64]]


def cutting_runs(tip: NDArray[np.float64], skip: NDArray[np.bool_]
                 ) -> list[NDArray[np.float64]]:
    """Split a tool-tip sequence into polylines of consecutive drawn moves.

    Parameters
    ----------
    tip : (n, 3) float64
        Tool tips, mm.
    skip : (n,) bool
        The move ending at each pose is not drawn (e.g. rapids).

    Returns
    -------
    list of (k, 3) float64
        Each run starts at the pose before its first drawn move (where that move
        starts) and holds at least two points.
    """
    tip = np.asarray(tip, dtype=np.float64).reshape(-1, 3)
    moving = ~np.asarray(skip, dtype=bool)
    moving[:1] = False  # the first pose has no incoming move to draw
    edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(np.int8), [0]])))
    return [tip[start - 1:stop] for start, stop in zip(edges[::2], edges[1::2], strict=True)]


def decimate_runs(runs: Sequence[NDArray[np.float64]], max_points: int
                  ) -> list[NDArray[np.float64]]:
    """Keep every k-th point of each run (and its last) so the total is about
    ``max_points`` or less; runs keep their ends."""
    total = sum(len(r) for r in runs)
    step = max(1, int(np.ceil(total / max(max_points, 1))))
    if step == 1:
        return [np.asarray(r) for r in runs]
    out = []
    for run in runs:
        index = np.unique(np.concatenate([np.arange(0, len(run), step), [len(run) - 1]]))
        out.append(np.asarray(run)[index])
    return out


def _quiet_vtk() -> None:
    try:  # VTK warns about a missing X display before it falls back to offscreen
        from vtkmodules.vtkCommonCore import vtkObject

        vtkObject.GlobalWarningDisplayOff()
    except ImportError:  # pragma: no cover - vtk layout without vtkmodules
        pass


def _polylines(runs: Sequence[NDArray[np.float64]]) -> Any:
    import pyvista as pv

    points = np.concatenate(runs) if runs else np.zeros((0, 3))
    cells = []
    offset = 0
    for run in runs:
        cells.append(np.concatenate([[len(run)], offset + np.arange(len(run))]))
        offset += len(run)
    lines = np.concatenate(cells).astype(np.int64) if cells else np.zeros(0, np.int64)
    return pv.PolyData(points, lines=lines)


def toolpath_png(part_vertices: NDArray[np.float64], part_faces: NDArray[np.int64],
                 layers: Sequence[PathLayer], *, view: str = "iso",
                 max_points: int = MAX_POINTS) -> bytes:
    """PNG of the impeller (translucent) with the layers' tool-tip polylines.

    Parameters
    ----------
    part_vertices : (v, 3) float64
    part_faces : (f, 3) int64
        The impeller mesh (geometry/impeller.stl), mm.
    layers : sequence of PathLayer
        Drawn in order, each in its colour.
    view : str
        ``"iso"`` or ``"top"``.
    max_points : int
        Points drawn over all layers (each layer gets its share).
    """
    import pyvista as pv

    _quiet_vtk()
    plotter = pv.Plotter(off_screen=True, window_size=list(IMAGE_SIZE))
    plotter.set_background("white")  # type: ignore[arg-type]  # pyvista stub
    faces = np.hstack([np.full((len(part_faces), 1), 3), part_faces]).ravel()
    part = pv.PolyData(np.asarray(part_vertices, np.float64), faces)
    plotter.add_mesh(part, color=PART_COLOUR, opacity=0.35, smooth_shading=True)
    total = sum(sum(len(r) for r in layer.runs) for layer in layers) or 1
    for layer in layers:
        size = sum(len(r) for r in layer.runs)
        if size == 0:
            continue
        share = max(200, int(max_points * size / total))
        plotter.add_mesh(_polylines(decimate_runs(layer.runs, share)), color=layer.colour,
                         line_width=2.0)
    if view == "top":
        plotter.view_xy()  # type: ignore[call-arg]  # pyvista stub
    else:
        plotter.view_isometric()  # type: ignore[call-arg]  # pyvista stub
        plotter.camera.elevation = 15
    plotter.reset_camera()  # type: ignore[call-arg]  # pyvista stub
    plotter.camera.zoom(1.45 if view == "top" else 1.25)
    image = np.asarray(plotter.screenshot(return_img=True))
    plotter.close()
    return _png(image)


def stock_png(npz: Path, title: str) -> bytes:
    """PNG of a saved stock state (``stock.npz``) as ``cam.verify`` draws it (iso)."""
    from cam.verify.report import render_mesh
    from cam.verify.stock import Stock
    from cam.verify.surface import stock_surface

    work = Stock.load(npz)
    vertices, faces = stock_surface(work.grids[2], work.lower[2], work.upper[2])
    return render_mesh(vertices, faces, view="iso", title=title)


def _png(image: NDArray[np.uint8]) -> bytes:
    import matplotlib.image

    buffer = io.BytesIO()
    matplotlib.image.imsave(buffer, image, format="png")
    return buffer.getvalue()
