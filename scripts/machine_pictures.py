"""Write docs/images/machine_<machine>_<pose>.png: each bundled machine model at A = 0
and at its extreme tilt (pyvista offscreen), with the job solids of a bundled impeller.

Run from the repository root::

    PYTHONPATH=. python scripts/machine_pictures.py [docs/images]

The tool tip is placed over the part's top centre, 30 mm above it (A = 0) or above
the highest point of the table side (extreme tilt); the title gives the
smallest distance between the checked pairs in that pose.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from cam.tools import resolve_tool
from cam.verify.machine_check import machine_scene_for, pose_distance
from cam.verify.machine_render import render_machine
from cam.verify.sources import load_stock
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine
from postproc.machine_model import group_poses

ROOT = Path(__file__).resolve().parents[1]
#: (machine file, impeller spec for the part, tool)
JOBS = (("trunnion-500", "nine_blade", "ball6_taper"), ("xyzac-trt", "small", "ball6"))


def _pose(scene, kins, top: float, tilt: float, lift: float) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Joints at tilt ``tilt`` with the tip over the part's top centre, ``lift`` mm
    above it (A = 0) or above the highest point of the table side (tilted)."""
    joints = np.array([0.0, 0.0, 0.0, tilt, 0.0])
    poses = group_poses(kins, joints[None, :], scene.gauge, scene.tilt)
    rot, trans = poses["C"]
    joints[:3] = rot[0] @ np.array([0.0, 0.0, top]) + trans[0]
    if tilt != 0.0:
        highest = max(float((s.vertices @ poses[s.group][0][0].T
                             + poses[s.group][1][0])[:, 2].max())
                      for s in scene.solids if s.group in ("A", "B", "C"))
        joints[2] = highest
    joints[2] += lift
    return joints


def main(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for machine_name, impeller, tool in JOBS:
        machine = load_machine(ROOT / "fixtures" / "machines" / f"{machine_name}.toml")
        kins = kinematics_for(machine)
        stock = load_stock(str(ROOT / "fixtures" / "impellers" / impeller / "spec.toml"), 1.0)
        scene = machine_scene_for(machine, resolve_tool(tool), stock)
        assert scene is not None
        top = float(stock.upper[2])
        extreme = machine.axes["A"].minimum
        poses = {"a0": _pose(scene, kins, top, 0.0, 30.0),
                 "tilt": _pose(scene, kins, top, extreme, 30.0)}
        for label, joints in poses.items():
            names = [s.name for s in scene.solids]
            distance, pair = min((pose_distance(scene, kins, i, j, joints), (names[i], names[j]))
                                 for i, j, _ in scene.pairs)
            title = (f"{machine_name}, {impeller} on its fixture, {tool}: "
                     f"A {math.degrees(joints[3]):.0f} deg; smallest clearance "
                     f"{distance:.1f} mm ({pair[0]} - {pair[1]})")
            png = render_machine(scene, kins, joints, title)
            path = folder / f"machine_{machine_name}_{label}.png"
            path.write_bytes(png)
            print(path, f"{distance:.1f} mm", pair)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "images")
