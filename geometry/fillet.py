"""Rolling-ball fillets between the blades and the hub (M1): centre line and sections.

M1: the centre line of a constant-radius fillet is the intersection of the blade
surface offset by the fillet radius r_f and the hub surface offset by r_f; the
fillet is the envelope of a ball of radius r_f rolling along that line, touching
the blade and the hub. The same line is the ball-centre path of a ball-end mill of
radius r_f.

For every outline segment of a blade (:mod:`geometry.outline`) and every sample
p, we solve ``hub.signed_distance(X(p, v) + r_f n(p, v)) = r_f`` for the span
parameter v (bisection, vectorised over p): the ball centre ``c``, its contact
``P_b = X`` on the blade and ``P_h`` on the hub (the foot point of c). In the plane
of the two normals the cross-section of the fillet is the circular arc of centre
``c`` from ``P_b`` to ``P_h`` (:func:`fillet_grid`). With ``r_f = 0`` the same
solver gives the blade's footprint on the hub (no fillet).

Where the centre line curves more tightly than ``1 / r_f`` (``fold_profile`` >= 1),
the circular arcs of neighbouring sections cross: the envelope folds into a
swallowtail whose sheets lie inside other balls of the roll, in the air (nine_blade:
the suction side's cut trailing-edge corner, where the blade leans 45 deg over the
hub; ``r_f`` times the curvature 1.35, arc points up to 0.39 mm inside other balls).
A rolling ball, or a ball-end mill of radius ``r_f`` on the centre line, removes
them: the real fillet is the boundary of the union of the balls, two sheets meeting
in a ridge (as a CAD system trims a blend). ``trim_fold`` moves the arc points onto
that boundary (:func:`fillet_grid` with ``spine``), so the faces never fold; where
the centre line is gentler nothing moves.

This module is pure numpy; :mod:`geometry.solids` turns the tracks into faces.
OpenCASCADE's own fillet and booleans are not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline
from scipy.spatial import cKDTree

from geometry.outline import OutlineSegment
from geometry.revolved import RevolvedSurface
from geometry.surfaces import BladeSurface
from impeller_cam.errors import InputError

__all__ = ["FilletTrack", "blade_tracks", "fillet_grid", "fold_depth", "fold_profile",
           "fold_ratio", "fold_summary", "loop_spine", "rolling_ball", "section_parameters",
           "trim_fold"]

Array = NDArray[np.float64]
_ITERATIONS = 80
#: Residual (mm) of the rolling-ball equation at which the root search stops.
_RESIDUAL = 1e-8
#: Smallest hub surface (mm along the contour) left between a fillet and a hub edge.
HUB_MARGIN = 0.1
#: Centre-line samples per outline segment of the densified spine (``loop_spine``).
SPINE_SAMPLES = 400
#: A fillet point farther than this (mm) inside a ball of the roll lies in a fold.
FOLD_TOLERANCE = 1e-5
#: Largest number of push-outs of one point in ``trim_fold``.
_PUSHES = 60


def _unit(a: Array) -> Array:
    return np.asarray(a / np.linalg.norm(a, axis=-1, keepdims=True))


@dataclass
class FilletTrack:
    """Rolling-ball solution along one outline segment, ``(n,)`` / ``(n, 3)`` arrays.

    Attributes
    ----------
    role : str
        Role of the blade segment it follows.
    p : (n,) float64
        Segment parameter of each section.
    v : (n,) float64
        Blade span parameter of the blade contact.
    centre : (n, 3) float64
        Ball centre c, mm (the fillet centre line).
    blade_contact, hub_contact : (n, 3) float64
        Contact points of the ball with the blade and the hub, mm (the hub contact
        lies on the closed-form hub surface).
    blade_normal, hub_normal : (n, 3) float64
        Outward (towards the passage) unit normals at the contacts.
    hub_s, hub_phi : (n,) float64
        Meridional parameter and angle (rad) of the hub contact.
    """

    role: str
    p: Array
    v: Array
    centre: Array
    blade_contact: Array
    hub_contact: Array
    blade_normal: Array
    hub_normal: Array
    hub_s: Array
    hub_phi: Array

    def section(self, i: int) -> tuple[Array, ...]:
        """Per-sample values of section ``i`` (used to share end sections)."""
        return (self.v[i], self.centre[i], self.blade_contact[i], self.hub_contact[i],
                self.blade_normal[i], self.hub_normal[i], self.hub_s[i], self.hub_phi[i])

    def set_section(self, i: int, values: tuple[Array, ...]) -> None:
        """Overwrite section ``i`` with ``values`` from :meth:`section`."""
        arrays = (self.v, self.centre, self.blade_contact, self.hub_contact,
                  self.blade_normal, self.hub_normal, self.hub_s, self.hub_phi)
        for array, value in zip(arrays, values, strict=True):
            array[i] = value


def _root(f: object, lo: Array, hi: Array, f_lo: Array, f_hi: Array) -> Array:
    """Root of a decreasing function on [lo, hi] (vectorised Illinois regula falsi).

    Stops when every residual is below ``_RESIDUAL`` mm (or after ``_ITERATIONS``).
    """
    x = lo
    side = np.zeros(lo.shape, dtype=np.int8)  # which end moved last (+1 lo, -1 hi)
    for _ in range(_ITERATIONS):
        x = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        x = np.where(np.isfinite(x), x, 0.5 * (lo + hi))
        fx = np.asarray(f(x))  # type: ignore[operator]
        if float(np.max(np.abs(fx))) < _RESIDUAL or float(np.max(hi - lo)) < 1e-13:
            break
        positive = fx > 0
        f_hi = np.where(positive & (side == 1), 0.5 * f_hi, f_hi)
        f_lo = np.where(~positive & (side == -1), 0.5 * f_lo, f_lo)
        lo, f_lo = np.where(positive, x, lo), np.where(positive, fx, f_lo)
        hi, f_hi = np.where(positive, hi, x), np.where(positive, f_hi, fx)
        side = np.where(positive, 1, -1).astype(np.int8)
    return np.asarray(x)


def _no_fit(radius: float, where: str, accepted: str) -> InputError:
    if radius > 0:
        return InputError(f"a rolling ball of radius {radius:g} mm {where}",
                          field="blade.fillet_radius_mm", value=radius, accepted=accepted)
    return InputError(f"the blade root {where}", field="meridional.hub", accepted=accepted)


def rolling_ball(segment: OutlineSegment, hub: RevolvedSurface, radius: float, p: Array,
                 v_max: Array) -> FilletTrack:
    """Ball of ``radius`` mm touching the blade segment and the hub, at each ``p``.

    Parameters
    ----------
    segment : OutlineSegment
    hub : RevolvedSurface
    radius : float
        Fillet radius r_f, mm (>= 0; 0 gives the blade's footprint on the hub).
    p : (n,) float64
        Segment parameters.
    v_max : (n,) float64
        Span parameter below the hub where the search stops.

    Raises
    ------
    InputError
        When the ball does not fit between v = 0 (blade tip) and ``v_max``.
    """
    p = np.asarray(p, float)

    def gap(v: Array) -> Array:
        centre = segment.point(p, v) + radius * segment.normal(p, v)
        return np.asarray(hub.signed_distance(centre) - radius)

    lo, hi = np.zeros_like(p), np.asarray(v_max, float)
    f_lo, f_hi = gap(lo), gap(hi)
    if np.any(f_lo <= 0) or np.any(f_hi >= 0):
        where = {"pressure": "pressure side", "suction": "suction side"}.get(
            segment.role, segment.role.replace("_", " "))
        raise _no_fit(radius, f"does not fit between the {where} and the hub",
                      "a fillet radius smaller than the blade height and the passage")
    v = _root(gap, lo, hi, f_lo, f_hi)
    contact = segment.point(p, v)
    normal = segment.normal(p, v)
    centre = contact + radius * normal
    z, r = centre[:, 2], np.hypot(centre[:, 0], centre[:, 1])
    s = hub.closest_s(z, r)
    phi = np.arctan2(centre[:, 1], centre[:, 0])
    hub_normal = hub.normal(s, phi)
    return FilletTrack(segment.role, p, v, centre, contact, hub.point(s, phi), normal,
                       hub_normal, s, phi)


def _v_limit(blade: BladeSurface, u: Array, depth: float) -> Array:
    """Span parameter ``depth`` mm beyond the hub camber line (v = 1) along the ruling."""
    length = np.linalg.norm(blade.camber(u, 1.0) - blade.camber(u, 0.0), axis=-1)
    return np.asarray(1.0 + depth / length)


def section_parameters(n: int) -> Array:
    """``(n,)`` segment parameters of the sections, half uniform, half Chebyshev-spaced.

    Denser towards both ends, where the not-a-knot interpolation of the faces is
    least accurate; symmetric (``1 - p[::-1] == p``), so a segment sampled in
    either direction gets the same parameters.
    """
    i = np.linspace(0.0, 1.0, n)
    p = 0.5 * i + 0.25 * (1.0 - np.cos(np.pi * i))
    return np.asarray(0.5 * (p + (1.0 - p[::-1])))


def blade_tracks(blade: BladeSurface, hub: RevolvedSurface, outline: list[OutlineSegment],
                 radius: float, samples: dict[str, int]) -> list[FilletTrack]:
    """Rolling-ball tracks of every outline segment of one blade.

    Neighbouring segments get *identical* common end sections (the values of the
    segment before are copied), so the faces built from them share their edges.

    Parameters
    ----------
    blade : BladeSurface
    hub : RevolvedSurface
    outline : list of OutlineSegment
        :func:`geometry.outline.blade_loop` of the blade (closed loop order).
    radius : float
        Fillet radius, mm (0: footprint only).
    samples : dict
        Samples per segment kind (``side``, ``cap``, ``corner``, ``face``).

    Raises
    ------
    InputError
        The ball does not fit, or the fillet runs off the hub contour (less than
        ``HUB_MARGIN`` mm of hub left at the nose or rim side).
    """
    depth = 2.0 * radius + float(np.max(blade.thickness(np.linspace(0, 1, 11)))) + 1.0
    tracks = []
    for segment in outline:
        p = section_parameters(samples[segment.kind])
        track = rolling_ball(segment, hub, radius, p, _v_limit(blade, segment.u_of(p), depth))
        room = np.minimum(track.hub_s, 1.0 - track.hub_s) * hub.length
        if np.any(room < HUB_MARGIN):
            end = "nose (leading edge)" if track.hub_s.min() * hub.length < HUB_MARGIN \
                else "rim (trailing edge)"
            raise _no_fit(radius, f"runs off the hub contour at its {end}",
                          "a smaller fillet radius, or a hub contour reaching at least "
                          f"(fillet + thickness + {HUB_MARGIN:g}) mm beyond the blades")
        tracks.append(track)
    for k, track in enumerate(tracks):
        track.set_section(0, tracks[k - 1].section(-1))
    return tracks


def fold_profile(track: FilletTrack, radius: float) -> Array:
    """``(n,)`` ``r_f`` times the curvature of the track's centre line at each section.

    The rolling-ball surface (a canal surface) is regular where this is below 1; at
    1 or more its envelope folds (the ball cannot roll round that place without
    overlapping itself; a ball-end mill would leave a ridge there). Finite
    differences over the sections (second order, ends one-sided).
    """
    if radius <= 0 or len(track.p) < 5:
        return np.zeros(len(track.p))
    d1 = np.gradient(track.centre, track.p, axis=0, edge_order=2)
    d2 = np.gradient(d1, track.p, axis=0, edge_order=2)
    speed = np.linalg.norm(d1, axis=1)
    kappa = np.linalg.norm(np.cross(d1, d2), axis=1) / np.maximum(speed, 1e-300) ** 3
    return np.asarray(radius * kappa)


def fold_ratio(track: FilletTrack, radius: float) -> float:
    """Largest ``fold_profile`` of a track (0 for no fillet or too few sections)."""
    profile = fold_profile(track, radius)
    return float(profile.max()) if len(profile) else 0.0


def loop_spine(tracks: list[FilletTrack], samples: int = SPINE_SAMPLES) -> Array:
    """``(m, 3)`` ball centres of a blade's whole fillet loop, mm, densified.

    Per track a cubic spline in the segment parameter through its sections (exact
    at the sections), ``samples`` points each: the balls of the continuous roll
    to well below the fold depths that matter (a chord of 0.1 mm sags 0.5 um on a
    2.5 mm ball).
    """
    q = np.linspace(0.0, 1.0, samples)
    return np.concatenate([CubicSpline(t.p, t.centre, axis=0)(q) for t in tracks])


def trim_fold(points: Array, spine: Array, radius: float) -> Array:
    """``points`` moved onto the boundary of the union of the balls on ``spine``.

    A point inside a ball (closer than ``radius - FOLD_TOLERANCE`` to a centre) is
    pushed radially out of the ball of its nearest centre, repeatedly, until it lies
    in none: a point of a folded envelope's swallowtail lands on the union's
    boundary (an outer sheet next to the ridge where the sheets meet, for a shallow
    fold). Points of a regular envelope are at ``radius`` from their own centre and
    farther from the others: unchanged.

    Parameters
    ----------
    points : (..., 3) float64
        Fillet points, mm.
    spine : (m, 3) float64
        Ball centres (``loop_spine``), mm.
    radius : float
        Ball radius r_f, mm.
    """
    x = np.array(points, dtype=float).reshape(-1, 3)
    tree = cKDTree(spine)
    for _ in range(_PUSHES):
        distance, nearest = tree.query(x)
        inside = np.flatnonzero(distance < radius - FOLD_TOLERANCE)
        if not len(inside):
            break
        centre = spine[nearest[inside]]
        x[inside] = centre + radius * (x[inside] - centre) / distance[inside, None]
    return x.reshape(np.shape(points))


def fold_depth(track: FilletTrack, radius: float, spine: Array, n_arc: int = 41) -> float:
    """How far (mm) the untrimmed fillet arcs of ``track`` reach into balls of ``spine``.

    0 (to ``FOLD_TOLERANCE``) where the fillet does not fold; nine_blade's suction-side
    cut trailing-edge corner: 0.39 mm.
    """
    grid = fillet_grid(track, radius, n_arc).reshape(-1, 3)
    distance, _ = cKDTree(spine).query(grid)
    return float(max(0.0, radius - float(distance.min())))


def fold_summary(tracks: list[FilletTrack], radius: float) -> list[dict[str, float | str]]:
    """Per outline segment of one blade's loop: where and how much its fillet folds.

    Returns
    -------
    list of dict
        ``role`` of the segment, ``ratio`` (its largest ``fold_profile``), ``p``
        (the segment parameter there) and ``depth_mm`` (``fold_depth`` against the
        loop's spine: how far the untrimmed arcs reach into other balls, 0 where
        nothing folds).
    """
    if radius <= 0:
        return []
    spine = loop_spine(tracks)
    out: list[dict[str, float | str]] = []
    for track in tracks:
        profile = fold_profile(track, radius)
        k = int(np.argmax(profile))
        out.append({"role": track.role, "ratio": float(profile[k]), "p": float(track.p[k]),
                    "depth_mm": fold_depth(track, radius, spine)})
    return out


def fillet_grid(track: FilletTrack, radius: float, n_arc: int,
                spine: Array | None = None) -> Array:
    """``(n, n_arc, 3)`` points of the fillet cross-section arcs, blade -> hub contact.

    Each row is the circular arc of centre ``c`` and radius ``radius`` in the plane
    of the two contact normals, from the blade contact (first column, exactly
    ``track.blade_contact``) to the hub contact (last column, exactly
    ``track.hub_contact``), at uniform angle steps. With ``spine`` (``loop_spine``
    of the blade's tracks) the inner points are trimmed to the union of the balls
    (``trim_fold``): where the arcs fold they are moved onto the ridge.
    """
    e1 = -track.blade_normal
    cos = np.clip(np.einsum("ij,ij->i", e1, -track.hub_normal), -1.0, 1.0)
    e2 = _unit(-track.hub_normal - cos[:, None] * e1)
    angle = np.arccos(cos)[:, None] * np.linspace(0.0, 1.0, n_arc)[None, :]
    grid = track.centre[:, None, :] + radius * (np.cos(angle)[..., None] * e1[:, None, :]
                                                + np.sin(angle)[..., None] * e2[:, None, :])
    if spine is not None:
        grid[:, 1:-1] = trim_fold(grid[:, 1:-1], spine, radius)
    grid[:, 0] = track.blade_contact
    grid[:, -1] = track.hub_contact
    return np.asarray(grid)
