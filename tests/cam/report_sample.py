"""A small synthetic chain output folder for the report tests (no chain run needed).

``write_sample(out)`` writes the contract layout of ``impeller-cam run`` with small,
hand-made JSON files, real PNGs (matplotlib), a real STL (a cylinder), real APT
files (``postproc.apt.write_apt``), NC text and a saved stock (``Stock.box``). The
numbers are arbitrary but distinct so a test can find each one on the page.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np

#: Text that must come out escaped (it is put in an event message and a tool name).
HOSTILE = '<script>alert("x")</script> & <b>bold</b>'


def png_bytes(width: int = 64, height: int = 48, seed: int = 0) -> bytes:
    """A small RGB PNG (matplotlib's writer)."""
    import matplotlib.image

    rng = np.random.default_rng(seed)
    image = rng.integers(0, 255, size=(height, width, 3), dtype=np.uint8)
    buffer = io.BytesIO()
    matplotlib.image.imsave(buffer, image, format="png")
    return buffer.getvalue()


def _json(path: Path, document: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=2) + "\n")


def _toolpath(name: str, z: float, n: int = 40) -> Any:
    from postproc.toolpath import MoveKind, Toolpath

    angle = np.linspace(0.0, np.pi, n)
    tip = np.column_stack([20.0 * np.cos(angle), 20.0 * np.sin(angle), np.full(n, z)])
    axis = np.tile([0.0, 0.0, 1.0], (n, 1))
    kind = np.full(n, int(MoveKind.FEED), np.int8)
    kind[0] = int(MoveKind.RAPID)
    feed = np.where(kind == int(MoveKind.RAPID), np.nan, 1000.0)
    return Toolpath(tip, axis, feed, kind, name=name)


def run_json(stages: dict[str, str] | None = None) -> dict[str, Any]:
    """run.json with every stage done unless ``stages`` says otherwise."""
    names = ("geometry", "rough", "finish", "post", "verify", "motion", "report")
    status = {name: "done" for name in names}
    status["report"] = "not run"
    status.update(stages or {})
    return {
        "spec": "fixtures/impellers/sample/spec.toml",
        "machine": "fixtures/machines/xyzac-trt.toml",
        "tools": {"rough": "ball6", "finish": HOSTILE},
        "stages": [{"name": n, "status": status[n], "seconds": 1.25 + i, "peak_mb": 100.0 + i,
                    "outputs": [], "error": "boom <bad>" if status[n] == "failed" else None}
                   for i, n in enumerate(names)],
    }


def verify_json(events: list[dict[str, Any]], counts: dict[str, int],
                max_mm: float = 0.41) -> dict[str, Any]:
    return {
        "format": "impeller-cam verify", "version": 1,
        "programs": [{"name": "finish_hub.ngc", "blocks": 4}], "tool": "ball4",
        "initial_volume_mm3": 5000.25, "removed_volume_mm3": 1234.5,
        "remaining_volume_mm3": 3765.75, "resolution_mm": 0.25, "gouge_tolerance_mm": 0.02,
        "event_counts": {"stock_short": 0, "rapid_in_stock": 0, "holder_collision": 0, "gouge": 0,
                         "overtravel": 0, "excess": 0, **counts},
        "events": events,
        "deviation": {"samples": 1000, "min_mm": -0.0123, "max_mm": max_mm,
                      "mean_abs_mm": 0.0567, "allowance_mm": 0.8},
    }


def region_table(max_mm: float, limit: float) -> dict[str, Any]:
    return {"samples": 500, "machined_share": 0.9876, "max_mm": max_mm, "p99_mm": 0.3,
            "median_mm": 0.1, "min_mm": -0.01, "over_limit": int(max_mm > limit),
            "over_limit_share": 0.002 * (max_mm > limit), "within_limit": max_mm <= limit}


def regions_json(hub_max: float) -> dict[str, Any]:
    """verify/regions.json: finish limit 0.82 mm (allowance 0.8 + tolerance 0.02)."""
    def summary(allowance: float, hub: float) -> dict[str, Any]:
        limit = allowance + 0.02
        lathe_limit = 1.0 + 0.02
        milled = {"hub": region_table(hub, limit), "hub_near_fillet": region_table(0.5, limit),
                  "pressure": region_table(0.3456, limit),
                  "suction": region_table(0.2345, limit)}
        lathe = {"back": region_table(0.5, lathe_limit),
                 "hub_outside_blades": region_table(1.7531, lathe_limit)}
        accepted = all(t["within_limit"] for t in milled.values())
        return {"allowance_mm": allowance, "tolerance_mm": 0.02, "limit_mm": limit,
                "lathe_allowance_mm": 1.0, "lathe_limit_mm": lathe_limit,
                "near_fillet_mm": 2.0, "samples": 2500, "gouge": False, "min_mm": -0.01,
                "stock_short_samples": 0, "stock_short_max_mm": 0.0,
                "roles": {**milled, **lathe}, "acceptance": milled, "lathe": lathe,
                "failed": sorted(k for k, t in milled.items() if not t["within_limit"]),
                "accepted": accepted}
    return {"format": "impeller-cam regions 2", "resolution_mm": 0.25,
            "finish_ball_radius_mm": 2.0, "rough": summary(1.3, 1.0),
            "finish": summary(0.8, hub_max)}


def indexing_json() -> dict[str, Any]:
    """motion.json "indexing" as the chain's motion stage writes it (cam.run.motion)."""
    case = {"positioning_time_s": 0.2384, "access_time_s": 0.1222, "settling_time_s": 0.1163,
            "amax_up_mm_s2": 30000.0, "amax_down_mm_s2": 30000.0, "vmax_mm_s": 500.0,
            "s_factor": 22.0}
    best = {"positioning_time_s": 0.1487, "access_time_s": 0.1487, "settling_time_s": 0.0,
            "amax_up_mm_s2": 30000.0, "amax_down_mm_s2": 20000.0, "vmax_mm_s": 500.0,
            "s_factor": 115.0}
    symmetric = dict(best, positioning_time_s=0.1536, amax_down_mm_s2=30000.0)
    return {
        "index_moves": 12, "machine_time_s": 7.654, "longest_move_s": 0.9876,
        "largest_A_deg": 91.69, "largest_C_deg": 60.0, "stroke_mm": 50.0,
        "stroke_basis": "longest X/Y/Z travel", "grid": "coarse", "grid_note": "coarse grid",
        "case_I_s": 0.2384, "best_symmetric_s": 0.1536, "best_asymmetric_s": 0.1487,
        "chosen": "best_asymmetric", "chosen_profile": best,
        "improvement_vs_case_I": 0.3763, "total_case_I_s": 2.8608, "total_chosen_s": 1.7844,
        "optimisation": {"stroke_mm": 50.0,
                         "positioning_time_s": {"best": 0.1487, "best_symmetric": 0.1536,
                                                "case_max": 0.2384},
                         "best": best, "best_symmetric": symmetric, "case_max": case,
                         "grid": {"s_factor": {"first": 0.0, "last": 115.0, "count": 24}}},
        "plots": ["indexing.png"],
    }


def write_sample(out: Path, *, finish_events: list[dict[str, Any]] | None = None,
                 max_mm: float = 0.41) -> Path:
    """Write the synthetic chain folder into ``out`` and return ``out``; ``max_mm`` is
    the largest deviation after finishing (whole part and hub)."""
    import trimesh

    from cam.verify.stock import Stock
    from postproc.apt import write_apt

    out.mkdir(parents=True, exist_ok=True)
    _json(out / "run.json", run_json())
    # geometry
    _json(out / "geometry/geometry.json", {"blades": 6, "d_min_mm": 8.1234, "r_max_mm": 3.1301})
    (out / "geometry/impeller.png").write_bytes(png_bytes(seed=1))
    cylinder = trimesh.creation.cylinder(radius=25.0, height=10.0, sections=24)
    cylinder.apply_translation([0.0, 0.0, 5.0])
    cylinder.export(out / "geometry/impeller.stl")
    # rough
    _json(out / "rough/rough.json", {
        "tool": {"name": "ball6", "diameter_mm": 6.0}, "d_min_mm": 8.1234,
        "umrs": [{"index": 1, "lane": 0, "A_deg": -91.6938, "C_deg": -90.7286,
                  "alpha_deg": -156.7312, "beta_deg": -88.1562, "area_mm2": 352.0587,
                  "time_min": {"500": 23.12, "1000": 11.587, "1500": 7.7427, "2000": 5.8205}},
                 {"index": 2, "lane": 1, "A_deg": 45.125, "C_deg": 12.5,
                  "alpha_deg": 1.0, "beta_deg": 2.0, "area_mm2": 10.0, "time_min": {}}],
        "time_min": {"3axis": {"500": 23.12, "1000": 11.587, "1500": 7.7427, "2000": 5.8205},
                     "5axis": {"500": 24.0011, "1000": 12.0144, "1500": 8.0189,
                               "2000": 6.0211}},
        "time_limited_min": {"3axis": {"500": 23.4327, "1000": 11.9135, "1500": 8.0859,
                                       "2000": 6.1814},
                             "5axis": {"500": 24.7414, "1000": 14.1464, "1500": 11.6696,
                                       "2000": 11.0687}},
    })
    write_apt(out / "rough/rough_umr1.apt", [_toolpath("rough_umr1", 12.0)])
    # finish
    _json(out / "finish/finish.json", {
        "tool": {"name": "ball4", "diameter_mm": 4.0}, "options": {"scallop_mm": 0.8},
        "summary": {"paths": 2, "reversals_before": {"A": 1, "C": 7},
                    "reversals_after": {"A": 0, "C": 0}},
        "paths": [{"name": "p0.hub.01", "operation": "hub", "passage": 0, "points": 28,
                   "reversals_before": {"A": 1, "C": 7}, "reversals_after": {"A": 0, "C": 0},
                   "plot": "plots/p0.hub.01.png"},
                  {"name": "p1.hub.01", "operation": "hub", "passage": 1, "points": 28,
                   "reversals_before": {"A": 0, "C": 0}, "reversals_after": {"A": 0, "C": 0}}],
    })
    write_apt(out / "finish/finish_hub.apt", [_toolpath("finish_hub", 8.0)])
    (out / "finish/plots").mkdir(parents=True, exist_ok=True)
    (out / "finish/plots/p0.hub.01.png").write_bytes(png_bytes(seed=2))
    # post
    (out / "nc").mkdir(parents=True, exist_ok=True)
    (out / "nc/rough_umr1.ngc").write_text("%\nG21 G90\nG0 Z50\nG1 X1 Y2 Z3 F1000\nM30\n%\n")
    (out / "nc/finish_hub.ngc").write_text("%\nG21 G90\nG0 Z50\nG1 X4.5 Y5 Z6 F800\nM30\n%\n")
    _json(out / "nc/post.json", {"post": "linuxcnc", "machine": "xyzac-trt.toml", "programs": [
        {"operation": "rough", "name": "rough_umr1", "apt": "rough/rough_umr1.apt",
         "nc": "nc/rough_umr1.ngc", "blocks": 6, "tool": "ball6"},
        {"operation": "finish", "name": "finish_hub", "apt": "finish/finish_hub.apt",
         "nc": "nc/finish_hub.ngc", "blocks": 6, "tool": "ball4"}]})
    # verify
    _json(out / "verify/rough/verify.json", verify_json([], {}, max_mm=0.9))
    (out / "verify/rough/stock_1_rough_umr1.png").write_bytes(png_bytes(seed=3))
    events = finish_events if finish_events is not None else [
        {"type": "gouge", "line": 4, "program": "finish_hub.ngc",
         "position_mm": [1.0, 2.0, 3.0], "amount": 0.0456, "message": HOSTILE}]
    counts: dict[str, int] = {}
    for event in events:
        kind = str(event["type"])
        counts[kind] = counts.get(kind, 0) + 1
    _json(out / "verify/finish/verify.json", verify_json(events, counts, max_mm=max_mm))
    _json(out / "verify/regions.json", regions_json(max_mm))
    for view in ("iso", "top", "front"):
        (out / f"verify/finish/deviation_{view}.png").write_bytes(png_bytes(seed=4))
    Stock.box(np.array([-5.0, -5.0, 0.0]), np.array([5.0, 5.0, 4.0]), 1.0).save(
        out / "verify/finish/stock.npz")
    # motion
    (out / "motion").mkdir(parents=True, exist_ok=True)
    (out / "motion/indexing.png").write_bytes(png_bytes(seed=5))
    (out / "motion/servo.png").write_bytes(png_bytes(seed=6))
    _json(out / "motion/motion.json", {
        "programs": [{"nc": "nc/rough_umr1.ngc", "operation": "rough", "cycle_time_s": 868.7,
                      "nominal_s": 586.9, "blocks": 6},
                     {"nc": "nc/finish_hub.ngc", "operation": "finish",
                      "cycle_time_s": 1950.2, "nominal_s": 1236.1, "blocks": 6}],
        "total_s": 2818.9,
        "total_nominal_s": 1823.0,
        "cycle_time_basis": "jerk-limited exact stop per block",
        "indexing": indexing_json(),
        "servo": {"program": "all finishing programs", "dt_s": 0.001,
                  "axis_models": {"X": "identified", "Z": "default: matched to X",
                                  "C": "identified"},
                  "kffp_machine": {"X": 100.0, "Z": 100.0, "C": 100.0},
                  "max_contour_um": 12.34,
                  "programs": [{"program": "nc/finish_hub.ngc", "blocks": 6,
                                "max_contour_um": 12.34, "rms_contour_um": 3.21,
                                "median_contour_um": 2.5, "worst_line": 4,
                                "max_tool_axis_deg": 0.012,
                                "max_contour_best_kffp_um": 4.56,
                                "rms_contour_best_kffp_um": 1.23,
                                "median_contour_best_kffp_um": 0.9,
                                "saturated_in_feed": ["C"],
                                "per_line": "contour_finish_hub.csv"}],
                  "plot": "servo.png"},
    })
    return out
