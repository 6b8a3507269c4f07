"""The import report: what was found in the file and how far the rebuilt blade is from it.

``import_report.json`` (all figures) and ``import_report.txt`` (a short summary):
blade count, splitter and its start, spans, units, edge shapes, the thickness law
fitted, the rule deviation of every span's mean line from the ruled surface through
the hub and shroud lines (and where it is largest), and -- when the file holds
section points (BladeGen) -- the largest distance from those points to the rebuilt
solid's surface (built without fillets, tessellated at ``SURFACE_TOLERANCE``; the
candidate triangles of each point are those with the nearest centroids).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from geometry.exchange.model import AeroBlading
from geometry.mesh_query import closest_point_on_triangle
from geometry.spec import ImpellerSpec

__all__ = ["SURFACE_TOLERANCE", "report_texts", "solid_distance", "surface_summary"]

Array = NDArray[np.float64]
#: Linear deflection (mm) of the mesh the section points are measured against.
SURFACE_TOLERANCE = 0.002
_CANDIDATES = 24


def solid_distance(spec: ImpellerSpec, points: Array) -> Array:
    """Distance (mm) of each of ``(n, 3)`` points to the spec's solid, ``(n,)``.

    The solid is built without fillets (the sections end at the hub, where a fillet
    would be).
    """
    from geometry.impeller import Impeller

    mesh = Impeller(spec, fillets=False).mesh(tolerance=SURFACE_TOLERANCE)
    triangles = np.asarray(mesh.triangles)
    tree = cKDTree(triangles.mean(axis=1))
    _, near = tree.query(points, k=min(_CANDIDATES, len(triangles)))
    repeated = np.repeat(points, near.shape[1], axis=0)
    foot = closest_point_on_triangle(repeated, triangles[near.ravel()])
    return np.asarray(np.linalg.norm(foot - repeated, axis=1).reshape(near.shape).min(axis=1))


def surface_summary(points: Array, spans: Array, dist: Array) -> dict[str, Any]:
    """JSON-ready summary of the section points' distances: overall and per span."""
    i = int(np.argmax(dist))
    per_span = [{"span": float(s), "max_mm": float(dist[spans == s].max()),
                 "mean_mm": float(dist[spans == s].mean())} for s in np.unique(spans)]
    return {"max_mm": float(dist[i]), "at": points[i].tolist(), "span": float(spans[i]),
            "mean_mm": float(dist.mean()), "points": len(points), "per_span": per_span}


def report_texts(blading: AeroBlading, spec: ImpellerSpec, facts: dict[str, Any],
                 surface: dict[str, Any] | None) -> dict[str, str]:
    """``import_report.json`` and ``import_report.txt`` texts."""
    main = blading.blades[0]
    data: dict[str, Any] = {
        "source": str(blading.source), "format": blading.format, "units": blading.unit,
        "blades": blading.blade_sets, "blades_per_set": len(blading.blades),
        "splitters": spec.splitters,
        "splitter_start": spec.splitter_start if spec.splitters else None,
        "spans": [float(s) for s in main.spans],
        "points_per_mean_line": [len(line) for line in main.mean_lines],
        "leading_edge": spec.leading_edge, "trailing_edge": spec.trailing_edge,
        **facts, "surface_distance": surface,
    }
    law = facts["thickness_law"]
    law_text = f"constant {law['mm']} mm" if law["kind"] == "constant" else \
        f"PCHIP through {law['knots']} knots, {law['min_mm']:.3f} to {law['max_mm']:.3f} mm"
    worst = max(facts["rule_deviation"], key=lambda d: d["mm"])
    lines = [
        f"imported {blading.source.name} ({blading.format}, units {blading.unit})",
        f"blades: {blading.blade_sets}" + (f" + {blading.blade_sets} splitters starting at "
                                           f"u = {spec.splitter_start:.4f}"
                                           if spec.splitters else ""),
        f"spans: {len(main.spans)} (" + ", ".join(f"{100 * s:.1f}%" for s in main.spans) + ")",
        f"edges: leading {spec.leading_edge}, trailing {spec.trailing_edge}",
        f"thickness law: {law_text} (spread over spans {facts['thickness_spread_mm']:.4f} mm)",
        "rule deviation per span (mm): " + ", ".join(
            f"{100 * d['span']:.0f}%: {d['mm']:.4f}" for d in facts["rule_deviation"]),
        f"largest rule deviation {worst['mm']:.4f} mm at span {100 * worst['span']:.0f}%, "
        f"u = {worst['u']:.3f}; blade is " + ("ruled" if facts["ruled"] else
                                               "not ruled (mid-span line written)"),
    ]
    if facts.get("splitter"):
        s = facts["splitter"]
        lines.append(f"splitter deviates {s['deviation_from_main_mm']:.4f} mm from the main "
                     "blade turned half a pitch")
    if surface is not None:
        lines.append(f"section points to the rebuilt solid: largest {surface['max_mm']:.4f} mm "
                     f"(span {100 * surface['span']:.0f}%), mean {surface['mean_mm']:.4f} mm "
                     f"({surface['points']} points, mesh deflection {SURFACE_TOLERANCE} mm, "
                     "no fillets); largest per span: " + ", ".join(
                         f"{100 * s['span']:.0f}%: {s['max_mm']:.4f}" for s in surface["per_span"]))
    lines += [f"note: {n}" for n in facts["notes"]]
    return {"import_report.json": json.dumps(data, indent=2, sort_keys=True) + "\n",
            "import_report.txt": "\n".join(lines) + "\n"}
