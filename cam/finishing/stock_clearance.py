"""Finishing against the in-process stock: what roughing really left (issue 18).

Finishing keeps shank and holder ``clearance_mm`` from the design. In the chain that
clearance includes the material roughing is *meant* to leave (``offset``, mm: the
finishing allowance plus the roughing scallop, or the blank's skin over the blade
tips); where roughing leaves more, the tool's parts that do not cut would run into
it. This module turns a verified tri-dexel stock (``cam.verify.stock.Stock``, e.g.
the chain's ``verify/rough/stock.npz``) into a second collision scene holding only the
material farther than ``offset`` from the design, and wraps both scenes so that the
finishing planner (posture checks, the dC remedy, the posture repair, the links) sees
one scene with the combined answers:

* **the excess solid**: the stock is voxelised at ``pitch`` (a voxel is material when
  any dexel interval of any of the three grids passes through it, so the voxels
  cover every ray's material); the *skin* voxels (material with an empty face
  neighbour) whose centre lies farther than ``offset - pitch sqrt(3) / 2`` from the
  design (signed distance, ``cam.verify.deviation.DesignDistance``) are kept, so
  every skin point more than ``offset`` off the design lies in a kept voxel. Their
  exposed faces are the mesh (role ``"stock"``). A tool part coming from outside must
  cross this skin, so a clearance from it bounds the clearance from the excess
  material (conservative by at most a voxel diagonal);
* **the combined check** (``StockScene``): contact is the design's or the stock's;
  the shank/holder clearance is ``min(design clearance, stock clearance + offset)``,
  so a caller comparing it with ``clearance_mm`` keeps shank and holder
  ``clearance_mm - offset`` (``stock_clearance_mm``) from the excess and
  ``clearance_mm`` from the design. The cutter cuts the stock, so it is checked
  against it only when the caller grows it (``cutter_allowance < 0``: a rapid's
  clearance), grown by ``-cutter_allowance - offset`` (at least touching);
* **engagement** (``engagement``): per posture the deepest excess material (its
  design distance, mm) inside the cutter (ball and flutes); a path reports the
  largest and the postures whose cutter meets material beyond ``offset``.

With no excess material (roughing left nothing beyond ``offset``) the wrapper gives
exactly the design scene's answers.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from functools import cached_property
from itertools import chain
from typing import TYPE_CHECKING, Any

import numpy as np
import trimesh
from numba import njit
from numpy.typing import ArrayLike, NDArray

from cam.collision import CollisionScene
from cam.collision.scene import PostureReport
from cam.collision.scene_wrapper import SceneWrapper
from cam.collision.tool_mesh import PART_NAMES
from cam.tools import Tool

if TYPE_CHECKING:
    from cam.verify.deviation import DesignDistance
    from cam.verify.stock import Stock

__all__ = ["STOCK_ROLE", "StockExcess", "StockScene", "engagement", "excess_voxels",
           "stock_blocked", "stock_blocks", "stock_scene_of", "voxel_mesh"]

Array = NDArray[np.float64]
#: Role name of the excess stock in reports (``PostureReport.hit_role``).
STOCK_ROLE = "stock"


@njit(cache=True)
def _mark(occupied, k, a, b, origin, pitch, g_origin, g_shape, g_pitch,  # type: ignore[no-untyped-def]
          count, start, lo, hi):
    """Mark the voxels every interval of one dexel grid passes through."""
    n0, n1, n2 = occupied.shape
    sizes = (n0, n1, n2)
    na, nb, nk = sizes[a], sizes[b], sizes[k]
    idx = np.zeros(3, np.int64)
    for r in range(count.shape[0]):
        c = count[r]
        if c == 0:
            continue
        i = r // g_shape[1]
        j = r - i * g_shape[1]
        ia = int(math.floor((g_origin[0] + (i + 0.5) * g_pitch - origin[a]) / pitch))
        ib = int(math.floor((g_origin[1] + (j + 0.5) * g_pitch - origin[b]) / pitch))
        if ia < 0 or ia >= na or ib < 0 or ib >= nb:
            continue
        idx[a] = ia
        idx[b] = ib
        for m in range(c):
            s = start[r] + m
            k0 = max(int(math.floor((lo[s] - origin[k]) / pitch)), 0)
            k1 = min(int(math.floor((hi[s] - origin[k]) / pitch)), nk - 1)
            for q in range(k0, k1 + 1):
                idx[k] = q
                occupied[idx[0], idx[1], idx[2]] = True
    return occupied


def _occupancy(stock: Stock, pitch: float) -> tuple[NDArray[np.bool_], Array]:
    """Voxels (pitch mm) holding material on any dexel ray, and the grid's corner."""
    origin = np.floor(stock.lower / pitch) * pitch - pitch
    shape = tuple(int(n) for n in np.ceil((stock.upper - origin) / pitch).astype(int) + 2)
    occupied = np.zeros(shape, dtype=np.bool_)
    for grid in stock.grids:
        a, b = grid.axes
        _mark(occupied, grid.k, a, b, origin, float(pitch),
              np.asarray(grid.origin, np.float64), np.asarray(grid.shape, np.int64),
              float(grid.pitch), grid.count, grid.start, grid.lo, grid.hi)
    return occupied, origin


def _skin(occupied: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Material voxels with an empty face neighbour (the grid border counts as empty)."""
    padded = np.pad(occupied, 1)
    inner = padded[1:-1, 1:-1, 1:-1].copy()
    for axis in range(3):
        for shift in (-1, 1):
            inner &= np.roll(padded, shift, axis=axis)[1:-1, 1:-1, 1:-1]
    return occupied & ~inner


@dataclass
class StockExcess:
    """Stock material farther than ``offset`` from the design, as voxels.

    Attributes
    ----------
    index : (m, 3) int64
        Kept voxels (grid indices).
    origin : (3,) float64
        Grid corner, mm.
    pitch : float
        Voxel edge, mm.
    depth : (m,) float64
        Signed design distance of each voxel centre, mm.
    offset : float
        Material meant to remain (the design clearance's share of it), mm.
    skin_voxels : int
        Skin voxels examined.
    stock_volume : float
        Material volume of the stock they come from, mm^3 (``Stock.volume``).
    """

    index: NDArray[np.int64]
    origin: Array
    pitch: float
    depth: Array
    offset: float
    skin_voxels: int
    stock_volume: float = math.nan

    @cached_property
    def centres(self) -> Array:
        """``(m, 3)`` voxel centres, mm (computed once: the fields are not changed)."""
        return np.asarray(self.origin + (self.index + 0.5) * self.pitch)

    @cached_property
    def tree(self) -> Any:
        """A ``scipy.spatial.cKDTree`` of ``centres``, built once for every query."""
        from scipy.spatial import cKDTree

        return cKDTree(self.centres)

    def summary(self) -> dict[str, Any]:
        """finish.json's ``stock`` entry (mm)."""
        return {"voxel_mm": self.pitch, "offset_mm": self.offset,
                "stock_volume_mm3": round(self.stock_volume, 3),
                "skin_voxels": self.skin_voxels, "excess_voxels": len(self.index),
                "max_depth_mm": round(float(self.depth.max()), 4) if len(self.depth)
                else None}


def excess_voxels(stock: Stock, distance: DesignDistance, offset: float,
                  pitch: float) -> StockExcess:
    """The stock's skin voxels that may hold material farther than ``offset`` (mm)
    from the design (see the module docstring).

    Parameters
    ----------
    stock : Stock
        Tri-dexel stock (workpiece frame, mm).
    distance : DesignDistance
        Signed distance from the design, mm (+ outside).
    offset : float
        Material farther than this from the design is kept, mm.
    pitch : float
        Voxel edge, mm.
    """
    occupied, origin = _occupancy(stock, pitch)
    skin = np.argwhere(_skin(occupied))
    centres = origin + (skin + 0.5) * pitch
    depth = distance(centres)
    keep = depth > offset - 0.5 * math.sqrt(3.0) * pitch
    return StockExcess(np.asarray(skin[keep], np.int64), origin, float(pitch),
                       np.asarray(depth[keep]), float(offset), len(skin), stock.volume())


def voxel_mesh(index: NDArray[np.int64], origin: Array, pitch: float) -> trimesh.Trimesh:
    """The exposed faces of a set of voxels (two triangles each), mm."""
    if not len(index):
        raise ValueError("no voxels")
    lo = index.min(axis=0) - 1
    dims = index.max(axis=0) - lo + 2
    solid = np.zeros(tuple(int(d) for d in dims), dtype=np.bool_)
    solid[tuple((index - lo).T)] = True
    quads = []
    # unit-square corners of the face normal to each axis (counter-clockwise seen from +)
    corners = {0: [(0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)],
               1: [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)],
               2: [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]}
    for axis in range(3):
        nxt = np.roll(solid, -1, axis=axis)
        for cells, shift, flip in ((solid & ~nxt, 1, False), (~solid & nxt, 1, True)):
            found = np.argwhere(cells)
            if not len(found):
                continue
            base = found.copy()
            base[:, axis] += shift
            quad = base[:, None, :] + np.array(corners[axis])[None]
            quads.append(quad[:, ::-1] if flip else quad)
    corner = np.concatenate(quads).reshape(-1, 3)
    unique, inverse = np.unique(corner, axis=0, return_inverse=True)
    q = inverse.reshape(-1, 4)
    faces = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    vertices = origin + (unique + lo) * pitch
    return trimesh.Trimesh(vertices, faces, process=False)


class StockScene(SceneWrapper, CollisionScene):
    """The design scene and the excess stock's scene as one (module docstring).

    A ``CollisionScene`` to its callers (the planner's type), built around an existing
    one: it does not run ``CollisionScene.__init__``; every attribute it does not
    define is the design scene's.

    Parameters
    ----------
    design : CollisionScene
        The part's meshes.
    excess : StockExcess
        Material beyond ``excess.offset`` from the design (no voxels: the design
        scene's answers unchanged).
    """

    def __init__(self, design: CollisionScene, excess: StockExcess) -> None:
        self.inner = self.design = design  # everything else is the design scene's
        self.excess = excess
        self.offset = excess.offset
        self.stock: CollisionScene | None = None
        if len(excess.index):
            mesh = voxel_mesh(excess.index, excess.origin, excess.pitch)
            self.stock = CollisionScene({STOCK_ROLE: mesh})

    def _stock_call(self, method: str, tool: Tool, tip: ArrayLike, axis: ArrayLike,
                    parts: Collection[str], cutter_allowance: float, clearance: bool,
                    clearance_cap: float, clearance_limits: Sequence[float],
                    extra: dict[str, float]) -> PostureReport | None:
        if self.stock is None:
            return None
        stock_parts = [p for p in PART_NAMES if p in parts
                       and (p != "cutter" or cutter_allowance < 0)]
        if not stock_parts:
            return None
        check = getattr(self.stock, method)
        report: PostureReport = check(
            tool, tip, axis, parts=stock_parts,
            cutter_allowance=min(cutter_allowance + self.offset, 0.0),
            clearance=clearance, clearance_cap=max(clearance_cap - self.offset, 0.0),
            clearance_limits=[v - self.offset for v in clearance_limits
                              if v - self.offset >= 0.0], **extra)
        return report

    def _combine(self, first: PostureReport, second: PostureReport | None) -> PostureReport:
        if second is None:
            return first
        own = np.asarray(first.collides, dtype=bool)
        collides = own | np.asarray(second.collides, dtype=bool)
        part = np.where(own, first.part, second.part).astype(np.int8)
        roles = [r if c else (STOCK_ROLE if s else None)
                 for r, c, s in zip(first.hit_role, own, second.collides, strict=True)]
        stock_clear = np.asarray(second.clearance, dtype=np.float64) + self.offset
        clear = np.asarray(first.clearance, dtype=np.float64)
        clear = np.where(np.isnan(stock_clear), clear, np.fmin(clear, stock_clear))
        checks = dict(first.checks)
        for key, value in second.checks.items():
            checks[f"stock_{key}"] = value
        return PostureReport(collides, part, roles, clear, max(first.bound, second.bound),
                             checks)

    def check_postures(self, tool: Tool, tip: ArrayLike, axis: ArrayLike, *,
                       parts: Collection[str] = PART_NAMES, cutter_allowance: float = 0.0,
                       cutter_roles: Collection[str] | None = None, clearance: bool = True,
                       clearance_cap: float = math.inf,
                       clearance_limits: Sequence[float] = ()) -> PostureReport:
        """``CollisionScene.check_postures`` against the design and the excess stock."""
        first = self.design.check_postures(
            tool, tip, axis, parts=parts, cutter_allowance=cutter_allowance,
            cutter_roles=cutter_roles, clearance=clearance, clearance_cap=clearance_cap,
            clearance_limits=clearance_limits)
        return self._combine(first, self._stock_call(
            "check_postures", tool, tip, axis, parts, cutter_allowance, clearance,
            clearance_cap, clearance_limits, {}))

    def check_motion(self, tool: Tool, tip: ArrayLike, axis: ArrayLike, *,
                     max_step_mm: float, max_step_deg: float,
                     parts: Collection[str] = PART_NAMES, cutter_allowance: float = 0.0,
                     cutter_roles: Collection[str] | None = None, clearance: bool = True,
                     clearance_cap: float = math.inf,
                     clearance_limits: Sequence[float] = (),
                     ends: PostureReport | None = None) -> PostureReport:
        """``CollisionScene.check_motion`` against the design and the excess stock.

        ``ends`` (this scene's ``check_postures`` on the same postures: design and
        stock combined) stands for the design's end samples, which the design scene
        then skips; the stock scene checks every sample, ends included (its own part
        of ``ends`` cannot be told apart). The combination is the same as without
        ``ends``: contacts are or-ed and clearances the smaller of the two (an end's
        is already the smaller), so a segment collides, or comes closer than a limit,
        exactly when it does without them. Only which contact a segment reports
        first can differ where the stock touches at its end posture and the design
        in between: that end posture collides in ``ends`` itself.
        """
        first = self.design.check_motion(
            tool, tip, axis, max_step_mm=max_step_mm, max_step_deg=max_step_deg,
            parts=parts, cutter_allowance=cutter_allowance, cutter_roles=cutter_roles,
            clearance=clearance, clearance_cap=clearance_cap,
            clearance_limits=clearance_limits, ends=ends)
        return self._combine(first, self._stock_call(
            "check_motion", tool, tip, axis, parts, cutter_allowance, clearance,
            clearance_cap, clearance_limits,
            {"max_step_mm": max_step_mm, "max_step_deg": max_step_deg}))


def stock_blocked(scene: StockScene, tool: Tool, tip: Array, axis: Array,
                  cutter_allowance: float, clearance: float) -> NDArray[np.bool_]:
    """Postures whose shank or holder touch the excess stock or come closer to it than
    ``clearance`` (mm): which of a path's interfering postures the stock blocks.

    Parameters
    ----------
    tip, axis : (n, 3) float64
        Postures, mm and unit axes.
    """
    if scene.stock is None or not len(tip):
        return np.zeros(len(tip), dtype=bool)
    report = scene.stock.check_postures(tool, tip, axis, parts=("shank", "holder"),
                                        cutter_allowance=cutter_allowance,
                                        clearance_cap=clearance,
                                        clearance_limits=(clearance,))
    clear = np.asarray(report.clearance, dtype=np.float64)
    return np.asarray(report.collides, dtype=bool) | (np.isfinite(clear) & (clear < clearance))


def stock_scene_of(scene: Any) -> StockScene | None:
    """The ``StockScene`` inside a finishing scene's wrappers (machine obstacle,
    ``DrivenScene``: their ``inner``); None when the scene holds no stock."""
    while not isinstance(scene, StockScene):
        scene = vars(scene).get("inner")  # vars: not the wrappers' forwarding
        if scene is None:
            return None
    return scene


def stock_blocks(scene: Any, tool: Tool, tip: Array, axis: Array, index: NDArray[np.intp],
                 cutter_allowance: float, clearance: float, max_step_mm: float,
                 max_step_deg: float) -> NDArray[np.bool_]:
    """Which postures ``index`` of a pass the excess stock blocks: shank or holder
    touch it or come closer than ``clearance`` (mm) to it at the posture or along the
    motion to the next posture (``interference.InterferenceResult.interfering_points``
    marks a bad motion at its start).

    A posture kept from the pass this way has no contact role (the stock's clearance
    is not a contact: ``PostureReport.hit_role`` is None), so ``pieces.finish_runs``
    asks this for the cause of its left-out postures.

    Parameters
    ----------
    scene : scene
        A finishing scene (``stock_scene_of``); none with stock: nothing is blocked.
    tip, axis : (n, 3) float64
        The pass's postures, mm and unit axes.
    index : (k,) intp
        The postures asked about.
    max_step_mm, max_step_deg : float
        Sub-sampling of the motions (the options' ``motion_step_mm`` / ``_deg``).

    Returns
    -------
    (k,) bool
    """
    index = np.asarray(index, dtype=np.intp)
    found = stock_scene_of(scene)
    if found is None or not index.size:
        return np.zeros(len(index), dtype=bool)
    clearance = max(clearance - found.offset, 0.0)
    blocked = stock_blocked(found, tool, tip[index], axis[index], cutter_allowance, clearance)
    if found.stock is None:
        return blocked
    for k, i in enumerate(index.tolist()):
        if blocked[k] or i + 1 >= len(tip):
            continue
        motion = found.stock.check_motion(
            tool, tip[i:i + 2], axis[i:i + 2], max_step_mm=max_step_mm,
            max_step_deg=max_step_deg, parts=("shank", "holder"),
            cutter_allowance=cutter_allowance, clearance_cap=clearance,
            clearance_limits=(clearance,))
        clear = np.asarray(motion.clearance, dtype=np.float64)
        blocked[k] = bool(np.asarray(motion.collides, dtype=bool).any()
                          or (np.isfinite(clear) & (clear < clearance)).any())
    return blocked


#: Postures whose (posture, voxel) pairs ``engagement`` tests at a time.
_ENGAGEMENT_CHUNK = 2048


def engagement(excess: StockExcess, tool: Tool, tip: Array, axis: Array
               ) -> tuple[Array, NDArray[np.bool_]]:
    """Deepest excess material inside the cutter (ball and flutes) per posture.

    Parameters
    ----------
    excess : StockExcess
    tool : Tool
        A ball-end mill.
    tip, axis : (n, 3) float64
        Postures, mm and unit axes.

    Returns
    -------
    depth : (n,) float64
        Largest design distance of an excess voxel whose centre lies within the
        cutter (NaN: none), mm.
    over : (n,) bool
        The cutter meets material farther than ``excess.offset`` from the design.
    """
    n = len(tip)
    depth = np.full(n, np.nan)
    if not len(excess.index) or not n:
        return depth, np.zeros(n, dtype=bool)
    radius = tool.radius
    reach = max(tool.flute_length - radius, 0.0)
    tip = np.asarray(tip, np.float64)
    axis = np.asarray(axis, np.float64)
    centre = tip + radius * axis
    middle = centre + 0.5 * reach * axis
    points = excess.centres
    # the voxels near each posture's cutter (the ball around the middle of its fluted
    # length that holds the ball end and the flutes: half the length plus the radius),
    # then the cutter's own test on all (posture, voxel) pairs of a chunk
    bound = 0.5 * reach + radius + 1e-9
    deepest = np.full(n, -np.inf)
    for lo in range(0, n, _ENGAGEMENT_CHUNK):
        hi = min(lo + _ENGAGEMENT_CHUNK, n)
        found = excess.tree.query_ball_point(middle[lo:hi], bound, return_sorted=False)
        counts = np.fromiter(map(len, found), np.int64, count=hi - lo)
        if not counts.any():
            continue
        members = np.fromiter(chain.from_iterable(found), np.int64, count=int(counts.sum()))
        owner = np.repeat(np.arange(lo, hi), counts)
        rel = points[members] - centre[owner]
        axes = axis[owner]
        along = np.clip(np.einsum("ij,ij->i", rel, axes), 0.0, reach)
        inside = np.linalg.norm(rel - along[:, None] * axes, axis=1) <= radius
        np.maximum.at(deepest, owner[inside], excess.depth[members[inside]])
    met = np.isfinite(deepest)
    depth[met] = deepest[met]
    over = np.isfinite(depth) & (np.nan_to_num(depth, nan=-np.inf) > excess.offset)
    return depth, over
