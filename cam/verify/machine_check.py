"""The machine's own components against each other and the part, block by block.

The scene (``machine_scene``) is the machine file's ``[model]`` solids plus what the
job adds: the cutter with its shank (``tool``), the holder (``holder``, the convex
hull of its segments), the part (``part``: a cylinder round the stock's material on
the C axis) and the fixture (``postproc.machine_model.fixture_solids``).

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

import fcl
import numpy as np
from numpy.typing import NDArray

from cam.verify.events import Event
from cam.verify.motion import block_poser
from postproc.machine_model import (
    MachineModel,
    Solid,
    fixture_solids,
    group_poses,
    round_solid,
)

__all__ = [
    "MachineCheck", "MachineScene", "check_program", "machine_scene", "machine_scene_for",
    "machine_summary", "part_solid", "pose_distance", "render_worst_pose", "scene_summary",
]

#: Samples whose poses are computed at once (memory ~ 100 bytes per sample and solid).
CHUNK = 100_000
#: Sub-samples per block at most.
MAX_SAMPLES = 4096


@dataclass
class MachineScene:
    """Solids, checked pairs ``(i, j, clearance)`` and pairs left out with a reason."""

    solids: list[Solid]
    pairs: list[tuple[int, int, float]]
    left_out: list[tuple[str, str, str]]
    gauge: float
    step: float
    tilt: str
    objects: list[list[Any]] = field(default_factory=list)


def _convex_hull(points: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Vertices and outward triangles of the convex hull of ``points`` (p, 3)."""
    import trimesh

    hull = trimesh.convex.convex_hull(points)
    return np.asarray(hull.vertices, np.float64), np.asarray(hull.faces, np.int64)


def _tool_solids(tool: Any, gauge: float) -> list[Solid]:
    """Cutter + shank (a cylinder to the holder nose) and the holder hull, group Z."""
    radius = max(tool.radius, 0.5 * tool.shank_diameter)
    solids = [round_solid("tool", "Z", radius, radius, tool.stickout, "z",
                          (0.0, 0.0, 0.5 * tool.stickout - gauge))]
    if tool.holder:
        rings = []
        for seg in tool.holder:
            for z, r in ((seg.z0, seg.r0), (seg.z1, seg.r1)):
                ring = round_solid("ring", "Z", max(r, 1e-3), max(r, 1e-3), 1e-3, "z",
                                   (0.0, 0.0, z - gauge))
                rings.append(ring.vertices)
        vertices, faces = _convex_hull(np.vstack(rings))
        solids.append(Solid("holder", "Z", "convex", vertices, faces))
    return solids


def _part_profile(stock: Any, slab: float = 2.0) -> NDArray[np.float64]:
    """Largest radius of the stock's material per ``slab`` of height, as ``(r, z)``.

    From the X and Y dexels: a ray at ``(y, z)`` (or ``(x, z)``) with material between
    ``lo`` and ``hi`` reaches ``hypot(max(|lo|, |hi|), |y| + h/2)`` from the C axis; its
    cell spans ``z +- h/2``. Returns an axis-to-axis staircase profile, mm.
    """
    lows, highs, reach = [], [], []
    slab = max(slab, float(stock.pitch))
    for grid in stock.grids[:2]:
        count = np.asarray(grid.count)
        rays = np.flatnonzero(count > 0)
        if not len(rays):
            continue
        i, j = np.divmod(rays, int(grid.shape[1]))
        first_axis = grid.origin[0] + (i + 0.5) * grid.pitch  # world axis (k + 1) % 3
        second_axis = grid.origin[1] + (j + 0.5) * grid.pitch  # world axis (k + 2) % 3
        z, other = (second_axis, first_axis) if grid.k == 0 else (first_axis, second_axis)
        across = np.abs(other) + 0.5 * grid.pitch
        first = np.asarray(grid.lo)[np.asarray(grid.start)[rays]]
        last = np.asarray(grid.hi)[np.asarray(grid.start)[rays] + count[rays] - 1]
        reach.append(np.hypot(np.maximum(np.abs(first), np.abs(last)), across))
        lows.append(z - 0.5 * grid.pitch)
        highs.append(z + 0.5 * grid.pitch)
    if not reach:
        lo, hi = float(stock.lower[2]), float(stock.upper[2])
        return np.array([[0.0, lo], [1.0, lo], [1.0, hi], [0.0, hi]])
    radius, low, high = np.concatenate(reach), np.concatenate(lows), np.concatenate(highs)
    z0 = float(low.min())
    n = max(1, int(np.ceil((float(high.max()) - z0) / slab)))
    per = np.zeros(n)
    for edge in (low, high - 1e-9):  # a cell (<= one slab high) counts in both its slabs
        slot = np.clip(((edge - z0) / slab).astype(np.int64), 0, n - 1)
        np.maximum.at(per, slot, radius)
    per = np.maximum(per, 1e-3)
    top = min(z0 + n * slab, float(high.max()))
    edges = np.minimum(z0 + slab * np.arange(n + 1), top)
    points: list[tuple[float, float]] = [(0.0, float(edges[0]))]
    for k in range(n):
        points += [(float(per[k]), float(edges[k])), (float(per[k]), float(edges[k + 1]))]
    points.append((0.0, float(edges[-1])))
    return np.asarray(points)


def part_solid(stock: Any, piece_height: float = 10.0) -> Solid:
    """The stock's material as a solid of revolution about the C axis (group C).

    Distances are taken to convex pieces: the hulls of the profile's rings over
    ``piece_height`` mm of height each (they hold the staircase, so they hold the part).
    """
    from cam.collision.tool_mesh import revolve

    profile = _part_profile(stock)
    mesh = revolve(profile, 48)
    scale = 1.0 / math.cos(math.pi / 24)
    angle = np.linspace(0.0, 2.0 * math.pi, 24, endpoint=False)
    ring = np.column_stack([np.cos(angle), np.sin(angle)]) * scale
    inner = profile[1:-1]
    z0 = float(inner[0, 1])
    slot = np.minimum(((inner[:, 1] - z0) / piece_height).astype(np.int64),
                      int((inner[-1, 1] - z0 - 1e-9) // piece_height))
    pieces = []
    for k in np.unique(slot):
        rows = inner[slot == k]
        # the piece also reaches its neighbours' end heights, so the pieces overlap
        lo = float(rows[0, 1]) if k == slot[0] else float(inner[slot == k - 1][-1, 1])
        pts = [np.column_stack([r * ring, np.full(24, z)]) for r, z in rows]
        pts.append(np.column_stack([rows[0, 0] * ring, np.full(24, lo)]))
        pieces.append(np.vstack(pts))
    return Solid("part", "C", "stl", np.asarray(mesh.vertices, np.float64),
                 np.asarray(mesh.faces, np.int64), pieces=tuple(pieces))


def _convex(points: NDArray[np.float64]) -> Any:
    vertices, faces = _convex_hull(points)
    flat = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
    return fcl.CollisionObject(fcl.Convex(vertices, len(faces), flat), fcl.Transform())


def _fcl_objects(solid: Solid) -> list[Any]:
    """fcl objects whose union is the solid (one, or one per convex piece)."""
    if solid.pieces:
        return [_convex(points) for points in solid.pieces]
    if solid.box is not None:
        geometry = fcl.Box(*solid.box[0])
    elif solid.cylinder is not None:
        geometry = fcl.Cylinder(solid.cylinder[0], solid.cylinder[1])
    elif solid.kind == "convex":
        return [_convex(solid.vertices)]
    else:
        geometry = fcl.BVHModel()
        geometry.beginModel(len(solid.vertices), len(solid.faces))
        geometry.addSubModel(solid.vertices, solid.faces)
        geometry.endModel()
    return [fcl.CollisionObject(geometry, fcl.Transform())]


def _local(solid: Solid) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Placement of the fcl geometry in its group frame (rotation, centre)."""
    if solid.pieces:
        return np.eye(3), np.zeros(3)
    if solid.box is not None:
        return np.eye(3), solid.box[1]
    if solid.cylinder is not None:
        return solid.cylinder[2], solid.cylinder[3]
    return np.eye(3), np.zeros(3)


def machine_scene(model: MachineModel, tool: Any, stock: Any,
                  part: Solid | None = None) -> MachineScene:
    """The machine's solids with the job's tool, holder, part and fixture.

    Parameters
    ----------
    model : MachineModel
    tool : cam.tools.Tool
        The holder's gauge line is the top of its last holder segment (the stickout
        without a holder), mm above the tip.
    stock : Stock
        The verifier's stock (its material gives the part's solid of revolution).
    part : Solid, optional
        The part's solid already made (``part_solid``; ``stock`` is then not read).
    """
    gauge = float(tool.length)
    part = part_solid(stock) if part is None else part
    solids = [*model.components, *_tool_solids(tool, gauge), part]
    if model.fixture is not None:
        bottom, top = float(part.vertices[:, 2].min()), float(part.vertices[:, 2].max())
        rim = float(np.hypot(*part.vertices[part.vertices[:, 2] < bottom + 1e-9, :2].T).max())
        solids += fixture_solids(model.fixture, bottom, top, rim, "C")
    pairs: list[tuple[int, int, float]] = []
    left_out: list[tuple[str, str, str]] = []
    for i, a in enumerate(solids):
        for j in range(i + 1, len(solids)):
            clearance, reason = model.pair_rule(a, solids[j])
            if clearance is not None:
                pairs.append((i, j, clearance))
            elif a.group != solids[j].group:
                left_out.append((a.name, solids[j].name, reason))
    scene = MachineScene(solids, pairs, left_out, gauge, model.step, model.tilt)
    scene.objects = [_fcl_objects(s) for s in solids]
    return scene


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


def _distance(scene: MachineScene, poses: dict[str, Any], i: int, j: int, s: int,
              witness: list[Any] | None = None) -> float:
    """fcl distance of solids ``i`` and ``j`` at sample ``s`` of ``poses`` (0: overlap);
    ``witness`` gets the nearest points (machine frame) of the closest pieces."""
    for k in (i, j):
        solid = scene.solids[k]
        rot, trans = poses[solid.group][0][s], poses[solid.group][1][s]
        turn, centre = _local(solid)
        placed = fcl.Transform(rot @ turn, rot @ centre + trans)
        for item in scene.objects[k]:
            item.setTransform(placed)
    request = fcl.DistanceRequest()
    value = math.inf
    for first in scene.objects[i]:
        for second in scene.objects[j]:
            result = fcl.DistanceResult()
            found = float(fcl.distance(first, second, request, result))
            if found < value and witness is not None:
                witness[:] = list(result.nearest_points)
            value = min(value, found)
    return max(value, 0.0)


def pose_distance(scene: MachineScene, kins: Any, i: int, j: int,
                  joints: NDArray[np.float64]) -> float:
    """fcl distance of solids ``i`` and ``j`` at one joint vector (5,), mm."""
    poses = group_poses(kins, np.asarray(joints, np.float64)[None, :], scene.gauge, scene.tilt)
    return _distance(scene, poses, i, j, 0)


def _radii(scene: MachineScene, kins: Any) -> dict[str, float]:
    """Largest distance of a table-side point from the tilt pivot and from the C axis."""
    tilt = [s for s in scene.solids if s.group in (scene.tilt, "C")]
    pivot = np.asarray(kins.offset, dtype=np.float64)
    out = {"tilt": 0.0, "C": 0.0}
    for solid in tilt:
        out["tilt"] = max(out["tilt"], float(np.linalg.norm(solid.vertices - pivot, axis=1).max()))
        if solid.group == "C":
            out["C"] = max(out["C"], float(np.hypot(*solid.vertices[:, :2].T).max()))
    return out


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


def machine_scene_for(machine: Any, tool: Any, stock: Any) -> MachineScene | None:
    """The scene of a machine with a ``[model]`` (``None`` without one)."""
    if machine.model is None:
        return None
    return machine_scene(machine.model, tool, stock)


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


def scene_summary(scene: MachineScene) -> dict[str, Any]:
    """verify.json ``machine_model``: components, checked pairs, pairs left out."""
    names = [s.name for s in scene.solids]
    return {
        "components": [{"name": s.name, "axis": s.group, "shape": s.kind} for s in scene.solids],
        "gauge_line_mm": round(scene.gauge, 3),
        "step_mm": scene.step,
        "pairs_checked": [[names[i], names[j], c] for i, j, c in scene.pairs],
        "pairs_left_out": [[a, b, reason] for a, b, reason in scene.left_out],
    }


def render_worst_pose(scene: MachineScene, kins: Any, check: MachineCheck, name: str) -> bytes:
    """PNG of the machine at a program's smallest clearance (the pair in red)."""
    from cam.verify.machine_render import render_machine

    a, b = check.pair
    title = (f"{name}: {a} - {b} {check.smallest:.1f} mm at line {check.line} "
             f"(A {np.degrees(check.joints[3]):.1f}, C {np.degrees(check.joints[4]):.1f} deg)")
    return render_machine(scene, kins, check.joints, title, (a, b))
