"""The impeller solid: hub body + blades (+ splitters) + rolling-ball fillets, one solid.

Every face of the result is built directly with its role known by construction
and the faces are sewn into one closed shell; no boolean operation is run (the
blade-to-fillet and fillet-to-hub contacts are tangent, where OpenCASCADE's
booleans and its own fillets fail):

1. per blade *type* (main blade, splitter): the outline (:mod:`geometry.outline`),
   the rolling-ball tracks of every outline segment (:mod:`geometry.fillet`; with
   no fillet the blade's footprint on the hub), and the lateral, fillet and tip
   faces (:func:`geometry.solids.blade_faces`);
2. every blade of the type: those faces rotated by its angle (the hub is a surface
   of revolution, so the rolling-ball solution rotates with the blade);
3. the hub body (:func:`geometry.solids.hub_body_faces`): the hub face split into
   passage-wide sectors along a mid-passage curve that follows the blade wrap
   (:func:`_sector_boundary`), each trimmed by the holes of its blade(s), bounded
   by edges on the hub surface through the fillets' hub contacts; rim, nose, back
   and bore faces;
4. sewing (tolerance ``SEWING_TOLERANCE``) into one shell, one solid;
   ``BRepCheck_Analyzer`` must accept it, every face must have a role, and with
   a fillet radius > 0 every outline segment of every blade has its fillet face.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from OCP.TopoDS import TopoDS_Face
from scipy.interpolate import PchipInterpolator

from geometry.brep import GeometryBuildError, faces_of, is_valid, solid_from_faces
from geometry.fillet import FilletTrack, blade_tracks
from geometry.outline import blade_loop
from geometry.solids import (
    Hole,
    RoleSolid,
    SolidSampling,
    blade_faces,
    hub_body_faces,
    match_roles,
    rotated,
)
from geometry.surfaces import BladeSurface, ImpellerSurfaces, rotation_z
from impeller_cam.errors import InputError

__all__ = ["ROLES", "SEWING_TOLERANCE", "ImpellerSolid", "build_impeller_solid"]

#: Every face role of the impeller solid.
ROLES = (
    "hub",
    "pressure",
    "suction",
    "leading_edge",
    "trailing_edge",
    "fillet",
    "shroud",
    "back",
    "bore",
    "rim",
    "nose",
)
#: Sewing tolerance, mm. Faces sharing a boundary sample identical points; the only
#: gap is between a fillet's hub edge (interpolated in 3-D) and the hub hole edge
#: (interpolated in the hub's parameters), measured below 1e-5 mm.
SEWING_TOLERANCE = 1e-4
#: Samples of the hub sector boundary curve phi_B(s).
BOUNDARY_SAMPLES = 41
#: Smallest room (mm) between a blade's hub footprint and a hub sector boundary.
MIN_SECTOR_CLEARANCE = 0.2


@dataclass
class ImpellerSolid:
    """The impeller solid and what was built on the way.

    Attributes
    ----------
    part : RoleSolid
        The one valid solid and the role of each face.
    tracks : list of list of FilletTrack
        Per blade (mains then splitters), the rolling-ball tracks of its outline
        segments (with no fillet: the footprint on the hub, ``radius 0``).
    radius : float
        Fillet radius built, mm (0: no fillets).
    """

    part: RoleSolid
    tracks: list[list[FilletTrack]] = field(default_factory=list)
    radius: float = 0.0


def _is_rotation(blade: BladeSurface, ref: BladeSurface) -> bool:
    """``blade`` is ``ref`` rotated about +Z by the difference of their angles."""
    u, v = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 3), indexing="ij")
    turn = rotation_z(blade.angle - ref.angle)
    gap = np.abs(blade.camber(u, v) - ref.camber(u, v) @ turn.T).max()
    same_t = np.array_equal(blade.thickness(u[:, 0]), ref.thickness(u[:, 0]))
    return bool(gap < 1e-9 and same_t)


def _rotate_track(track: FilletTrack, angle: float) -> FilletTrack:
    turn = rotation_z(angle).T
    return FilletTrack(track.role, track.p, track.v, track.centre @ turn,
                       track.blade_contact @ turn, track.hub_contact @ turn,
                       track.blade_normal @ turn, track.hub_normal @ turn, track.hub_s,
                       track.hub_phi + angle)


def _sector_boundary(surfaces: ImpellerSurfaces, loops: list[list[FilletTrack]]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Mid-passage curve phi_B(s) bounding the hub sectors, and the clearance it leaves.

    phi_B follows the main blade's hub camber angle (constant beyond its ends),
    shifted by the offset (searched over one pitch) that leaves the most room
    between it and every hub contact of the reference blades ``loops``.

    Returns
    -------
    boundary, s : (BOUNDARY_SAMPLES,) float64
        phi_B (rad) at contour parameters s (uniform over [0, 1]).
    clearance : float
        Smallest distance (mm, along the parallel circle) from a hub contact to a
        sector boundary.
    """
    hub, pitch = surfaces.hub, surfaces.spec.pitch
    q = surfaces.blades[0].camber(np.linspace(0.0, 1.0, 41), 1.0)
    s_c = hub.closest_s(q[:, 2], np.hypot(q[:, 0], q[:, 1]))
    phi_c = np.unwrap(np.arctan2(q[:, 1], q[:, 0]))
    keep = (s_c > 1e-6) & (s_c < 1.0 - 1e-6) & (np.diff(s_c, prepend=-1.0) > 1e-9)
    law = PchipInterpolator(np.concatenate([[0.0], s_c[keep], [1.0]]),
                            np.concatenate([[phi_c[keep][0]], phi_c[keep], [phi_c[keep][-1]]]))
    s_h = np.concatenate([t.hub_s for loop in loops for t in loop])
    phi_h = np.concatenate([t.hub_phi for loop in loops for t in loop])
    r_h = hub.meridian(s_h)[:, 1]
    offsets = np.linspace(0.0, pitch, 145)[:-1]
    w = np.mod(phi_h[None, :] - law(s_h)[None, :] - offsets[:, None], pitch)
    room = (np.minimum(w, pitch - w) * r_h[None, :]).min(axis=1)
    best = int(np.argmax(room))
    s = np.linspace(0.0, 1.0, BOUNDARY_SAMPLES)
    return law(s) + offsets[best], s, float(room[best])


def _holes(loops: list[list[FilletTrack]], boundary: NDArray[np.float64],
           s: NDArray[np.float64], pitch: float) -> list[Hole]:
    """Hub contacts of the reference blades as (p, U, s) inside sector 0."""
    out = []
    for loop in loops:
        pieces: Hole = []
        for t in loop:
            edge = np.interp(t.hub_s, s, boundary)
            u = edge - pitch + np.mod(t.hub_phi - edge, pitch)
            pieces.append((t.p, u, t.hub_s))
        out.append(pieces)
    return out


def build_impeller_solid(surfaces: ImpellerSurfaces,
                         sampling: SolidSampling | None = None,
                         progress: Callable[[str], object] | None = None,
                         fillets: bool = True) -> ImpellerSolid:
    """Build the one-solid impeller with face roles.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
    sampling : SolidSampling, optional
        Sampling of the closed-form surfaces into B-spline faces (default
        ``SolidSampling()``).
    progress : callable, optional
        ``progress(message)`` called before each step.
    fillets : bool
        Build the blade-to-hub fillets (default). ``False`` is an explicit request
        for a solid without fillets (reported as such by the callers); with
        ``True`` a fillet that cannot be built is an error, never dropped.

    Raises
    ------
    InputError
        The geometry admits no fillet / blade root of the spec (message says why).
    GeometryBuildError
        An OpenCASCADE step failed, or the blades are not rotated copies of one
        another (message says which).
    """
    spec = surfaces.spec
    sampling = sampling or SolidSampling()
    say = progress if progress is not None else (lambda _m: None)
    radius = float(spec.fillet_radius) if fillets else 0.0
    pitch = float(spec.pitch)
    faces: list[TopoDS_Face] = []
    roles: list[str] = []
    tracks: list[list[FilletTrack]] = []
    loops = []
    for kind, group in (("blade", surfaces.blades), ("splitter", surfaces.splitters)):
        if not group:
            continue
        ref = group[0]
        say(f"{kind}: rolling-ball tracks")
        outline = blade_loop(ref, spec.leading_edge, spec.trailing_edge)
        ref_tracks = blade_tracks(ref, surfaces.hub, outline, radius, sampling.per_kind())
        say(f"{kind}: faces")
        built = blade_faces(outline, ref_tracks, radius, sampling)
        loops.append(ref_tracks)
        for blade in group:
            if not _is_rotation(blade, ref):
                raise GeometryBuildError("the blades are not rotated copies of one another")
            angle = blade.angle - ref.angle
            faces.extend(rotated(built.faces, angle) if angle else built.faces)
            roles.extend(built.roles)
            tracks.append([_rotate_track(t, angle) for t in ref_tracks])
    say("hub body")
    boundary, s, room = _sector_boundary(surfaces, loops)
    if room < MIN_SECTOR_CLEARANCE:
        raise InputError(
            f"the fillets of neighbouring blades leave {2 * room:.3f} mm of hub between them "
            f"(at least {2 * MIN_SECTOR_CLEARANCE:g} mm needed)",
            file=spec.source, field="blade.fillet_radius_mm", value=spec.fillet_radius,
            accepted="a fillet radius that leaves hub surface between the blades")
    hub_faces, hub_roles = hub_body_faces(surfaces.hub, spec.bore_radius, pitch, spec.blades,
                                          boundary, s, _holes(loops, boundary, s, pitch))
    faces.extend(hub_faces)
    roles.extend(hub_roles)
    say("sewing")
    solid = solid_from_faces(faces, SEWING_TOLERANCE, what="impeller")
    part = RoleSolid(solid, faces_of(solid), match_roles(solid, faces, roles))
    _check(part, radius, sum(len(t) for t in tracks))
    return ImpellerSolid(part, tracks, radius)


def _check(part: RoleSolid, radius: float, segments: int) -> None:
    if not is_valid(part.solid):
        raise GeometryBuildError("the impeller is not a valid solid")
    unknown = [r for r in part.roles if r not in ROLES]
    if unknown:
        raise GeometryBuildError(f"{len(unknown)} faces of the impeller have no role")
    fillets = part.roles.count("fillet")
    expected = segments if radius > 0 else 0
    if fillets != expected:
        raise GeometryBuildError(
            f"the impeller has {fillets} fillet faces, expected {expected} "
            f"(one per outline segment of every blade, radius {radius:g} mm)"
        )
