"""Benchmark: tri-dexel material removal against manifold3d boolean subtraction.

Same moves, same tool, side by side, one run:

* **3-axis**: a 6 mm ball end mill cutting six parallel slots (plunge + 12 collinear
  feed moves + retract each) into a 60 x 44 x 15 mm box. The slots do not touch, so
  the removed volume has a closed form (``tests/cam/test_verify_volume.py``).
* **5-axis**: the same ball end mill on 8 joint-mode blocks of the LinuxCNC
  ``xyzac-trt`` machine whose A and C turn inside each block, subdivided by
  ``cam.verify.motion`` within 0.01 mm; both engines remove exactly the same
  sub-moves (manifold: convex hull of the tool's ball and flute cylinder at the two
  ends of a sub-move - the exact sweep of a convex piece along a straight move).

manifold3d runs at increasing numbers of circular segments; each dexel run is compared
with the most accurate manifold run that is not more accurate than it (so the dexel
engine has equal or better volume accuracy). References: the closed form (3-axis); the dexel
engine at 0.025 mm (5-axis, not timed; across-ray error falls like h^1.5). Each engine
and resolution runs in a fresh subprocess, so peak memory (``ru_maxrss``) is its own.

Run: ``python benchmarks/bench_verify.py`` (about a few minutes on 2 cores).
"""

from __future__ import annotations

import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

R = 3.0
FLUTE = 12.0
BOXES = {
    "3axis": (np.array([-30.0, -22.0, -15.0]), np.array([30.0, 22.0, 0.0])),
    "5axis": (np.array([-18.0, -14.0, -10.0]), np.array([18.0, 14.0, 0.0])),
}


def three_axis_moves() -> tuple[np.ndarray, np.ndarray, float]:
    """Polyline of tips (n, 3) for six slots and the closed-form removed volume."""
    e = 1.0
    tip_z = -e - R
    length, pts = 24.0, []
    rows = np.arange(-17.5, 17.6, 7.0)  # six slots, 1 mm of stock between neighbours
    for y in rows:
        pts.append((-12.0, y, 5.0))
        pts += [(-12.0 + 2.0 * i, y, tip_z) for i in range(13)]
        pts.append((12.0, y, 5.0))
    tips = np.array(pts)
    n_slots = len(rows)
    section = 0.5 * math.pi * R * R + 2.0 * R * e
    ends = 2.0 * (math.pi * R**3 / 3.0 + 0.5 * math.pi * R * R * e)
    return tips, np.tile([0.0, 0.0, 1.0], (len(tips), 1)), n_slots * (length * section + ends)


def five_axis_moves() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sub-moves (tips, displacements, axes) of 8 turning blocks on xyzac-trt."""
    from cam.verify.motion import program_moves
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine
    from postproc.program import MachineProgram

    machine = load_machine(ROOT / "fixtures" / "machines" / "xyzac-trt.toml")
    kins = kinematics_for(machine)
    n = 8
    t = np.linspace(0.0, 1.0, n)
    joints = np.column_stack([
        -10.0 + 20.0 * t, 5.0 * np.sin(4 * t), -3.0 + 1.0 * np.cos(3 * t),
        np.radians(-12.0 - 6.0 * np.sin(5 * t)), np.radians(24.0 * t),
    ])
    program = MachineProgram(
        joints=joints, motion=np.ones(n, np.int8), feed_mode=np.full(n, 94, np.int16),
        feed=np.full(n, 500.0), line=np.arange(1, n + 1), tcp=np.zeros(n, bool),
        tool_number=np.ones(n, np.int32), start=np.r_[-12.0, 0.0, 6.0, 0.0, 0.0],
    )
    moves = program_moves(program, machine, kins, math.hypot(FLUTE, R), 0.01,
                          start_at_first=False)
    return moves.tips, moves.moves, moves.axes


def _tool():  # type: ignore[no-untyped-def]
    from cam.tools import Tool

    return Tool(name="ball6", number=1, shape="ball", diameter=2 * R, corner_radius=R,
                flute_length=FLUTE, shank_diameter=2 * R, stickout=FLUTE)


# ---------------------------------------------------------------------- engines
def run_dexel(case: str, pitch: float) -> dict:
    from cam.verify.stock import Stock
    from cam.verify.toolshape import tool_shape

    shape = tool_shape(_tool())
    if case == "3axis":
        pts, axes, _ = three_axis_moves()
        tips, moves, axes = pts[:-1], np.diff(pts, axis=0), axes[:-1]
    else:
        tips, moves, axes = five_axis_moves()
    warm = Stock.box([-1, -1, -1], [1, 1, 0], 0.5)
    warm.sweep(tips[:1] * 0, moves[:1] * 0, axes[:1], np.zeros(1, np.int32), shape)
    stock = Stock.box(BOXES[case][0], BOXES[case][1], pitch)
    before = stock.volume()
    wall, cpu = time.perf_counter(), time.process_time()
    stock.sweep(tips, moves, axes, np.arange(len(tips), dtype=np.int32), shape)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {"removed": before - stock.volume(), "wall": wall, "cpu": cpu, "moves": len(tips),
            "memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "stock_mb": stock.memory_bytes() / 2**20}


def _frame(axis: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) taking +Z to ``axis``."""
    z = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def run_manifold(case: str, segments: int) -> dict:
    import manifold3d as mf

    if case == "3axis":
        pts, axes, _ = three_axis_moves()
        tips, moves, axes = pts[:-1], np.diff(pts, axis=0), axes[:-1]
    else:
        tips, moves, axes = five_axis_moves()
    ball = np.asarray(mf.Manifold.sphere(R, segments).to_mesh().vert_properties)[:, :3]
    ball = ball + np.array([0.0, 0.0, R])
    flute = np.asarray(
        mf.Manifold.cylinder(FLUTE - R, R, R, segments).to_mesh().vert_properties
    )[:, :3] + np.array([0.0, 0.0, R])
    lo, hi = BOXES[case]
    stock = mf.Manifold.cube(hi - lo).translate(lo)
    before = stock.volume()
    wall, cpu = time.perf_counter(), time.process_time()
    for tip, move, axis in zip(tips, moves, axes, strict=True):
        rot = _frame(axis)
        for piece in (ball, flute):
            local = piece @ rot.T
            hull = mf.Manifold.hull_points(np.vstack([local + tip, local + tip + move]))
            stock = stock - hull
    volume = stock.volume()  # forces evaluation
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {"removed": before - volume, "wall": wall, "cpu": cpu, "moves": len(tips),
            "memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _child(engine: str, case: str, param: float) -> dict:
    out = subprocess.run(
        [sys.executable, __file__, "--one", engine, case, str(param)],
        check=True, capture_output=True, text=True, cwd=ROOT,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _compare(case: str, pitch: float, dex: dict, tried: list[tuple[int, dict]]) -> None:
    """Ratio against the most accurate manifold run that is not more accurate than
    the dexel run (so the dexel engine has equal or better accuracy)."""
    worse = [(seg, res) for seg, res in tried if res["err"] >= dex["err"]]
    if not worse:
        seg, man = tried[0]
        note = "manifold more accurate at every segment count tried"
    else:
        seg, man = worse[-1]
        note = "dexel error <= manifold error"
    print(f"  {case} dexel {pitch} mm vs manifold {seg} segments: "
          f"{man['wall'] / dex['wall']:.1f}x faster (wall), "
          f"{man['cpu'] / dex['cpu']:.1f}x (cpu); {note}")


def main() -> None:
    header = "case    engine              moves  wall s   cpu s  moves/s(cpu)  vol err %  peak MB"
    print(header)
    _, _, exact3 = three_axis_moves()
    # 5-axis reference: the dexel engine at 0.025 mm (its volume error falls like
    # h^1.5 across the rays and is exact along them; 0.1 -> 0.025 mm divides it by 8)
    reference = {"3axis": exact3, "5axis": _child("dexel", "5axis", 0.025)["removed"]}
    segment_counts = {"3axis": (24, 32, 48, 64, 96, 128, 192), "5axis": (24, 32, 48, 64)}
    for case in ("3axis", "5axis"):
        rows: list[tuple[str, dict]] = []
        dexel = {}
        for pitch in (0.1, 0.05):
            res = _child("dexel", case, pitch)
            res["err"] = 100 * abs(res["removed"] - reference[case]) / reference[case]
            dexel[pitch] = res
            rows.append((f"{case} dexel {pitch}", res))
        tried: list[tuple[int, dict]] = []
        for segments in segment_counts[case]:
            res = _child("manifold", case, segments)
            res["err"] = 100 * abs(res["removed"] - reference[case]) / reference[case]
            tried.append((segments, res))
            rows.append((f"{case} manifold {segments}seg", res))
            if res["err"] < dexel[0.05]["err"]:
                break
        for name, res in rows:
            print(f"{name:27s} {res['moves']:5d} {res['wall']:7.2f} {res['cpu']:7.2f} "
                  f"{res['moves'] / res['cpu']:12.1f} {res['err']:9.4f} {res['memory_mb']:8.0f}",
                  flush=True)
        for pitch in (0.1, 0.05):
            _compare(case, pitch, dexel[pitch], tried)


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "--one":
        engine, case, param = sys.argv[2], sys.argv[3], float(sys.argv[4])
        result = run_dexel(case, param) if engine == "dexel" else run_manifold(case, int(param))
        print(json.dumps(result))
    else:
        main()
