"""Deviation of a verified stock from the design, face by face, and the verdict.

``verify.json`` gives one deviation summary for the whole part. Acceptance needs it
per face: every milled face (blade sides, hub between the blades, fillets, leading
and trailing edges, of main blades and splitters) must be left within allowance +
scallop (+ the verification's gouge tolerance), while the faces turned on the lathe
(back face, bore, rim, nose, the blank's skin over the blade tips, the hub upstream
of the leading and downstream of the trailing edge) keep the blank's stock allowance
and are listed apart. Every stock surface sample (a dexel end,
``Stock.surface_samples``) gets the role of its closest design triangle
(``Impeller.triangle_roles``); ``face_groups`` splits the samples into milled and
lathe groups: blade-side and hub samples within ``near_fillet`` of a fillet face are
their own milled groups (a ball larger than the fillet radius cannot reach there);
samples of a blade side or edge beyond the shroud envelope (``shroud_offset`` > 0) or
whose closest design point lies on a tip's edge (the skin's corner, which on a
leaning blade reaches slightly inside the envelope: 220 of nine_blade's suction-side
samples, up to 0.29 mm inside it and up to 0.55 mm from the design) are the skin over
the tips; so are those above the blades' highest point (``blade_top``: the blank's
flat inlet face is turned to it plus the stock allowance, ``geometry.blank``) and
beside the blades, over the passage (their foot on that height farther from the
design than the limit): before the shroud contour's inlet end the envelope test does
not see that skin (the splitter fixture, whose leading edge is a radial line at the
inlet: 149 samples whose closest face is a main blade's leading edge lay up to 2.0 mm
above its apex, z 52.80 mm, and up to 5.4 mm beside it, and judged the edge at 5.96
mm; the 49,000 samples of nine_blade's milled stock above its leading edges' apex all
lie over the edge, feet within 0.46 mm of it); and
those radially beyond the blades' largest radius (``blade_radius``):
the blank's outer diameter over the blades is turned to that radius plus the stock
allowance (``geometry.blank``), and a lathe finishes it. Beyond the shroud contour's
outlet end the envelope test does not see that skin: on nine_blade 3,410 of the
5,127 samples whose closest face is the cut trailing edge lay on it (up to 3.8 mm
from the design), while the cut face itself (r 104.1 to 105.6 mm: a flat cut across
the backswept blade, not a surface of revolution) is milled and stays judged.
The splitters' faces are groups of their own (``splitter_`` before the name:
``splitter_pressure``, ``splitter_suction``, ``splitter_fillet``,
``splitter_leading_edge``, ``splitter_trailing_edge``, their ``_near_fillet`` strips
and ``_beyond_shroud`` skin), judged against the same limit: every face of the design
carries its blade (``cam.run.blade_owner``), and the main blades' groups keep the
plain names. ``region_summary`` reports every group and the verdict: every milled
group within the limit, no gouge, no stock short of the design.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.run.blade_owner import splitter_points
from cam.run.meridional import passage_position, shroud_offset
from cam.verify.deviation import Deviation
from impeller_cam.threads import default_threads

__all__ = ["ACCEPTANCE_ROLES", "BLADE_ROLES", "LATHE_ROLES", "SPLITTER", "LabelledDesign",
           "blade_radius", "blade_top", "closest_roles", "face_groups",
           "near_faces", "on_tip_edge", "passage_position", "region_summary", "role_table",
           "shroud_offset"]

#: Roles whose surfaces are milled and acceptance checks: blade sides, hub (between
#: the blades), fillets, leading and trailing edges (of main blades and splitters).
ACCEPTANCE_ROLES = ("pressure", "suction", "hub", "fillet", "leading_edge", "trailing_edge")
#: Blade-side roles (split off beyond the shroud envelope).
BLADE_SIDES = ("pressure", "suction")
#: Blade roles whose samples beyond the shroud envelope are the skin over the tips.
TIP_SIDED = ("pressure", "suction", "leading_edge", "trailing_edge")
#: Roles whose samples next to a fillet are reported apart as well (``_near_fillet``).
FILLET_NEIGHBOURS = ("pressure", "suction", "hub")
#: Faces turned on the lathe, not milled: back face, bore, rim, hub nose, blade tips.
LATHE_ROLES = ("back", "bore", "rim", "nose", "shroud")
#: Roles of a blade's own faces: a splitter's are grouped apart (``SPLITTER`` + name).
BLADE_ROLES = ("pressure", "suction", "fillet", "leading_edge", "trailing_edge")
#: Prefix of the splitters' face groups.
SPLITTER = "splitter_"
#: A sample whose closest tip-face point is this close to its closest design point has
#: its foot on the tip's edge, mm (the two faces share the edge's vertices).
ON_EDGE = 1e-6
#: Samples per chunk of the closest-triangle query.
CHUNK = 50_000


def closest_roles(
    triangles: NDArray[np.float64], roles: NDArray[np.str_], points: NDArray[np.float64],
    candidates: int = 16,
) -> tuple[NDArray[np.str_], NDArray[np.float64]]:
    """Role of the closest triangle and the distance to it, for every point.

    Parameters
    ----------
    triangles : (t, 3, 3) float64
        Design triangles, mm (small: subdivide large ones first).
    roles : (t,) str
        Face role of every triangle.
    points : (n, 3) float64
        Query points, mm.
    candidates : int
        Triangles (nearest centroids) examined per point.

    Returns
    -------
    role : (n,) str
    distance : (n,) float64
        Unsigned distance to the closest examined triangle, mm.
    """
    from geometry.mesh_query import closest_of_candidates

    triangles = np.ascontiguousarray(triangles, dtype=np.float64)
    tree = cKDTree(triangles.mean(axis=1))
    k = int(min(candidates, len(triangles)))
    normals = np.zeros((len(triangles), 3))  # unsigned: any normal
    out_role = np.empty(len(points), dtype=roles.dtype)
    out_dist = np.empty(len(points))
    for s in range(0, len(points), CHUNK):
        p = np.ascontiguousarray(points[s:s + CHUNK], dtype=np.float64)
        _, idx = tree.query(p, k=k, workers=default_threads())
        idx = np.ascontiguousarray(np.asarray(idx, np.int64).reshape(len(p), k))
        dist, pick = closest_of_candidates(p, idx, triangles, normals, 0.0)
        out_role[s:s + CHUNK] = roles[pick]
        out_dist[s:s + CHUNK] = np.abs(dist)
    return out_role, out_dist


def _nearest_within(centroids: NDArray[np.float64], points: NDArray[np.float64],
                    bound: float) -> NDArray[np.float64]:
    """Distance (n,) from each point to the nearest centroid, mm, where it is at most
    ``bound``; larger (possibly ``inf``) elsewhere.

    The search stops at the bound (a point far from every centroid costs the most
    without it: 10 us a point on nine_blade's fillets), split over the points; points
    whose cell test (``geometry.mesh_query.possibly_within``) puts every centroid
    beyond the bound are not searched (``inf``, as the bounded search answers them).
    """
    from geometry.mesh_query import possibly_within

    padded = np.nextafter(bound, np.inf) * (1.0 + 1e-12) + 1e-12
    nearest = np.full(len(points), np.inf)
    if not len(centroids) or not len(points):
        return nearest
    maybe = np.flatnonzero(possibly_within(np.ascontiguousarray(centroids, np.float64),
                                           np.ascontiguousarray(points, np.float64), padded))
    found, _ = cKDTree(centroids).query(points[maybe], k=1, distance_upper_bound=padded,
                                        workers=default_threads())
    nearest[maybe] = found
    return nearest


def near_faces(triangles: NDArray[np.float64], points: NDArray[np.float64], within: float,
               candidates: int = 16) -> NDArray[np.bool_]:
    """Whether each point lies closer than ``within`` (mm) to one of ``triangles``.

    Points whose nearest triangle centroid is farther than ``within`` plus the largest
    centroid-to-vertex distance cannot be that close and are answered without the
    exact query (most of a part's surface samples are far from its fillets); nor are
    those whose nearest centroid is closer than ``within``: that centroid's triangle
    is among the candidates and no farther from the point than its centroid (the
    answer of the exact query, found without it).

    Parameters
    ----------
    triangles : (t, 3, 3) float64
    points : (n, 3) float64
    """
    out = np.zeros(len(points), dtype=bool)
    if not len(triangles) or not len(points):
        return out
    centroids = triangles.mean(axis=1)
    reach = float(np.linalg.norm(triangles - centroids[:, None], axis=2).max())
    nearest = _nearest_within(centroids, points, within + reach)
    out[nearest < within] = True
    maybe = np.flatnonzero((nearest >= within) & (nearest <= within + reach))
    if len(maybe):
        _, distance = closest_roles(triangles, np.zeros(len(triangles), np.int8),
                                    points[maybe], candidates)
        out[maybe] = distance < within
    return out


def on_tip_edge(triangles: NDArray[np.float64], roles: NDArray[np.str_],
                points: NDArray[np.float64], distance: NDArray[np.float64]
                ) -> NDArray[np.bool_]:
    """Whether each point's closest design point lies on a blade tip (role ``shroud``).

    Parameters
    ----------
    triangles : (t, 3, 3) float64
        Design triangles, mm.
    roles : (t,) str
        Face role of every triangle.
    points : (n, 3) float64
        Blade-side samples, mm.
    distance : (n,) float64
        Their distance to the closest design triangle (``closest_roles``), mm.

    Returns
    -------
    (n,) bool
        True where the closest tip point is as close as the closest design point (to
        ``ON_EDGE``): the foot is on the edge a blade side shares with its tip.
    """
    out = np.zeros(len(points), dtype=bool)
    tips = triangles[roles == "shroud"]
    if not len(tips) or not len(points):
        return out
    # a tip triangle whose centroid is farther than distance + ON_EDGE + reach cannot
    # be that close: only points near a tip need the query (as in ``near_faces``)
    centroids = tips.mean(axis=1)
    reach = float(np.linalg.norm(tips - centroids[:, None], axis=2).max())
    nearest = _nearest_within(centroids, points, float(distance.max()) + ON_EDGE + reach)
    maybe = np.flatnonzero(nearest <= distance + ON_EDGE + reach)
    if len(maybe):
        _, to_tip = closest_roles(tips, np.full(len(tips), "shroud"), points[maybe])
        out[maybe] = to_tip <= distance[maybe] + ON_EDGE
    return out


def role_table(distance: NDArray[np.float64], limit: float, touched: NDArray[np.bool_]
               ) -> dict[str, Any]:
    """Summary of signed deviations (mm) of one group of samples against ``limit``."""
    if len(distance) == 0:
        return {"samples": 0, "limit_mm": limit}
    over = distance > limit
    return {
        "samples": int(len(distance)),
        "limit_mm": limit,
        "machined_share": round(float(touched.mean()), 4),
        "max_mm": round(float(distance.max()), 4),
        "p99_mm": round(float(np.percentile(distance, 99.0)), 4),
        "median_mm": round(float(np.median(distance)), 4),
        "min_mm": round(float(distance.min()), 4),
        "over_limit": int(over.sum()),
        "over_limit_share": round(float(over.mean()), 5),
        "within_limit": bool(not over.any()),
    }


class LabelledDesign:
    """The spec's design mesh (that of ``run_verify --design SPEC``) with face roles.

    Attributes
    ----------
    distance : DesignDistance
        Signed distance from the closed design mesh; the chain's verification runs use
        this same object, so their deviations carry the closest face of every sample.
    face_roles : (f,) str
        Face role of each triangle of the design mesh (``Impeller.triangle_roles``).
    face_splitter : (f,) bool
        Whether each triangle of the design mesh is a splitter's face (one of
        ``BLADE_ROLES`` whose centroid ``blade_owner.splitter_points`` places on a
        splitter); all False without splitters.
    triangles : (t, 3, 3) float64
        The design triangles subdivided to edges <= 2 mm (``distance.triangles``), mm.
    roles : (t,) str
        Face role of each of those.
    meridional : tuple
        Hub and shroud contours (z, r) and the blades' edge points on them (z, r),
        for ``passage_position``.
    """

    def __init__(self, spec: str | Path, impeller: Any = None) -> None:
        from cam.verify.deviation import DesignDistance
        from geometry.impeller import Impeller

        if impeller is None:
            impeller = Impeller.from_spec(spec)
        spec_ = impeller.spec
        edges = [c[[0, -1]][:, [2, 0]] for c in (spec_.hub_camber, spec_.shroud_camber)]
        self.meridional = (spec_.hub_contour, spec_.shroud_contour, edges[0], edges[1])
        mesh = impeller.mesh()
        self.face_roles = np.asarray(impeller.triangle_roles())
        faces = np.asarray(mesh.faces, np.int64)
        own = np.flatnonzero(np.isin(self.face_roles, BLADE_ROLES))
        self.face_splitter = np.zeros(len(self.face_roles), dtype=bool)
        centroids = np.asarray(mesh.vertices, np.float64)[faces[own]].mean(axis=1)
        self.face_splitter[own] = splitter_points(impeller.surfaces, centroids)
        self.distance = DesignDistance(np.asarray(mesh.vertices, np.float64),
                                       np.asarray(mesh.faces, np.int64))
        self.triangles = self.distance.triangles
        self.roles = self.face_roles[self.distance.source_face]


def blade_radius(design: LabelledDesign) -> float:
    """Largest radius of the blades' faces (sides, edges, tips), mm; ``inf`` without
    blade triangles.

    The outer diameter over the blades is turned to it (plus the stock allowance, by
    the blank; finished by a lathe): stock beyond it is lathe work.
    """
    faces = design.triangles[np.isin(design.roles, (*TIP_SIDED, "shroud"))]
    if not len(faces):
        return math.inf
    return float(np.hypot(faces[..., 0], faces[..., 1]).max())


def blade_top(design: LabelledDesign) -> float:
    """Highest z of the blades' faces (sides, edges, tips), mm; ``inf`` without blade
    triangles.

    The blank's inlet face is turned to it (plus the stock allowance, by the blank;
    finished by a lathe): stock of a blade face above it is lathe work.
    """
    faces = design.triangles[np.isin(design.roles, (*TIP_SIDED, "shroud"))]
    if not len(faces):
        return math.inf
    return float(faces[..., 2].max())


def face_groups(design: LabelledDesign, points: NDArray[np.float64],
                role: NDArray[np.str_], foot_distance: NDArray[np.float64],
                near_fillet: float, splitter: NDArray[np.bool_] | None = None,
                skin_gap: float = math.inf
                ) -> tuple[dict[str, NDArray[np.bool_]], dict[str, NDArray[np.bool_]]]:
    """Split stock samples into milled face groups and lathe face groups.

    Parameters
    ----------
    design : LabelledDesign
    points : (n, 3) float64
        Stock surface samples, mm.
    role : (n,) str
        Role of each sample's closest design face.
    foot_distance : (n,) float64
        Unsigned distance to that face, mm.
    near_fillet : float
        Width of the strips next to the fillets reported apart, mm.
    splitter : (n,) bool, optional
        Whether each sample's closest design face is a splitter's
        (``LabelledDesign.face_splitter``); default none.
    skin_gap : float
        A blade-side or edge sample above ``blade_top`` whose foot on the plane
        z = ``blade_top`` lies farther than this from the design is the blank's inlet
        face over the passage (lathe skin), mm; ``region_summary`` passes its limit
        (such a sample is farther than its foot from the design, so no sample within
        the limit moves; the milled stock on a leading edge's apex, over the edge,
        stays judged). Default: no such test.

    Returns
    -------
    milled, lathe : dict of str to (n,) bool
        Milled: ``pressure``, ``suction``, ``hub`` (between the blades' edges, away
        from the fillets), their ``<role>_near_fillet`` strips, ``fillet``,
        ``leading_edge``, ``trailing_edge``. Lathe: ``LATHE_ROLES``,
        ``hub_outside_blades`` (the axisymmetric inlet and outlet of the hub) and
        ``<role>_beyond_shroud`` (the blank's skin over the tips: samples of a blade
        side or edge beyond the shroud envelope, whose closest design point is on a
        tip's edge, above ``blade_top`` beside the blades (``skin_gap``) or radially
        beyond ``blade_radius``). The
        groups of a blade's own faces (``BLADE_ROLES``) hold the main blades' samples;
        the splitters' are the same names after ``SPLITTER``. Only groups with samples
        are listed.
    """
    triangles, labels = design.triangles, design.roles
    near = np.zeros(len(points), dtype=bool)
    checked = np.isin(role, FILLET_NEIGHBOURS)
    near[checked] = near_faces(triangles[labels == "fillet"], points[checked], near_fillet)
    hub = role == "hub"
    position = passage_position(points[hub], *design.meridional)
    between = np.zeros(len(points), dtype=bool)
    between[hub] = (position >= 0.0) & (position <= 1.0)
    beyond = np.zeros(len(points), dtype=bool)
    blade = np.isin(role, TIP_SIDED)
    hub_contour, shroud_contour = design.meridional[0], design.meridional[1]
    beyond[blade] = shroud_offset(points[blade], shroud_contour, hub_contour) > 0.0
    beyond[blade] |= on_tip_edge(triangles, labels, points[blade], foot_distance[blade])
    beyond[blade] |= np.hypot(points[blade, 0], points[blade, 1]) > blade_radius(design)
    top = blade_top(design)
    above = np.flatnonzero(blade & (points[:, 2] > top))
    if len(above) and math.isfinite(skin_gap):
        # over the passage, not over the edge: the foot of the sample on the plane of
        # the blades' top lies farther than ``skin_gap`` from the design
        foot = points[above].copy()
        foot[:, 2] = top
        beyond[above] |= np.abs(design.distance.closest(foot)[0]) > skin_gap
    on_splitter = np.zeros(len(points), dtype=bool) if splitter is None else splitter
    milled: dict[str, NDArray[np.bool_]] = {}
    lathe: dict[str, NDArray[np.bool_]] = {}

    def put(groups: dict[str, NDArray[np.bool_]], name: str, key: str,
            mask: NDArray[np.bool_]) -> None:
        if name not in BLADE_ROLES:
            groups[key] = mask
            return
        groups[key] = mask & ~on_splitter
        groups[SPLITTER + key] = mask & on_splitter

    for name in ACCEPTANCE_ROLES:
        sel = role == name
        inside = sel & (between if name == "hub" else ~beyond)
        if name in FILLET_NEIGHBOURS:
            put(milled, name, name, inside & ~near)
            put(milled, name, f"{name}_near_fillet", inside & near)
        else:
            put(milled, name, name, inside)
        if name == "hub":
            lathe["hub_outside_blades"] = sel & ~between
        elif name in TIP_SIDED:
            put(lathe, name, f"{name}_beyond_shroud", sel & beyond)
    for name in sorted(set(role.tolist()) - set(ACCEPTANCE_ROLES)):
        lathe[name] = role == name
    return ({k: v for k, v in milled.items() if v.any()},
            {k: v for k, v in lathe.items() if v.any()})


def region_summary(design: LabelledDesign, stock: str | Path | Deviation, allowance: float,
                   tolerance: float, near_fillet: float, lathe_allowance: float = 0.0
                   ) -> dict[str, Any]:
    """Per-face deviation of a verified stock from the spec's design, and the verdict.

    Parameters
    ----------
    design : LabelledDesign
        The design mesh with roles.
    stock : str, Path or Deviation
        The deviation of the final stock as the verification computed it
        (``run_verify(..., design_distance=design.distance)`` returns it), or a stock
        state written by ``run_verify`` (``stock.npz``), whose samples are measured here.
    allowance : float
        Material meant to remain on milled faces (allowance + scallop), mm.
    tolerance : float
        Verification tolerance added to the allowances (the gouge tolerance), mm.
    near_fillet : float
        Blade and hub samples closer than this to a fillet face are reported in
        groups of their own (``<role>_near_fillet``), mm: a ball of radius R > fillet
        radius cannot reach there.
    lathe_allowance : float
        Material the lathe-turned faces keep (the blank's stock allowance), mm.

    Returns
    -------
    dict
        ``limit_mm`` (allowance + tolerance); ``acceptance`` {group: table}
        (``role_table``) for every milled face group (``face_groups``: blade sides,
        hub between the blades, fillets, edges, the strips next to the fillets; the
        splitters' faces apart, ``splitter_<group>``);
        ``lathe`` {group: table} for the lathe-turned faces against
        ``lathe_limit_mm`` (``lathe_allowance`` + tolerance), listed, not judged;
        ``roles`` both together; ``gouge`` (a machined sample deeper than the
        tolerance inside the design); ``stock_short_samples`` and
        ``stock_short_max_mm`` (never machined samples deeper than the tolerance
        inside the design: the blank did not contain the part there);
        ``accepted``: every milled group within the limit, no gouge, no stock short.
    """
    if not isinstance(stock, Deviation) or stock.faces is None:
        from cam.verify.stock import Stock

        if isinstance(stock, Deviation):
            points, moves = stock.points, stock.moves
        else:
            points, moves = Stock.load(Path(stock)).surface_points()
        signed, faces = design.distance.closest(points)
        stock = Deviation(points, signed, moves, faces)
    assert stock.faces is not None
    points, signed, moves = stock.points, stock.distance, stock.moves
    role = design.face_roles[stock.faces]
    limit = allowance + tolerance
    milled, lathe = face_groups(design, points, role, np.abs(signed), near_fillet,
                                design.face_splitter[stock.faces], skin_gap=limit)
    lathe_limit = lathe_allowance + tolerance
    touched = moves >= 0
    acceptance = {name: role_table(signed[sel], limit, touched[sel])
                  for name, sel in milled.items()}
    turned = {name: role_table(signed[sel], lathe_limit, touched[sel])
              for name, sel in lathe.items()}
    # a gouge is material removed inside the design (as verify.json counts it); never
    # machined samples inside it are stock the blank lacked (verify's stock_short)
    gouge = bool(np.any(signed[touched] < -tolerance))
    unmachined = signed[~touched]
    short = unmachined[unmachined < -tolerance]
    return {
        "allowance_mm": allowance,
        "tolerance_mm": tolerance,
        "limit_mm": limit,
        "lathe_allowance_mm": lathe_allowance,
        "lathe_limit_mm": lathe_limit,
        "near_fillet_mm": near_fillet,
        "samples": int(len(points)),
        "gouge": bool(gouge),
        "min_mm": round(float(signed[touched].min()), 4) if touched.any() else None,
        "unmachined_min_mm": round(float(unmachined.min()), 4) if len(unmachined) else None,
        "stock_short_samples": int(len(short)),
        "stock_short_max_mm": round(float(-short.min()), 4) if len(short) else 0.0,
        "roles": {**acceptance, **turned},
        "acceptance": acceptance,
        "lathe": turned,
        "failed": sorted(name for name, t in acceptance.items() if not t["within_limit"]),
        "accepted": bool(acceptance and not gouge and not len(short)
                         and all(t["within_limit"] for t in acceptance.values())),
    }
