"""The machine check's scene: the machine's solids with the job's tool, part and fixture.

``machine_scene`` gathers the machine file's ``[model]`` solids and what the job adds:
the cutter with its shank (``tool``), the holder (``holder``, the convex hull of its
segments), the part (``part``: a solid of revolution round the stock's material on the
C axis, ``part_solid``) and the fixture (``postproc.machine_model.fixture_solids``);
the pairs to check with their clearances and the pairs left out with a reason
(``MachineModel.pair_rule``). ``_distance`` is the one exact distance of two solids at
a pose (``fcl.distance``), shared by the verifier (``cam.verify.machine_check``) and
the planners (``cam.verify.machine_query``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import fcl
import numpy as np
from numpy.typing import NDArray

from postproc.machine_model import (
    MachineModel,
    Solid,
    fixture_solids,
    group_poses,
    round_solid,
)

__all__ = [
    "MachineScene", "machine_scene", "machine_scene_for", "part_solid", "pose_distance",
    "scene_summary",
]


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
    radius = max(tool.flute_top_radius, 0.5 * tool.shank_diameter)
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


def machine_scene_for(machine: Any, tool: Any, stock: Any) -> MachineScene | None:
    """The scene of a machine with a ``[model]`` (``None`` without one)."""
    if machine.model is None:
        return None
    return machine_scene(machine.model, tool, stock)


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
