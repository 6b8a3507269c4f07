"""Offscreen pictures of the machine model in one pose (pyvista).

``render_machine`` draws every solid of a ``MachineScene`` posed by the joints, in
the machine frame, coloured by group; the two components of a pair (the worst pose
of a program) in red. ``scripts/machine_pictures.py`` writes the docs' pictures.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from postproc.machine_model import group_poses

__all__ = ["render_machine"]

#: Colour per group (tool side grey-blue, cradle ochre, table steel, part green).
COLOURS = {"base": "#8a8f96", "X": "#6f8fb0", "Y": "#6f8fb0", "Z": "#6f8fb0",
           "A": "#c9a24a", "B": "#c9a24a", "C": "#9fb3c8"}
#: Pixels of a picture.
SIZE = (900, 700)


def render_machine(scene: Any, kins: Any, joints: NDArray[np.float64], title: str = "",
                   highlight: tuple[str, ...] = ()) -> bytes:
    """PNG bytes of the scene's solids at ``joints`` (5,) (mm, rad), iso view.

    Parameters
    ----------
    scene : MachineScene
    kins : TableTiltingRotary
    joints : (5,) float64
    title : str
        Drawn top left.
    highlight : tuple of str
        Components drawn in red (e.g. the pair at the smallest clearance).
    """
    import pyvista as pv

    from cam.verify.report import _png

    pv.OFF_SCREEN = True
    try:  # VTK warns about a missing X display before falling back to offscreen
        from vtkmodules.vtkCommonCore import vtkObject

        vtkObject.GlobalWarningDisplayOff()
    except ImportError:  # pragma: no cover - vtk layout without vtkmodules
        pass
    poses = group_poses(kins, np.asarray(joints, np.float64)[None, :], scene.gauge, scene.tilt)
    plotter = pv.Plotter(off_screen=True, window_size=list(SIZE))
    plotter.set_background("white")  # type: ignore[call-arg, arg-type]
    for solid in scene.solids:
        rot, trans = poses[solid.group]
        points = solid.vertices @ rot[0].T + trans[0]
        cells = np.hstack([np.full((len(solid.faces), 1), 3), solid.faces]).ravel()
        mesh = pv.PolyData(points, cells)
        colour = "#d0453a" if solid.name in highlight else COLOURS.get(solid.group, "#aaaaaa")
        if solid.name == "part":
            colour = "#d0453a" if "part" in highlight else "#5f9e5f"
        plotter.add_mesh(mesh, color=colour, opacity=0.55 if solid.name == "part" else 1.0,
                         show_edges=False, smooth_shading=False)
    # from the operator's side (-Y), to the right and above, Z up
    plotter.camera.focal_point = (0.0, 0.0, 0.0)
    plotter.camera.position = (900.0, -1500.0, 900.0)
    plotter.camera.up = (0.0, 0.0, 1.0)
    plotter.reset_camera()  # type: ignore[call-arg]
    plotter.camera.zoom(1.2)
    if title:
        plotter.add_text(title, font_size=10, color="black")
    image = plotter.screenshot(return_img=True)
    plotter.close()
    return bytes(_png(np.asarray(image)))
