"""Whether a candidate UMR orientation keeps the machine's components clear (issue 18).

``machine_fit`` checks the posted program after planning; this asks the same
question of a candidate fixed axis while the passage is partitioned, so that an
orientation whose cutting poses bring two machine components (spindle head, table,
cradle, tool, holder, part) closer than their clearance is not chosen. The poses are
the region's ball-centre targets of its deepest and top layers (thinned to
``TARGETS`` per direction), as tool tips ``centre - R axis``, in every passage (turned
by ``k * pitch`` about +Z); their joints come from the machine's inverse kinematics,
and each checked pair of the verifier's scene (``cam.verify.machine_check``) is
measured with fcl at the poses where their bounding spheres come within the
clearance. The index moves and links between the poses are not sampled here: the
posted program is still checked whole afterwards (``machine_fit``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["OrientationCheck", "orientation_check", "region_targets"]

#: Ball-centre targets taken per pass direction (every ``stride``-th) at most.
TARGETS = 6


class OrientationCheck:
    """``check(axis, centres) -> (clear, worst)`` for one machine, tool and part.

    Parameters
    ----------
    scene : MachineScene
        The verifier's scene (machine model, tool, holder, part).
    kins : TableTiltingRotary
    radius : float
        Ball radius, mm (tip = ball centre - radius * axis).
    pitch : float
        Passage pitch, rad.
    passages : int
        Passages cut (each at ``C + k * pitch``).
    """

    def __init__(self, scene: Any, kins: Any, radius: float, pitch: float,
                 passages: int) -> None:
        self.scene = scene
        self.kins = kins
        self.radius = float(radius)
        self.pitch = float(pitch)
        self.passages = int(passages)

    def poses(self, axis: NDArray[np.float64], centres: NDArray[np.float64]
              ) -> NDArray[np.float64]:
        """Joints ``(n, 5)`` (mm, rad) of the tips under ``centres`` ``(..., 3)`` W."""
        from cam.roughing.passes import rotate_z

        flat = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
        tips = flat - self.radius * np.asarray(axis)[None, :]
        out = []
        for k in range(self.passages):
            angle = k * self.pitch
            t = rotate_z(tips, angle)
            a = np.repeat(rotate_z(np.asarray(axis)[None, :], angle), len(t), axis=0)
            out.append(np.asarray(self.kins.inverse(t, a)))
        return np.concatenate(out)

    def __call__(self, axis: NDArray[np.float64], centres: NDArray[np.float64]
                 ) -> tuple[bool, str]:
        """Whether every pose keeps every checked pair its clearance; the first pair
        found closer, its distance and A as text (empty when clear). A pair whose
        bounding spheres keep the clearance at a pose is not measured there (as in
        ``check_program``)."""
        from cam.verify.machine_scene import _distance
        from postproc.machine_model import group_poses

        joints = self.poses(axis, centres)
        scene = self.scene
        poses = group_poses(self.kins, joints, scene.gauge, scene.tilt)
        spheres = np.stack([poses[s.group][0] @ s.centre + poses[s.group][1]
                            for s in scene.solids], axis=1)  # (n, solids, 3)
        for i, j, clearance in scene.pairs:
            gap = (np.linalg.norm(spheres[:, i] - spheres[:, j], axis=1)
                   - scene.solids[i].radius - scene.solids[j].radius)
            for s in np.flatnonzero(gap < clearance):
                d = _distance(scene, poses, i, j, int(s))
                if d < clearance:
                    return False, (f"{scene.solids[i].name} and {scene.solids[j].name} "
                                   f"{d:.2f} mm apart (clearance {clearance:.2f} mm) at A "
                                   f"{np.degrees(joints[s, 3]):.1f} deg")
        return True, ""


def region_targets(centres: NDArray[np.float64], start: int, stop: int
                   ) -> NDArray[np.float64]:
    """Ball-centre targets ``(k, 3)`` of stations ``start..stop-1`` of a passage grid's
    ``centres`` ``(n1 + 1, n_s + 1, m, 3)``: the deepest layer and the shallowest,
    every pass direction and station thinned to ``TARGETS``."""
    sub = centres[[0, -1], :, start:stop]
    for ax in (1, 2):
        n = sub.shape[ax]
        keep = np.unique(np.linspace(0, n - 1, min(n, TARGETS)).round().astype(int))
        sub = np.take(sub, keep, axis=ax)
    return np.asarray(sub.reshape(-1, 3))


def orientation_check(machine: Any, kins: Any, tool: Any, spec: str | Path,
                      pitch: float, passages: int) -> OrientationCheck | None:
    """The check of a machine with a ``[model]`` (``None`` without one: every
    orientation is admitted), with the spec's blank (``machine_fit.BLANK_PITCH``)
    standing for the part."""
    if machine is None or getattr(machine, "model", None) is None:
        return None
    from cam.roughing.machine_fit import BLANK_PITCH
    from cam.verify.machine_check import machine_scene, part_solid
    from cam.verify.sources import load_stock

    part = part_solid(load_stock(str(spec), BLANK_PITCH))
    scene = machine_scene(machine.model, tool, None, part=part)
    if not scene.pairs:
        return None
    return OrientationCheck(scene, kins, tool.radius, pitch, passages)
