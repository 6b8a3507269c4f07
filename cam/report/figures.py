"""Report sections that are pictures: impeller, tool paths, stock, deviation, A/C plots.

Pictures the stages already wrote are reused (geometry/impeller.png, the verify
renders, finish/plots/*.png); the report renders only what no stage draws: the
tool paths over the impeller (``cam.report.renders``) and, when verify ran without
renders, the stock from its ``stock.npz``.
"""

from __future__ import annotations

import re
from pathlib import PurePosixPath
from typing import Any

import numpy as np

from cam.report.html import (
    Cell,
    Section,
    definition_table,
    figure,
    format_number,
    lack,
    missing,
    note,
    swatch_legend,
    table,
)
from cam.report.inputs import RunFolder

__all__ = ["FINISH_COLOURS", "ROUGH_COLOURS", "angles_section", "deviation_section",
           "operation_colour", "render_section", "stock_section", "toolpaths_section"]

#: Finishing operations and their colours (legend and picture).
FINISH_COLOURS = {"junction": "#d62728", "blade": "#2ca02c", "hub": "#ff7f0e", "edge": "#bcbd22",
                  "fillet": "#f0027f"}
#: Roughing UMR colours, cycled by UMR number.
ROUGH_COLOURS = ("#1f77b4", "#9467bd", "#17becf", "#8c564b", "#e377c2", "#393b79",
                 "#637939", "#7f7f7f")
OTHER_COLOUR = "#444444"
#: Angular displacement plots shown in full (the rest are listed).
MAX_ANGLE_PLOTS = 12
GEOMETRY_FIGURES = (
    ("blades", "Blades", ""), ("d_min_mm", "Minimum passage width d_min", "mm"),
    ("r_max_mm", "Largest ball radius r_max", "mm"),
    ("fillet_radius_mm", "Fillet radius", "mm"), ("min_thickness_mm", "Blade thickness", "mm"),
    ("area_mm2", "Surface area", "mm²"), ("volume_mm3", "Volume", "mm³"),
)


def operation_colour(stage: str, stem: str) -> tuple[str, str]:
    """Legend label and colour of an APT file: roughing per UMR, finishing per operation.

    >>> operation_colour("rough", "rough_umr2")
    ('roughing UMR 2', '#9467bd')
    >>> operation_colour("finish", "finish_hub")
    ('finishing hub', '#ff7f0e')
    """
    if stage == "rough":
        found = re.search(r"umr(\d+)", stem)
        if found:
            number = int(found.group(1))
            return f"roughing UMR {number}", ROUGH_COLOURS[(number - 1) % len(ROUGH_COLOURS)]
        return f"roughing {stem}", ROUGH_COLOURS[0]
    operation = stem.removeprefix("finish_")
    return f"finishing {operation}", FINISH_COLOURS.get(operation, OTHER_COLOUR)


def render_section(folder: RunFolder) -> Section:
    """Section 2: the impeller render and its main figures (geometry.json)."""
    parts: list[str] = []
    lost: list[str] = []
    png = folder.png("geometry/impeller.png")
    if png is None:
        lack(parts, lost, folder.why_missing("geometry/impeller.png"))
    else:
        parts.append(figure(png, "impeller, faces coloured by role (geometry/impeller.png)",
                            css="half"))
    figures = folder.json("geometry/geometry.json")
    if figures is None:
        lack(parts, lost, folder.why_missing("geometry/geometry.json"))
    else:
        rows: list[tuple[str, Cell]] = []
        for key, label, unit in GEOMETRY_FIGURES:
            value = figures.get(key)
            if isinstance(value, int | float):
                rows.append((f"{label} ({unit})" if unit else label, value))
        parts.append(definition_table(rows))
        parts.append(note("Figures from geometry/geometry.json."))
    body = '<div class="cols">' + "\n".join(parts) + "</div>"
    return Section("render", "Impeller", body, lost)


def _apt_files(folder: RunFolder) -> list[tuple[str, str]]:
    """(stage, relative APT path) of the roughing then finishing operations."""
    post = folder.json("nc/post.json") or {}
    listed = [(str(p.get("operation")), str(p.get("apt"))) for p in post.get("programs") or []
              if isinstance(p, dict) and p.get("apt")]
    if listed:
        return listed
    return [("rough", p) for p in folder.glob("rough/*.apt")] + \
        [("finish", p) for p in folder.glob("finish/*.apt")]


def path_layers(folder: RunFolder) -> tuple[dict[str, list[Any]], list[str]]:
    """Tool-tip layers by stage ("rough", "finish") from the APT files, and problems."""
    from cam.report.renders import PathLayer, cutting_runs
    from impeller_cam.errors import InputError
    from postproc.apt import read_apt
    from postproc.toolpath import MoveKind

    layers: dict[str, list[Any]] = {"rough": [], "finish": []}
    problems: list[str] = []
    for stage, relative in _apt_files(folder):
        if not folder.exists(relative):
            problems.append(folder.why_missing(relative))
            continue
        try:
            toolpaths = read_apt(folder.path(relative))
        except InputError as error:
            problems.append(f"cannot read {relative}: {error}")
            continue
        # a file per operation, or one file whose sections are the operations (the
        # roughing program: each UMR visit a section): one layer per UMR or operation
        by_label: dict[str, tuple[str, list[Any]]] = {}
        stem = PurePosixPath(relative).stem
        for tp in toolpaths:
            name = tp.name if stage == "rough" or len(toolpaths) > 1 else stem
            label, colour = operation_colour(stage, name)
            runs = cutting_runs(tp.tip, tp.kind != int(MoveKind.FEED))
            by_label.setdefault(label, (colour, []))[1].extend(runs)
        for label, (colour, runs) in by_label.items():
            layers.setdefault(stage, []).append(PathLayer(label, colour, runs))
    return layers, problems


def toolpaths_section(folder: RunFolder, render: bool = True) -> Section:
    """Section 3: tool tips of every operation over the impeller, with a legend."""
    parts: list[str] = []
    lost: list[str] = []
    stl = "geometry/impeller.stl"
    layers, problems = path_layers(folder)
    for problem in problems:
        lack(parts, lost, problem)
    if not any(layers.values()):
        notes = [n for n in (folder.stage_note("rough"), folder.stage_note("finish")) if n]
        lack(parts, lost, "no APT files in rough/ or finish/"
             + (f" ({'; '.join(notes)})" if notes else ""))
        return Section("toolpaths", "Tool paths", "\n".join(parts), lost)
    mesh = _mesh(folder, stl) if render else None
    if render and mesh is None:
        lack(parts, lost, folder.why_missing(stl))
    titles = {"rough": "Roughing (3+2, one colour per UMR)",
              "finish": "Finishing (5-axis, one colour per operation)"}
    for stage in ("rough", "finish"):
        stage_layers = layers.get(stage) or []
        if not stage_layers:
            lack(parts, lost, f"no {stage} tool paths")
            continue
        parts.append(f"<h3>{titles[stage]}</h3>")
        # one entry per label: a UMR's programs (one per visit) share its colour
        parts.append(swatch_legend(list(dict.fromkeys(
            (layer.label, layer.colour) for layer in stage_layers))))
        points = sum(len(r) for layer in stage_layers for r in layer.runs)
        if mesh is not None:
            from cam.report.renders import toolpath_png

            figs = [figure(toolpath_png(mesh[0], mesh[1], stage_layers, view=view),
                           f"{stage} tool tips, {view} view", css="half")
                    for view in ("iso", "top")]
            parts.append("".join(figs))
        parts.append(note(f"Tool tips of the feed moves ({points} points; rapids, plunges "
                          "and retracts not drawn; decimated for the picture) read from "
                          + ", ".join(sorted({rel for st, rel in _apt_files(folder)
                                              if st == stage})) + "."))
    return Section("toolpaths", "Tool paths", "\n".join(parts), lost)


def _mesh(folder: RunFolder, relative: str) -> tuple[np.ndarray, np.ndarray] | None:
    if not folder.exists(relative):
        return None
    import trimesh

    try:
        mesh = trimesh.load_mesh(folder.path(relative), file_type="stl")
    except (ValueError, OSError) as error:
        folder.problems[relative] = f"cannot read {relative}: {error}"
        return None
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def _last_stock_png(folder: RunFolder, stage: str) -> str | None:
    """verify/<stage>/stock_<i>_<program>.png with the largest i (after the last program)."""
    found = []
    for relative in folder.glob(f"verify/{stage}/stock_*.png"):
        match = re.match(r"stock_(\d+)_", PurePosixPath(relative).name)
        if match:
            found.append((int(match.group(1)), relative))
    return max(found)[1] if found else None


def stock_section(folder: RunFolder, render: bool = True) -> Section:
    """Section 4: the stock after roughing and after finishing, with its volumes."""
    parts: list[str] = []
    lost: list[str] = []
    figs: list[str] = []
    rows: list[list[Cell]] = []
    for stage, label in (("rough", "after roughing"), ("finish", "after finishing")):
        document = folder.json(f"verify/{stage}/verify.json")
        if document is not None:
            rows.append([label, document.get("initial_volume_mm3"),
                         document.get("removed_volume_mm3"),
                         document.get("remaining_volume_mm3"), document.get("resolution_mm")])
        png_path = _last_stock_png(folder, stage)
        png = folder.png(png_path) if png_path else None
        npz = f"verify/{stage}/stock.npz"
        if png is not None:
            figs.append(figure(png, f"stock {label} ({png_path})", css="half"))
        elif render and folder.exists(npz):
            from cam.report.renders import stock_png

            figs.append(figure(stock_png(folder.path(npz), f"stock {label}"),
                               f"stock {label} (rendered from {npz})", css="half"))
        else:
            lack(parts, lost, f"stock {label}: {folder.why_missing(npz)}")
    parts.append("".join(figs))
    if rows:
        parts.append(table(["Stock", "Initial volume (mm³)", "Removed (mm³)",
                            "Remaining (mm³)", "Dexel spacing (mm)"], rows,
                           digits=(0, 1, 1, 1, 3)))
        parts.append(note("Volumes from verify/rough/verify.json and "
                          "verify/finish/verify.json (tri-dexel stock; finishing starts "
                          "from the roughed stock)."))
    return Section("stock", "Stock after roughing and finishing", "\n".join(parts), lost)


def deviation_section(folder: RunFolder) -> Section:
    """Section 5: signed deviation of the stock from the design (maps and numbers)."""
    parts: list[str] = []
    lost: list[str] = []
    rows: list[list[Cell]] = []
    for stage in ("rough", "finish"):
        document = folder.json(f"verify/{stage}/verify.json")
        if document is None:
            continue
        dev = document.get("deviation") or {}
        rows.append([f"after {stage}ing", dev.get("min_mm"),
                     dev.get("max_mm"), dev.get("mean_abs_mm"), dev.get("allowance_mm"),
                     document.get("gouge_tolerance_mm"), dev.get("samples")])
    figs = []
    if folder.json("verify/finish/verify.json") is None and \
            not folder.glob("verify/finish/deviation_*.png"):
        lack(parts, lost, folder.why_missing("verify/finish/verify.json"))
    for view in ("iso", "top", "front"):
        relative = f"verify/finish/deviation_{view}.png"
        png = folder.png(relative)
        if png is None:
            if not lost:
                lack(parts, lost, folder.why_missing(relative))
        else:
            figs.append(figure(png, f"after finishing, {view} view ({relative})",
                               css="third"))
    parts.append("".join(figs))
    if rows:
        parts.append(table(["Stock", "Min (mm)", "Max (mm)", "Mean |d| (mm)",
                            "Allowance (mm)", "Gouge tolerance (mm)", "Samples"], rows,
                           digits=3))
    parts += _region_tables(folder)
    parts.append(note("Signed distance of the stock surface from the design: positive = "
                      "material left, negative = gouge (cut into the part). Colour bar in "
                      "mm, blue = gouge, red = material left. Numbers: verify/*/verify.json "
                      "\"deviation\"."))
    rough_iso = folder.png("verify/rough/deviation_iso.png")
    if rough_iso is not None:
        parts.append(figure(rough_iso, "after roughing, iso view "
                            "(verify/rough/deviation_iso.png)", css="third"))
    return Section("deviation", "Deviation from the design", "\n".join(parts), lost)


def _mm(value: Any) -> str:
    """A length from a JSON file for running text (3 decimals; as is when not a number)."""
    return format_number(value) if isinstance(value, int | float) else str(value)


def _region_tables(folder: RunFolder) -> list[str]:
    """Deviation per face role after roughing and finishing (verify/regions.json)."""
    regions = folder.json("verify/regions.json")
    if regions is None:
        return [note(f"No per-face figures: {folder.why_missing('verify/regions.json')}.")]
    parts = []
    for stage in ("finish", "rough"):
        summary = regions.get(stage)
        if not isinstance(summary, dict) or not isinstance(summary.get("roles"), dict):
            parts.append(missing(f"verify/regions.json has no \"{stage}\" table"))
            continue
        checked = set(summary.get("acceptance") or {})
        turned = set(summary.get("lathe") or {})
        rows: list[list[Cell]] = []
        for role, t in summary["roles"].items():
            if not isinstance(t, dict) or not t.get("samples"):
                continue
            share = t.get("machined_share")
            kind = "milled" if role in checked else "lathe" if role in turned else "no"
            rows.append([role, kind, t.get("samples"),
                         100.0 * share if isinstance(share, int | float) else None,
                         t.get("max_mm"), t.get("p99_mm"), t.get("median_mm"), t.get("min_mm"),
                         t.get("over_limit"), t.get("within_limit")])
        limit, allowance, tolerance = (_mm(summary.get(k)) for k in
                                       ("limit_mm", "allowance_mm", "tolerance_mm"))
        caption = (f"After {stage}ing, per face: limit {limit} mm = allowance {allowance} + "
                   f"tolerance {tolerance} mm on milled faces, "
                   f"{_mm(summary.get('lathe_limit_mm'))} mm on lathe faces; stock short: "
                   f"{summary.get('stock_short_samples', 'n/a')} samples; accepted: "
                   f"{'yes' if summary.get('accepted') else 'no'}")
        parts.append(table(["Face", "Checked", "Samples", "Machined (%)", "Max (mm)",
                            "99 % (mm)", "Median (mm)", "Min (mm)", "Over limit",
                            "Within limit"], rows, digits=(0, 0, 0, 1, 3, 3, 3, 3, 0, 0),
                           caption=caption))
    parts.append(note("From verify/regions.json: every stock surface sample takes the face "
                      "role of its closest design triangle. Milled faces (checked, all of "
                      "them in the verdict): blade sides, hub between the blades, fillets, "
                      "leading and trailing edges, and the strips of blade and hub next to "
                      "the fillets (\"_near_fillet\": within the finishing ball radius "
                      f"{_mm(regions.get('finish_ball_radius_mm'))} mm of a fillet). Lathe "
                      "faces (back, bore, rim, nose, the skin over the tips "
                      "\"_beyond_shroud\", the hub outside the blades) are turned, not "
                      "milled, and listed against the blank's stock allowance."))
    return parts


def angles_section(folder: RunFolder) -> Section:
    """Section 6: A/C angular displacement before and after smoothing (finish plots)."""
    parts: list[str] = []
    lost: list[str] = []
    finish = folder.json("finish/finish.json")
    if finish is None:
        lack(parts, lost, folder.why_missing("finish/finish.json"))
    entries = [p for p in (finish or {}).get("paths") or [] if isinstance(p, dict)]
    summary = (finish or {}).get("summary") or {}
    if summary:
        before, after = summary.get("reversals_before") or {}, summary.get("reversals_after") or {}
        parts.append(definition_table([
            ("Finishing paths", summary.get("paths")),
            ("A reversals before / after smoothing", f"{before.get('A')} / {after.get('A')}"),
            ("C reversals before / after smoothing", f"{before.get('C')} / {after.get('C')}"),
        ]))
    plotted = [e for e in entries if e.get("plot")]
    rows: list[list[Cell]] = []
    for e in plotted:
        b, a = e.get("reversals_before") or {}, e.get("reversals_after") or {}
        rows.append([str(e.get("name")), str(e.get("operation")), e.get("points"),
                     b.get("A"), a.get("A"), b.get("C"), a.get("C")])
    if rows:
        parts.append(table(["Path (passage 0)", "Operation", "Points", "A rev. before",
                            "A rev. after", "C rev. before", "C rev. after"], rows))
    # the most reversals first: those show what smoothing did
    order = sorted(plotted, key=lambda e: -sum((e.get("reversals_before") or {}).values()))
    shown = 0
    figs: list[str] = []
    for e in order:
        relative = f"finish/{e['plot']}"
        png = folder.png(relative)
        if png is None:
            lack(parts, lost, folder.why_missing(relative))
            continue
        if shown < MAX_ANGLE_PLOTS:
            figs.append(figure(png, f"{e.get('name')} ({relative})", css="third"))
            shown += 1
    if finish is not None and not plotted:
        files = folder.glob("finish/plots/*.png")
        for relative in files[:MAX_ANGLE_PLOTS]:
            png = folder.png(relative)
            if png is not None:
                figs.append(figure(png, relative, css="third"))
        if not files:
            lack(parts, lost, "finish/plots/ has no plots (finishing run without plots?)")
    parts.append("".join(figs))
    if len(plotted) > shown:
        parts.append(note(f"{len(plotted) - shown} more plots in finish/plots/ (the paths "
                          "with the most reversals are shown)."))
    parts.append(note("Each plot: increments of A (top) and C (bottom) between consecutive "
                      "tool path points, degrees, before (red, initial postures) and after "
                      "(blue, smoothed and remedied) smoothing. A reverse movement is a zero "
                      "crossing of a curve. Counts from "
                      "finish/finish.json (\"summary\", \"paths\"); passage 0 only, the other "
                      "passages are rotations of it."))
    return Section("angles", "A/C angular displacement before and after smoothing",
                   "\n".join(parts), lost)
