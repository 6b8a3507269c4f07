"""The lathe-turned blank of an impeller: its meridional profile.

One definition for every stage that needs the stock before milling: roughing plans
against it (``cam.roughing.stock.Blank``: which balls meet it, the surface its
stock maps start from) and verification simulates it (``cam.verify.sources``,
``--stock SPEC``). Until session 7 roughing had a blank of its own (the shroud
envelope's signed distance, closed by a ring out to the rim up to the shroud's
outlet height): it planned cuts in air around the trailing edges and knew a
slightly different stock than the one verification removes.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from geometry.spec import ImpellerSpec

__all__ = ["blank_profile", "spec_blank_profile"]


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


def spec_blank_profile(spec: ImpellerSpec) -> NDArray[np.float64]:
    """``blank_profile`` of an impeller spec : its
    shroud contour, stock allowance, bore, hub contour, and the blades' highest z
    and largest radius from their camber lines, ``(k, 2)`` (r, z), mm."""
    blade_top = float(max(spec.hub_camber[:, 2].max(), spec.shroud_camber[:, 2].max()))
    blade_radius = float(max(spec.hub_camber[:, 0].max(), spec.shroud_camber[:, 0].max()))
    return blank_profile(spec.shroud_contour, spec.stock_allowance, spec.bore_radius,
                         spec.hub_contour, blade_top, blade_radius)
