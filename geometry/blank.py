"""The lathe-turned blank of an impeller: its meridional profile.

One definition for every stage that needs the stock before milling: roughing plans
against it (``cam.roughing.stock.Blank``: which balls meet it, the surface its
stock maps start from) and verification simulates it (``cam.verify.sources``,
``--stock SPEC``). Until session 7 roughing had a blank of its own (the shroud
envelope's signed distance, closed by a ring out to the rim up to the shroud's
outlet height): it planned cuts in air around the trailing edges and knew a
slightly different stock than the one verification removes.

Since issue 28 the blank follows the design's true extent (``spec_blank_profile``:
every blade face, round and cut edges, tips, fillets, splitters, dilated by the stock
allowance), not the camber lines' ends, which the edges and the fillets at the rim
reach beyond: the camber-based blank cut up to 0.7 mm into the part.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from geometry.spec import ImpellerSpec
from geometry.surfaces import ImpellerSurfaces

__all__ = ["SLACK", "STEP", "blank_profile", "raised_profile", "spec_blank_profile"]

#: Spacing of the radii at which the dilated blades' envelope is taken, mm. Between
#: two radii the envelope is linear: where a disc's vertical side falls between them
#: (the outer side of a fillet's bump on the rim), up to this much of the allowance
#: may be missing (with an allowance larger than this the blank never cuts into the
#: design).
STEP = 0.05
#: Tolerance of the profile's thinning, mm; the envelope is raised by as much first,
#: so the thinned blank still holds the allowance.
SLACK = 0.01


def _offset(contour: NDArray[np.float64], allowance: float
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(r, z) of a meridional contour (k, 2) of (z, r) offset by ``allowance`` along
    its normal, outwards (away from the impeller's material: larger r and z)."""
    r, z = contour[:, 1], contour[:, 0]
    dr, dz = np.gradient(r), np.gradient(z)
    length = np.hypot(dr, dz)
    nr, nz = -dz / length, dr / length
    flip = (nr + nz) < 0
    nr[flip], nz[flip] = -nr[flip], -nz[flip]
    return r + allowance * nr, z + allowance * nz


def blank_profile(
    shroud_contour: NDArray[np.float64],
    allowance: float,
    bore_radius: float,
    hub_contour: NDArray[np.float64] | None = None,
    blade_top: float | None = None,
    blade_radius: float | None = None,
) -> NDArray[np.float64]:
    """Meridional polygon (k, 2) of (r, z), mm, of the lathe-turned blank.

    The shroud contour (z, r), inlet to outlet, is offset outwards by ``allowance``
    along its meridional normal; the blank runs from the back face z = 0, from the
    bore out to the largest contour radius plus the allowance (a hub rim may reach
    beyond the blade tips).

    Without ``hub_contour`` the top is flat at the highest contour point plus the
    allowance. With it, the inlet end is turned as a lathe would leave it for milling:
    a flat inlet face at ``max(offset shroud inlet, blade_top + allowance)``
    (``blade_top``: highest z of the blades, mm, e.g. of their camber lines), and
    where the hub nose stands above that face, the nose turned to its final contour
    (no allowance: no milling operation reaches it, and a cutter's shank passing over
    the inlet must not meet stock that the design does not have). With ``blade_radius``
    (largest radius of the blades, mm) the outer diameter is turned before milling to
    the blades' largest radius (the trailing edges' cylinder; a lathe finishes it, no
    milling operation does): beyond it nothing stands in a lathe tool's way, so the
    blank there is the hub contour offset by the allowance (out to the rim), not a
    ring of stock up to the shroud's outlet height around and between the trailing
    edges, which the finishing tools' shanks brushed.
    """
    contour = np.asarray(shroud_contour, dtype=np.float64)
    r = contour[:, 1]
    off_r, off_z = _offset(contour, allowance)
    both = contour if hub_contour is None else np.vstack([contour, hub_contour])
    r_max = float(both[:, 1].max()) + allowance
    order = np.arange(len(r))[::-1]  # outlet first, then along the contour to the inlet
    if hub_contour is None:
        z_top = float(both[:, 0].max()) + allowance
        pts = [(bore_radius, 0.0), (r_max, 0.0), (r_max, float(off_z[order[0]]))]
        pts += [(float(off_r[i]), float(min(off_z[i], z_top))) for i in order]
        pts += [(float(off_r[order[-1]]), z_top), (bore_radius, z_top), (bore_radius, 0.0)]
        return np.array(pts)
    hub = np.asarray(hub_contour, dtype=np.float64)
    top = -np.inf if blade_top is None else blade_top + allowance
    face = max(float(off_z[order[-1]]), top)
    pts = [(bore_radius, 0.0), (r_max, 0.0)]
    r_cut = math.inf if blade_radius is None else blade_radius
    if r_cut < r_max - 1e-9:
        hub_r, hub_z = _offset(hub, allowance)
        outer = np.argsort(-hub_r)  # outlet first
        outer = outer[hub_r[outer] > r_cut]
        by_r = np.argsort(hub_r)
        z_cut = float(np.interp(r_cut, hub_r[by_r], hub_z[by_r]))
        pts.append((r_max, float(hub_z[outer[0]]) if len(outer) else z_cut))
        pts += [(float(hub_r[i]), float(hub_z[i])) for i in outer if hub_r[i] < r_max]
        pts += [(r_cut, z_cut), (r_cut, float(off_z[order[0]]))]
    else:
        pts.append((r_max, float(off_z[order[0]])))
    pts += [(float(off_r[i]), float(min(off_z[i], face))) for i in order if off_r[i] <= r_cut]
    pts.append((float(off_r[order[-1]]), face))
    above = hub[:, 0] > face  # the nose above the inlet face, z descending from the nose
    if above.any():
        inlet = np.argsort(hub[:, 0])  # ascending z for the crossing of the face
        r_face = float(np.interp(face, hub[inlet, 0], hub[inlet, 1]))
        pts.append((r_face, face))
        pts += [(float(rr), float(zz)) for zz, rr in hub[above][::-1]]
        pts.append((bore_radius, float(hub[above, 0].max())))
    else:
        pts.append((bore_radius, face))
    pts.append((bore_radius, 0.0))
    profile = np.array(pts)
    keep = np.r_[True, np.linalg.norm(np.diff(profile, axis=0), axis=1) > 1e-9]
    return profile[keep]


def _limits(path: NDArray[np.float64], at: NDArray[np.float64]
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Highest z of a path's non-vertical segments just left and just right of each r.

    Parameters
    ----------
    path : (k, 2) float64
        (r, z) points, mm.
    at : (c,) float64
        Radii, mm.

    Returns
    -------
    left, right : (c,) float64
        Limits from r < at and r > at, mm (``-inf`` where no segment is).
    """
    left = np.full(len(at), -np.inf)
    right = np.full(len(at), -np.inf)
    for (r0, z0), (r1, z1) in zip(path[:-1], path[1:], strict=True):
        if abs(r1 - r0) < 1e-12:
            continue
        (ra, za), (rb, zb) = sorted(((r0, z0), (r1, z1)))
        value = za + (at - ra) / (rb - ra) * (zb - za)
        right = np.where((ra <= at) & (at < rb), np.maximum(right, value), right)
        left = np.where((ra < at) & (at <= rb), np.maximum(left, value), left)
    return left, right


def _thinned(points: NDArray[np.float64], tolerance: float) -> NDArray[np.float64]:
    """Douglas-Peucker: the polyline's points needed to stay within ``tolerance`` mm of it
    (the two ends always kept), ``(j, 2)``."""
    keep = np.zeros(len(points), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(points) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = points[i], points[j]
        ab = b - a
        rel = points[i + 1:j] - a
        length = float(np.hypot(*ab))
        if length < 1e-12:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        else:
            dist = np.abs(ab[0] * rel[:, 1] - ab[1] * rel[:, 0]) / length
        k = int(np.argmax(dist))
        if dist[k] > tolerance:
            keep[i + 1 + k] = True
            stack += [(i, i + 1 + k), (i + 1 + k, j)]
    return points[keep]


def raised_profile(profile: NDArray[np.float64], radii: NDArray[np.float64],
                   top: NDArray[np.float64], slack: float = 0.0) -> NDArray[np.float64]:
    """A blank profile raised to at least ``top`` at every radius.

    The profile is read as the region under its top (``blank_profile``'s: from z = 0 up
    to the top path, from the bore out); the result is the region under the larger of
    that top and the polyline through ``top`` (crossings computed exactly), as one
    closed polygon, thinned to within ``slack`` of it.

    Parameters
    ----------
    profile : (k, 2) float64
        Closed polygon (r, z), mm, from ``(bore, 0)`` out along z = 0 to the outer
        diameter, back along the top to the bore and down to ``(bore, 0)``.
    radii : (m,) float64
        Increasing radii, mm.
    top : (m,) float64
        Height the blank must reach at each radius, mm (``-inf``: no demand), e.g.
        ``geometry.blank_envelope.dilated_top``.
    slack : float
        Tolerance of the thinning (Douglas-Peucker), mm.

    Returns
    -------
    (j, 2) float64
        Closed polygon (r, z), mm, first point repeated.

    Notes
    -----
    The profile's top is read, at each radius, as its highest point there; a top
    path whose radius turns back (an overhang) is filled underneath.
    """
    path = np.asarray(profile[1:-1], dtype=np.float64)
    bore = float(profile[0, 0])
    demand = np.where(np.isfinite(top), top, -1e9)  # the wall of a demand: within a step
    cuts = np.unique(np.concatenate([path[:, 0], radii[(radii > bore)
                                                      & np.isfinite(top)]]))[::-1]
    l_left, l_right = _limits(path, cuts)
    raise_to = np.interp(cuts, radii, demand, left=-1e9, right=-1e9)
    up_left = np.maximum(np.maximum(l_left, raise_to), 0.0)
    up_right = np.maximum(np.maximum(l_right, raise_to), 0.0)
    points: list[tuple[float, float]] = []
    for k, c in enumerate(cuts):
        points += [(float(c), float(up_right[k])), (float(c), float(up_left[k]))]
        if k + 1 == len(cuts):
            break
        a, b = l_left[k], l_right[k + 1]  # the profile from c to the next cut
        e, f = raise_to[k], raise_to[k + 1]
        if np.isfinite(a) and np.isfinite(b) and (a - e) * (b - f) < 0:
            t = (e - a) / ((b - a) - (f - e))
            points.append((float(c + t * (cuts[k + 1] - c)), float(a + t * (b - a))))
    thinned = _thinned(np.array(points), slack) if slack > 0 else np.array(points)
    closed = np.vstack([[bore, 0.0], thinned, [bore, 0.0]])
    keep = np.r_[True, np.linalg.norm(np.diff(closed, axis=0), axis=1) > 1e-9]
    return np.asarray(closed[keep])


def spec_blank_profile(spec: ImpellerSpec, surfaces: ImpellerSurfaces | None = None
                       ) -> NDArray[np.float64]:
    """The lathe-turned blank of an impeller spec, ``(k, 2)`` (r, z), mm.

    ``blank_profile`` of the spec's shroud contour, stock allowance, bore and hub
    contour, with the blades' true extent (``geometry.blank_envelope.blade_points``:
    every face of the main blades and splitters, round or cut edges, tips; not their
    camber lines, which the edges and the sides' corners reach beyond): the inlet face
    at their highest z plus the allowance, the outer diameter over the blades turned
    to their largest radius plus the allowance. The profile is then raised
    (``raised_profile``) to the blades and fillets dilated by the allowance
    (``dilated_top`` at radii ``STEP`` mm apart): every blade face, fillets at the
    rim and at the nose included, has the stock allowance of material over it (see
    ``STEP``).

    Parameters
    ----------
    spec : ImpellerSpec
        The impeller (contours, bore, stock allowance in mm).
    surfaces : ImpellerSurfaces, optional
        The spec's surfaces when already built (else built here).

    Returns
    -------
    (k, 2) float64
        Closed meridional polygon ``(r, z)``, mm (made once per geometry in a
        process, ``geometry.built_cache.derived``; a copy).
    """
    from geometry.built_cache import derived

    return derived(spec, "blank_profile", lambda: _spec_blank_profile(spec, surfaces))


def _spec_blank_profile(spec: ImpellerSpec, surfaces: ImpellerSurfaces | None
                        ) -> NDArray[np.float64]:
    """``spec_blank_profile``, made (not kept)."""
    from geometry.blank_envelope import blade_points, dilated_top
    from geometry.surfaces import build_surfaces

    surfaces = surfaces if surfaces is not None else build_surfaces(spec)
    blade, fillets = blade_points(surfaces)
    allowance = float(spec.stock_allowance)
    blade_top = float(blade[:, 1].max())
    blade_radius = float(blade[:, 0].max()) + allowance
    profile = blank_profile(spec.shroud_contour, allowance, spec.bore_radius,
                            spec.hub_contour, blade_top, blade_radius)
    both = np.vstack([blade, fillets])
    lo = math.floor((both[:, 0].min() - allowance) / STEP) * STEP - STEP
    hi = math.ceil((both[:, 0].max() + allowance) / STEP) * STEP + STEP
    radii = np.arange(lo, hi + 0.5 * STEP, STEP)
    top = dilated_top(both, allowance, radii)
    return raised_profile(profile, radii, top + SLACK, SLACK)
