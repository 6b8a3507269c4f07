"""The blades' true meridional extent and its revolved envelope dilated by an allowance.

A lathe-turned blank contains the design when, in every meridional half-plane, it
contains the (r, z) image of every face. The blades' faces (pressure and suction
sides, leading and trailing edges, round or cut, the tips and the rolling-ball
fillets, of the main blades and of the splitters) reach beyond their camber lines:
a round trailing edge by half the thickness past the camber end, the corner of a cut
trailing edge past the camber end's radius, a fillet by its radius along the hub past
the trailing edge. ``blade_points`` samples those faces from the closed-form
surfaces (the rolling-ball tracks, no B-rep: a fraction of a second) and
``dilated_top`` turns the points into the upper envelope, at a row of radii, of the
points dilated by the stock allowance: the height a blank must reach there to keep
the allowance over every blade face.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from geometry.surfaces import ImpellerSurfaces

__all__ = ["ARC_SAMPLES", "SPAN_SAMPLES", "TRACK_SAMPLES", "blade_points", "dilated_top"]

#: Samples along the span of a blade face (from the tip to the fillet contact).
SPAN_SAMPLES = 33
#: Samples across a fillet's circular cross-section.
ARC_SAMPLES = 17
#: Rolling-ball sections per outline segment kind (``geometry.solids.SolidSampling``'s
#: defaults, as the solid is built; importing it would load OpenCASCADE).
TRACK_SAMPLES = {"side": 97, "cap": 13, "corner": 13, "face": 9}


def blade_points(surfaces: ImpellerSurfaces
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(r, z) of sample points of every blade face, mm: the blade and the fillets.

    The reference main blade and the reference splitter (the others are rotated
    copies: same meridional image) are sampled face by face as the solid is built
    (``geometry.assembly``): each outline segment from the tip down to its fillet's
    blade contact, and each fillet across its cross-section arcs.

    Parameters
    ----------
    surfaces : ImpellerSurfaces
        The closed-form surfaces of the spec (``geometry.surfaces.build_surfaces``).

    Returns
    -------
    blade : (n, 2) float64
        (r, z) of the lateral faces (sides, edges; their tip curves bound the tips).
    fillets : (f, 2) float64
        (r, z) of the fillet faces (empty without fillets).
    """
    from geometry.fillet import blade_tracks, fillet_grid
    from geometry.outline import blade_loop

    spec = surfaces.spec
    radius = float(spec.fillet_radius)
    tau = np.linspace(0.0, 1.0, SPAN_SAMPLES)
    chunks: list[NDArray[np.float64]] = []
    fillets: list[NDArray[np.float64]] = [np.zeros((0, 3))]
    for group in (surfaces.blades, surfaces.splitters):
        if not group:
            continue
        ref = group[0]
        outline = blade_loop(ref, spec.leading_edge, spec.trailing_edge)
        tracks = blade_tracks(ref, surfaces.hub, outline, radius, TRACK_SAMPLES)
        for segment, track in zip(outline, tracks, strict=True):
            grid = segment.point(track.p[:, None] * np.ones_like(tau),
                                 track.v[:, None] * tau[None, :])
            chunks.append(np.asarray(grid).reshape(-1, 3))
            chunks.append(track.blade_contact)
            if radius > 0:
                fillets.append(fillet_grid(track, radius, ARC_SAMPLES).reshape(-1, 3))
    return _meridional(np.vstack(chunks)), _meridional(np.vstack(fillets))


def _meridional(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """(r, z) ``(n, 2)`` of points ``(n, 3)``."""
    return np.column_stack([np.hypot(points[:, 0], points[:, 1]), points[:, 2]])


def dilated_top(points: NDArray[np.float64], allowance: float, radii: NDArray[np.float64]
                ) -> NDArray[np.float64]:
    """Highest z, at each radius, of the discs of radius ``allowance`` round ``points``.

    Parameters
    ----------
    points : (n, 2) float64
        (r, z), mm.
    allowance : float
        Disc radius, mm (> 0).
    radii : (m,) float64
        Increasing, evenly spaced radii, mm.

    Returns
    -------
    (m,) float64
        The envelope's height at each radius, mm; ``-inf`` where no disc reaches.
    """
    r, z = points[:, 0], points[:, 1]
    step = float(radii[1] - radii[0])
    nearest = np.rint((r - radii[0]) / step).astype(np.int64)
    top = np.full(len(radii), -np.inf)
    reach = int(np.ceil(allowance / step))
    for k in range(-reach, reach + 1):
        j = nearest + k
        ok = (j >= 0) & (j < len(radii))
        d = radii[j[ok]] - r[ok]
        near = np.abs(d) <= allowance
        np.maximum.at(top, j[ok][near], z[ok][near] + np.sqrt(allowance**2 - d[near]**2))
    return top
