"""Offscreen PNG render of the impeller, faces coloured by role (pyvista)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from impeller_cam.atomic import write_bytes_atomic

__all__ = ["ROLE_COLOURS", "render_png"]

ROLE_COLOURS = {
    "hub": "#8c8c8c", "pressure": "#d95f02", "suction": "#1b9e77",
    "leading_edge": "#e7298a", "trailing_edge": "#7570b3", "fillet": "#e6ab02",
    "shroud": "#66a61e", "back": "#555555", "bore": "#444444", "rim": "#a6761d",
    "nose": "#666666",
}


def render_png(mesh: trimesh.Trimesh, roles: np.ndarray, path: str | Path,
               size: tuple[int, int] = (1200, 900)) -> Path:
    """Render ``mesh`` isometrically with one colour per role to ``path`` (atomic)."""
    import tempfile

    import pyvista as pv

    try:  # VTK warns about a missing X display before it falls back to offscreen rendering
        from vtkmodules.vtkCommonCore import vtkObject

        vtkObject.GlobalWarningDisplayOff()
    except ImportError:  # pragma: no cover
        pass

    faces = np.hstack([np.full((len(mesh.faces), 1), 3), mesh.faces]).ravel()
    poly = pv.PolyData(np.asarray(mesh.vertices), faces)
    colours = np.array([_rgb(ROLE_COLOURS.get(r, "#ffffff")) for r in roles], dtype=np.uint8)
    poly.cell_data["rgb"] = colours
    plotter = pv.Plotter(off_screen=True, window_size=list(size))
    plotter.set_background("white")  # type: ignore[arg-type]  # pyvista stub
    plotter.add_mesh(poly, scalars="rgb", rgb=True, smooth_shading=False)
    plotter.view_isometric()  # type: ignore[call-arg]  # pyvista stub
    plotter.camera.elevation = 15
    plotter.reset_camera()  # type: ignore[call-arg]  # pyvista stub
    plotter.camera.zoom(1.3)
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp) / "render.png"
        plotter.screenshot(str(scratch))
        plotter.close()
        return write_bytes_atomic(path, scratch.read_bytes())


def _rgb(hex_colour: str) -> tuple[int, int, int]:
    h = hex_colour.lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)
