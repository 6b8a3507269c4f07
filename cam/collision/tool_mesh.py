"""Closed triangle meshes of the tool parts that circumscribe the true tool.

A tool part (``"cutter"``, ``"shank"``, ``"holder"``) is a solid of revolution
about the tool axis. Its meridian outline (radius ``r`` against height ``z`` above
the tip, tool frame: tip at the origin, axis +Z) is first replaced by a polygon
that *contains* the true outline: straight frusta are exact, and a circular arc
of radius ``c`` (ball or corner radius) is replaced by the polygon of its tangent
lines at ``k`` equally spaced angles (vertices at ``c / cos(da/2)``). That
polygon is revolved into ``N`` sections whose vertices lie at
``r / cos(pi/N)``, so the cross-section at every height is an N-gon that contains
the circle of the polygon's radius there.

Hence the mesh contains the true part: **a mesh miss implies a true miss**. The
mesh exceeds the true surface by at most

``excess = e_m + (r_max + e_m) * (sec(pi/N) - 1)``, ``e_m = c * (sec(da/2) - 1)``

(mm), where ``r_max`` is the largest radius of the part. With the default 48
sections and 7.5 deg arc steps this is 0.0043 mm for a 3 mm ball and 0.054 mm for
a 25 mm holder radius.

The cutter may be offset by ``offset`` mm (positive grows it, negative shrinks
it): side radius ``R + offset``, corner radius ``max(rc + offset, 0)`` around the
same corner centre, bottom at ``z = -offset``, top still at the flute length.
For growth, and for shrinking by no more than the corner radius, this is the
exact offset (dilation/erosion) of the cutter region below the flute length.
Tapered flutes (``Tool.flute_taper_deg`` = alpha): the corner arc ends at the
tangent point of the cone (angle ``-alpha``) and the side is the straight cone
line from there to the flute length, moved out by ``offset / cos(alpha)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import fcl
import numpy as np
import trimesh
from numpy.typing import NDArray

from cam.tools import Segment, Tool
from impeller_cam.errors import InputError

#: Tool part names, in the order the part codes of a report use (0, 1, 2).
PART_NAMES: tuple[str, ...] = ("cutter", "shank", "holder")
#: Default number of sections around the axis.
DEFAULT_SECTIONS = 48
#: Default largest angular step of a circumscribed arc in the meridian, radians.
DEFAULT_ARC_STEP = math.radians(7.5)


@dataclass(frozen=True)
class PartGeometry:
    """One tool part: meridian polygon, circumscribing mesh and its fcl model.

    Attributes
    ----------
    name : str
        ``"cutter"``, ``"shank"`` or ``"holder"``.
    profile : (k, 2) float64
        Circumscribing meridian polyline ``(r, z)`` from the axis back to the
        axis, mm, in the tool frame.
    radial_scale : float
        ``sec(pi / sections)``: mesh vertex radius over profile radius.
    mesh : trimesh.Trimesh
        Closed, outward-oriented mesh in the tool frame.
    bvh : fcl.BVHModel
        OBBRSS bounding-volume hierarchy of ``mesh``.
    excess : float
        Largest distance of the mesh outside the true part surface, mm.
    corner_centre_height : float
        Height of the ball/corner centre above the tip for the cutter, mm
        (``-inf`` for shank and holder).
    arc_excess : float
        Largest distance of ``profile`` outside the true outline, mm.
    """

    name: str
    profile: NDArray[np.float64]
    radial_scale: float
    mesh: trimesh.Trimesh
    bvh: fcl.BVHModel
    excess: float
    corner_centre_height: float = -math.inf
    arc_excess: float = 0.0


def bvh_model(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> fcl.BVHModel:
    """Build an fcl ``BVHModel`` (OBBRSS) of a triangle mesh.

    Parameters
    ----------
    vertices : (v, 3) float64
        Vertex positions, mm.
    faces : (f, 3) int
        Triangle vertex indices.
    """
    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(faces))
    model.addSubModel(
        np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, np.int64)
    )
    model.endModel()
    return model


def concatenate(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """One mesh holding all triangles of ``meshes`` (vertices not merged)."""
    joined = trimesh.util.concatenate(meshes)
    assert isinstance(joined, trimesh.Trimesh)
    return joined


def arc_polygon(
    centre: tuple[float, float], radius: float, angle0: float, angle1: float, max_step: float
) -> tuple[NDArray[np.float64], float]:
    """Tangent polygon that circumscribes a circular arc in the meridian plane.

    Parameters
    ----------
    centre : (r, z) of the arc centre, mm.
    radius : arc radius c, mm (> 0).
    angle0, angle1 : start and end angle, radians, ``angle0 < angle1``.
    max_step : largest angular step between tangent points, radians.

    Returns
    -------
    points : (k + 2, 2) float64
        The tangent point at ``angle0``, the ``k`` corners of consecutive tangent
        lines (at ``c / cos(step/2)``), the tangent point at ``angle1``.
    excess : float
        ``c * (sec(step/2) - 1)``, the largest distance of the polygon outside
        the arc, mm.
    """
    k = max(1, math.ceil((angle1 - angle0) / max_step - 1e-12))
    step = (angle1 - angle0) / k
    mid = angle0 + step * (np.arange(k) + 0.5)
    rho = radius / math.cos(0.5 * step)
    corners = np.column_stack([centre[0] + rho * np.cos(mid), centre[1] + rho * np.sin(mid)])
    ends = [
        [centre[0] + radius * math.cos(angle0), centre[1] + radius * math.sin(angle0)],
        [centre[0] + radius * math.cos(angle1), centre[1] + radius * math.sin(angle1)],
    ]
    points = np.vstack([ends[0], corners, ends[1]])
    return points, radius * (1.0 / math.cos(0.5 * step) - 1.0)


def cutter_profile(
    tool: Tool, offset: float = 0.0, arc_step: float = DEFAULT_ARC_STEP
) -> tuple[NDArray[np.float64], float]:
    """Circumscribing meridian polyline ``(r, z)`` of the (offset) cutter.

    Parameters
    ----------
    tool : Tool
    offset : float
        Signed offset of the cutter, mm: > 0 grows, < 0 shrinks.
    arc_step : float
        Largest angular step of the corner arc, radians.

    Returns
    -------
    profile : (k, 2) float64
        From ``(0, -offset)`` on the axis to ``(0, flute_length)``.
    arc_excess : float
        Meridian excess of the arc polygon, mm.
    """
    side = tool.radius + offset
    corner = max(tool.corner_radius + offset, 0.0)
    bottom = -offset
    if side <= 0 or bottom >= tool.flute_length:
        raise InputError(
            "cutter offset removes the whole cutter",
            field="cutter_allowance",
            value=-offset,
            accepted=f"less than the cutter radius {tool.radius:g} mm",
        )
    alpha = tool.flute_half_angle
    cx, cz = side - corner, bottom + corner
    points = [np.array([[0.0, bottom]])]
    excess = 0.0
    if corner > 0:
        arc, excess = arc_polygon((cx, cz), corner, -0.5 * math.pi, -alpha, arc_step)
        points.append(arc)
    else:
        points.append(np.array([[side, bottom]]))
    r_start, z_start = points[-1][-1]
    top = r_start + (tool.flute_length - z_start) * math.tan(alpha)
    points.append(np.array([[top, tool.flute_length], [0.0, tool.flute_length]]))
    return _dedupe(np.vstack(points)), excess


def segments_profile(segments: tuple[Segment, ...]) -> NDArray[np.float64]:
    """Meridian polyline ``(r, z)`` of a stack of frusta, axis to axis (exact)."""
    rows = [[0.0, segments[0].z0]]
    for seg in segments:
        rows += [[seg.r0, seg.z0], [seg.r1, seg.z1]]
    rows.append([0.0, segments[-1].z1])
    return _dedupe(np.asarray(rows, dtype=np.float64))


def grown_profile(profile: NDArray[np.float64], distance: float, step: float = 0.5
                  ) -> NDArray[np.float64]:
    """Meridian outline of a part grown by ``distance``: its revolve contains every
    point within ``distance`` of the revolved ``profile`` (Minkowski sum with a ball).

    A point at height ``z`` within ``distance`` of the part lies at most
    ``max R(z') + distance`` from the axis, over ``|z' - z| <= distance`` (``R``: the
    profile's radius at a height). That radius is taken at heights ``step`` mm apart
    over a window widened by ``step``, so the straight outline between two samples
    still contains it; the ends lie ``distance`` beyond the part's.

    Parameters
    ----------
    profile : (k, 2) float64
        ``(r, z)`` axis-to-axis meridian polyline (``revolve``'s input).
    distance, step : float
        Growth and sample spacing along the axis, mm (> 0).

    Returns
    -------
    (m, 2) float64
        Axis-to-axis polyline for ``revolve``.
    """
    side = profile[1:-1]
    z0, z1 = float(profile[0, 1]), float(profile[-1, 1])
    count = max(2, int(math.ceil((z1 - z0 + 2.0 * distance) / step)) + 1)
    heights = np.linspace(z0 - distance, z1 + distance, count)
    radii = np.empty(count)
    reach = distance + step
    for i, z in enumerate(heights):
        lo, hi = max(z - reach, z0), min(z + reach, z1)
        inside = side[(side[:, 1] >= lo) & (side[:, 1] <= hi), 0]
        ends = np.interp([lo, hi], side[:, 1], side[:, 0])
        radii[i] = max(float(ends.max()), float(inside.max(initial=0.0))) + distance
    return np.vstack([[0.0, heights[0]], np.column_stack([radii, heights]),
                      [0.0, heights[-1]]])


def _dedupe(points: NDArray[np.float64]) -> NDArray[np.float64]:
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(points, axis=0)) > 1e-12, axis=1)
    return points[keep]


def revolve(profile: NDArray[np.float64], sections: int) -> trimesh.Trimesh:
    """Revolve an axis-to-axis meridian polyline into a closed circumscribing mesh.

    Parameters
    ----------
    profile : (k, 2) float64
        ``(r, z)`` points; the first and last lie on the axis (r = 0), the others
        off it; z non-decreasing.
    sections : int
        Number of sections around the axis (>= 3). Ring vertices are placed at
        ``r / cos(pi / sections)`` so every cross-section contains its circle.

    Returns
    -------
    trimesh.Trimesh
        Watertight, outward-oriented mesh in the tool frame, mm.
    """
    z = profile[:, 1]
    inner = profile[1:-1]
    scale = 1.0 / math.cos(math.pi / sections)
    phi = 2.0 * math.pi * np.arange(sections) / sections
    rings = np.stack(
        [
            np.outer(inner[:, 0] * scale, np.cos(phi)),
            np.outer(inner[:, 0] * scale, np.sin(phi)),
            np.repeat(inner[:, 1:2], sections, axis=1),
        ],
        axis=-1,
    ).reshape(-1, 3)
    n_ring = len(inner)
    bottom_index = n_ring * sections
    top_index = bottom_index + 1
    vertices = np.vstack([rings, [[0.0, 0.0, z[0]], [0.0, 0.0, z[-1]]]])
    j = np.arange(sections)
    jn = (j + 1) % sections
    faces = [np.column_stack([np.full(sections, bottom_index), jn, j])]
    for i in range(n_ring - 1):
        a, b = i * sections, (i + 1) * sections
        faces.append(np.column_stack([a + j, a + jn, b + jn]))
        faces.append(np.column_stack([a + j, b + jn, b + j]))
    last = (n_ring - 1) * sections
    faces.append(np.column_stack([np.full(sections, top_index), last + j, last + jn]))
    mesh = trimesh.Trimesh(vertices, np.vstack(faces), process=False)
    if mesh.volume < 0:  # profile walked the other way round: flip to outward normals
        mesh.invert()
    return mesh


def part_geometry(
    tool: Tool,
    part: str,
    *,
    cutter_offset: float = 0.0,
    sections: int = DEFAULT_SECTIONS,
    arc_step: float = DEFAULT_ARC_STEP,
) -> PartGeometry | None:
    """Geometry of one tool part, or ``None`` when the tool has no such part.

    Parameters
    ----------
    tool : Tool
    part : ``"cutter"``, ``"shank"`` or ``"holder"``
    cutter_offset : float
        Signed offset of the cutter only, mm (> 0 grows).
    sections : int
        Sections around the axis (>= 8).
    arc_step : float
        Largest angular step of circumscribed arcs, radians.

    Returns
    -------
    PartGeometry or None
        Profile, mesh (mm) and BVH of the part.
    """
    if sections < 8:
        raise InputError("too few sections", field="sections", value=sections, accepted=">= 8")
    arc_excess = 0.0
    centre_height = -math.inf
    if part == "cutter":
        centre_height = max(tool.corner_radius + cutter_offset, 0.0) - cutter_offset
        profile, arc_excess = cutter_profile(tool, cutter_offset, arc_step)
    elif part == "shank":
        segs = tool.shank_segments()
        if not segs:
            return None
        profile = segments_profile(segs)
    elif part == "holder":
        if not tool.holder:
            return None
        profile = segments_profile(tool.holder)
    else:
        raise InputError("unknown tool part", field="parts", value=part, accepted=str(PART_NAMES))
    scale = 1.0 / math.cos(math.pi / sections)
    r_max = float(profile[:, 0].max())
    excess = arc_excess + (r_max + arc_excess) * (scale - 1.0)
    mesh = revolve(profile, sections)
    bvh = bvh_model(mesh.vertices, mesh.faces)
    return PartGeometry(part, profile, scale, mesh, bvh, excess, centre_height, arc_excess)


def tool_geometry(
    tool: Tool,
    *,
    cutter_offset: float = 0.0,
    sections: int = DEFAULT_SECTIONS,
    arc_step: float = DEFAULT_ARC_STEP,
) -> dict[str, PartGeometry]:
    """All parts of a tool that exist, by name (cutter, shank, holder order).

    Parameters
    ----------
    tool : Tool
        The tool (mm).
    cutter_offset : float
        Signed offset of the cutter only, mm (> 0 grows).
    sections : int
        Sections around the axis (>= 8).
    arc_step : float
        Largest angular step of circumscribed arcs, radians.

    Returns
    -------
    dict of str to PartGeometry
    """
    parts: dict[str, PartGeometry] = {}
    for name in PART_NAMES:
        geometry = part_geometry(
            tool, name, cutter_offset=cutter_offset, sections=sections, arc_step=arc_step
        )
        if geometry is not None:
            parts[name] = geometry
    return parts
