"""The machine's own components against each other and the part, block by block.

The scene (``cam.verify.machine_scene``) is the machine file's ``[model]`` solids plus
what the job adds: the cutter with its shank, the holder, the part and the fixture.

``check_program`` samples every block (rapids and feeds) at the controller's
interpolation (``cam.verify.motion.block_poser``) so that no point of any solid moves
more than ``step`` (1 mm by default) between samples, and measures, for every
checked pair, the distance with ``fcl.distance`` - not at every sample: a pair whose
distance was ``d`` at one sample cannot come closer than the threshold before the
pair's accumulated motion bound reaches ``d - threshold`` (conservative advancement).
The motion bound of a solid between two samples is ``|delta centre| + rho * delta
angle`` (``rho`` its bounding-sphere radius, ``delta angle`` the turn of its group);
a bounding-sphere distance stands in for the exact one when it already clears the
threshold. The threshold is the pair's clearance, or the smallest distance found so
far in the program less ``step`` (so the reported smallest clearance is exact at the
samples to within ``step``). Between two samples the true distance may be up to
``step / 2`` below the sampled one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam.verify.events import Event
from cam.verify.machine_scene import (
    MachineScene,
    _distance,
    _radii,
    machine_scene,
    machine_scene_for,
    part_solid,
    pose_distance,
    scene_summary,
)
from cam.verify.motion import block_poser
from postproc.machine_model import group_poses

__all__ = [
    "MachineCheck", "MachineScene", "check_program", "machine_scene", "machine_scene_for",
    "machine_summary", "part_solid", "pose_distance", "render_worst_pose", "scene_summary",
]

#: Samples whose poses are computed at once (memory ~ 100 bytes per sample and solid).
CHUNK = 100_000
#: Sub-samples per block at most.
MAX_SAMPLES = 4096


@dataclass
class MachineCheck:
    """What ``check_program`` found in one program.

    Attributes
    ----------
    events : list of Event
        ``machine_collision`` events, one per block and pair closer than its clearance
        and closer than at the block's start (a block that only moves a pair apart
        from where an earlier block drove it is not a new collision).
    smallest : float
        Smallest distance between any checked pair, mm (``inf``: no pair).
    pair : tuple of str
        The two components at ``smallest``.
    line : int
        NC line of the block with ``smallest``.
    joints : (5,) float64
        Joints at ``smallest`` (the worst pose), mm and rad.
    samples, exact : int
        Poses sampled, fcl distance queries made.
    """

    events: list[Event]
    smallest: float = math.inf
    pair: tuple[str, str] = ("", "")
    line: int = 0
    joints: NDArray[np.float64] = field(default_factory=lambda: np.zeros(5))
    samples: int = 0
    exact: int = 0


def _sample_plan(poser: Any, n_blocks: int, scene: MachineScene, rho: dict[str, float]
                 ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Block and fraction of every sample: the start of block 0, then sub-step ends."""
    blocks = np.arange(n_blocks, dtype=np.int64)
    j0 = poser.machine_joints(blocks, np.zeros(n_blocks))
    j1 = poser.machine_joints(blocks, np.ones(n_blocks))
    delta = np.abs(j1 - j0)
    bound = (np.linalg.norm(delta[:, :3], axis=1) + rho["tilt"] * delta[:, 3]
             + rho["C"] * delta[:, 4])
    count = np.clip(np.ceil(bound / scene.step), 1, MAX_SAMPLES).astype(np.int64)
    count[poser.tcp & (delta[:, 3:].sum(axis=1) > 0)] *= 2  # TCP: the chord is not the path
    count = np.minimum(count, MAX_SAMPLES)
    block = np.concatenate([[0], np.repeat(blocks, count)])
    first = np.cumsum(count) - count
    k = np.arange(len(block) - 1) - np.repeat(first, count) + 1
    frac = np.concatenate([[0.0], k / count[block[1:]]])
    return block, frac


def _scan_pair(
    scene: MachineScene, poses: dict[str, Any], pair: tuple[int, int, float],
    centres: NDArray, motion: NDArray, state: dict[str, Any]
) -> list[tuple[int, float, float]]:
    """Conservative advancement of one pair over one chunk of samples.

    ``poses`` are the chunk's group poses (``group_poses``), ``centres`` (m, solids, 3)
    the bounding-sphere centres, ``motion`` (m,) the pair's motion bound from the sample
    before. Returns ``(sample, distance, previous)`` where the distance is below the
    pair's clearance; ``previous`` is the distance at the sample before (``inf`` when
    that one was farther than the clearance). ``state`` carries, per pair, the motion
    bound since its last check (mm), how far it may go, and the last exact distance
    with its global sample index; also the program's ``best`` and the query count.
    """
    i, j, clearance = pair
    a, b = scene.solids[i], scene.solids[j]
    cum0, margin, last = state["pairs"].get((i, j), (0.0, -1.0, (-2, math.inf)))
    cumulative = cum0 + np.cumsum(motion)  # bound moved since the last check at each sample
    lower_bound = np.linalg.norm(centres[:, i] - centres[:, j], axis=1) - (a.radius + b.radius)
    base = 0.0
    hits: list[tuple[int, float, float]] = []
    s, n, offset = 0, len(motion), state["offset"]
    while s < n:
        if margin > 0:
            s = int(np.searchsorted(cumulative, base + margin, side="left"))
            if s >= n:
                break
        threshold = max(clearance, state["best"] - scene.step)
        distance = float(lower_bound[s])
        if distance < threshold:
            distance = _distance(scene, poses, i, j, s)
            state["exact"] += 1
            if distance < state["best"]:
                state["best"] = distance
                state["worst"] = (s + offset, (a.name, b.name))
            if distance < clearance:
                before = last[1] if last[0] == s + offset - 1 else math.inf
                hits.append((s, distance, before))
        last = (s + offset, distance)
        base = float(cumulative[s])
        margin = distance - max(clearance, state["best"] - scene.step)
        s += 1
    state["pairs"][(i, j)] = (float(cumulative[-1] - base) if n else cum0, margin, last)
    return hits


def check_program(scene: MachineScene, kins: Any, program: Any, name: str,
                  tool_length: float = 0.0) -> MachineCheck:
    """Every block of ``program`` against every checked pair of ``scene``.

    Parameters
    ----------
    scene : MachineScene
    kins : TableTiltingRotary
    program : MachineProgram
    name : str
        NC file name (for the events).
    tool_length : float
        As for ``cam.verify.motion.program_moves``.
    """
    check = MachineCheck(events=[])
    n_blocks = len(program)
    if n_blocks == 0 or not scene.pairs:
        return check
    poser = block_poser(program, kins, tool_length)
    block, frac = _sample_plan(poser, n_blocks, scene, _radii(scene, kins))
    check.samples = len(block)
    state: dict[str, Any] = {"pairs": {}, "best": math.inf, "exact": 0, "worst": None,
                             "offset": 0}
    worst_joints = np.zeros(5)
    found: dict[tuple[int, int, int], tuple[float, float]] = {}  # min, distance at start
    previous: NDArray[np.float64] | None = None
    for start in range(0, len(block), CHUNK):
        stop = min(len(block), start + CHUNK)
        joints = poser.machine_joints(block[start:stop], frac[start:stop])
        poses = group_poses(kins, joints, scene.gauge, scene.tilt)
        centres = np.stack([poses[s.group][0] @ s.centre + poses[s.group][1]
                            for s in scene.solids], axis=1)  # (m, solids, 3)
        chain = joints if previous is None else np.vstack([previous[None, :], joints])
        turn = np.abs(np.diff(chain[:, 3:], axis=0))
        if previous is None:
            turn = np.vstack([np.zeros((1, 2)), turn])
        moved = np.zeros((len(joints), len(scene.solids)))
        moved[1:] = np.linalg.norm(np.diff(centres, axis=0), axis=2)
        if previous is not None:
            moved[0] = np.linalg.norm(centres[0] - state["last_centres"], axis=1)
        for k, solid in enumerate(scene.solids):
            angle = (turn[:, 0] if solid.group == scene.tilt
                     else turn.sum(axis=1) if solid.group == "C" else 0.0)
            moved[:, k] += solid.radius * angle
        state["offset"] = start
        worst_before = state["worst"]
        for pair in scene.pairs:
            motion = moved[:, pair[0]] + moved[:, pair[1]]
            for s, distance, before in _scan_pair(scene, poses, pair, centres, motion, state):
                b = int(block[start + s])
                key = (b, pair[0], pair[1])
                # the block's first sample below the clearance: the one before it (the
                # block's start, or a sample of it at or beyond the clearance) sets the
                # distance the block started from
                at_start = found.get(key, (math.inf, before))[1]
                found[key] = (min(found.get(key, (math.inf, 0.0))[0], distance), at_start)
        if state["worst"] is not None and state["worst"] != worst_before:
            worst_joints = joints[state["worst"][0] - start].copy()
        previous = joints[-1].copy()
        state["last_centres"] = centres[-1].copy()
    check.exact = state["exact"]
    if state["worst"] is not None:
        sample, pair_names = state["worst"]
        check.smallest, check.pair = state["best"], pair_names
        check.line, check.joints = int(program.line[block[sample]]), worst_joints
    for (b, i, j), (distance, at_start) in sorted(found.items()):
        if not distance < at_start - 1e-9:
            continue  # the block only leaves a pose an earlier block drove into
        a, c = scene.solids[i].name, scene.solids[j].name
        clearance = next(p[2] for p in scene.pairs if p[0] == i and p[1] == j)
        check.events.append(Event(
            "machine_collision", int(program.line[b]), name, tuple(poser.tip[b + 1]),
            clearance - distance,
            f"{a} and {c} come within {distance:.3f} mm of each other "
            f"(clearance {clearance:.3f} mm)",
            {"components": [a, c], "distance_mm": distance, "clearance_mm": clearance},
        ))
    return check


def machine_summary(check: MachineCheck) -> dict[str, Any]:
    """verify.json keys of one program: the smallest clearance and where."""
    if not check.pair[0]:
        return {"machine_clearance_mm": None}
    return {
        "machine_clearance_mm": round(float(check.smallest), 3),
        "machine_clearance_pair": list(check.pair),
        "machine_clearance_line": int(check.line),
        "machine_clearance_joints": [round(float(v), 4) for v in
                                     [*check.joints[:3], *np.degrees(check.joints[3:])]],
        "machine_samples": int(check.samples),
        "machine_distance_queries": int(check.exact),
    }


def render_worst_pose(scene: MachineScene, kins: Any, check: MachineCheck, name: str) -> bytes:
    """PNG of the machine at a program's smallest clearance (the pair in red)."""
    from cam.verify.machine_render import render_machine

    a, b = check.pair
    title = (f"{name}: {a} - {b} {check.smallest:.1f} mm at line {check.line} "
             f"(A {np.degrees(check.joints[3]):.1f}, C {np.degrees(check.joints[4]):.1f} deg)")
    return render_machine(scene, kins, check.joints, title, (a, b))
