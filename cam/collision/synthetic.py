"""A synthetic impeller-like scene of closed-form meshes, for tests and benchmarks.

Hub: the quarter-ellipse contour of ``tests/geometry/synthetic.py`` (nose at
``z = 40, r = 12``, rim at ``z = 8, r = 40``) closed down to the back face
``z = 0`` and revolved. Blades: thin twisted plates (constant circumferential
thickness) between the hub contour (sunk 0.5 mm into the hub) and a shroud
contour, wrapping ``wrap_deg`` from inlet to outlet; splitters are the same
plates from 40 % of the meridian, half a pitch apart. Not an impeller design:
only a realistic-looking obstacle set for the collision service.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from numpy.typing import NDArray

from cam.collision.tool_mesh import concatenate

HUB_CENTRE, HUB_AXES = (40.0, 40.0), (32.0, 28.0)  # (z, r) centre and semi-axes
SHROUD_CENTRE, SHROUD_AXES = (52.0, 40.0), (38.0, 10.0)


def _ellipse(
    centre: tuple[float, float], axes: tuple[float, float], t: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(z, r) of the quarter ellipse at t in [0, pi/2] (nose to rim)."""
    return np.stack([centre[0] - axes[0] * np.sin(t), centre[1] - axes[1] * np.cos(t)], axis=-1)


def hub_mesh(sections: int = 96, samples: int = 40) -> trimesh.Trimesh:
    """Closed hub mesh, mm (workpiece frame: axis +Z, back face at z = 0)."""
    contour = _ellipse(HUB_CENTRE, HUB_AXES, np.linspace(0.0, 0.5 * math.pi, samples))
    r_rim = contour[-1, 1]
    profile = np.vstack(
        [[[0.0, 0.0], [r_rim, 0.0]], contour[::-1, ::-1], [[0.0, contour[0, 0]]]]
    )
    return trimesh.creation.revolve(profile, sections=sections)


def _unit_box(nu: int, nv: int) -> trimesh.Trimesh:
    """Surface of the unit cube [0,1]^3 gridded nu x nv on the (u, v) faces."""
    faces_u = np.linspace(0.0, 1.0, nu + 1)
    faces_v = np.linspace(0.0, 1.0, nv + 1)
    parts = []

    def grid(a: NDArray[np.float64], b: NDArray[np.float64], place: object) -> None:
        aa, bb = np.meshgrid(a, b, indexing="ij")
        pts = place(aa.ravel(), bb.ravel())  # type: ignore[operator]
        na, nb = len(a), len(b)
        idx = np.arange(na * nb).reshape(na, nb)
        q = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], -1).reshape(-1, 4)
        tri = np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
        corner = pts[tri]
        normal = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
        inward = np.einsum("ij,ij->i", normal, corner.mean(axis=1) - 0.5) < 0
        tri[inward] = tri[inward][:, ::-1]
        parts.append(trimesh.Trimesh(pts, tri, process=False))

    one, zero = np.ones, np.zeros
    w = np.array([0.0, 1.0])
    grid(faces_u, faces_v, lambda a, b: np.column_stack([a, b, zero(len(a))]))
    grid(faces_u, faces_v, lambda a, b: np.column_stack([a, b, one(len(a))]))
    grid(faces_u, w, lambda a, b: np.column_stack([a, zero(len(a)), b]))
    grid(faces_u, w, lambda a, b: np.column_stack([a, one(len(a)), b]))
    grid(faces_v, w, lambda a, b: np.column_stack([zero(len(a)), a, b]))
    grid(faces_v, w, lambda a, b: np.column_stack([one(len(a)), a, b]))
    box = concatenate(parts)
    box.merge_vertices()
    return box


def blade_mesh(
    angle: float,
    *,
    u_start: float = 0.0,
    thickness: float = 1.5,
    wrap_deg: float = 40.0,
    nu: int = 24,
    nv: int = 8,
) -> trimesh.Trimesh:
    """One closed twisted plate blade at circumferential position ``angle`` (rad)."""
    box = _unit_box(nu, nv)
    u, v, w = box.vertices.T
    t = (u_start + (1.0 - u_start) * u) * 0.5 * math.pi * 0.94 + 0.03
    hub = _ellipse(HUB_CENTRE, HUB_AXES, t)
    shroud = _ellipse(SHROUD_CENTRE, SHROUD_AXES, t)
    # sink the root 0.5 mm into the hub along the hub -> shroud direction
    span = shroud - hub
    span_len = np.linalg.norm(span, axis=1)
    root = hub - 0.5 * span / span_len[:, None]
    zr = root + v[:, None] * (shroud - root)
    z, r = zr[:, 0], zr[:, 1]
    theta = angle + math.radians(wrap_deg) * (t - 0.03) / (0.5 * math.pi * 0.94)
    theta = theta + (w - 0.5) * thickness / r
    vertices = np.column_stack([r * np.cos(theta), r * np.sin(theta), z])
    mesh = trimesh.Trimesh(vertices, box.faces, process=False)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def impeller_meshes(blades: int = 9, splitters: bool = True) -> dict[str, trimesh.Trimesh]:
    """Scene meshes by role: ``"hub"``, ``"blades"`` and optionally ``"splitters"``."""
    pitch = 2.0 * math.pi / blades
    meshes = {
        "hub": hub_mesh(),
        "blades": concatenate([blade_mesh(k * pitch) for k in range(blades)]),
    }
    if splitters:
        meshes["splitters"] = concatenate(
            [blade_mesh((k + 0.5) * pitch, u_start=0.4) for k in range(blades)]
        )
    return meshes
