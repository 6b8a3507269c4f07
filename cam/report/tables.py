"""Report sections that are tables: UMRs, cycle times, indexing optimisation, servo.

Numbers come from rough/rough.json and motion/motion.json as written; keys the
report does not know are still shown (flattened into key/value rows with units
read from their suffix), so a richer JSON never loses information on the page.
"""

from __future__ import annotations

from typing import Any

from cam.report.html import Cell, Section, definition_table, figure, lack, missing, note, table
from cam.report.inputs import RunFolder

__all__ = ["FEEDS", "cycle_time_section", "flat_rows", "indexing_section", "label_of",
           "record_tables", "servo_section", "umr_section"]

#: The four feeds of the cycle-time table (the paper's Table 1), mm/min.
FEEDS = ("500", "1000", "1500", "2000")
#: Key suffix -> unit, longest first.
UNITS = (("_mm_s2", "mm/s²"), ("_rad_s", "rad/s"), ("_mm_s", "mm/s"), ("_mm2", "mm²"),
         ("_mm3", "mm³"), ("_percent", "%"), ("_deg", "deg"), ("_min", "min"),
         ("_mm", "mm"), ("_mb", "MB"), ("_s", "s"))


#: Labels of keys the motion stage writes (others: ``label_of``'s generic rule).
LABELS = {
    "kffp_best": "Best K_FFP (%)", "max_deviation_mm": "Largest tool-tip deviation (mm)",
    "rms_deviation_mm": "RMS tool-tip deviation (mm)", "program": "NC program",
    "worst_line": "NC line of the largest deviation", "stroke_mm": "Index stroke (mm)",
    "improvement_vs_case_max": "Improvement over case I (fraction)",
    "chosen": "Chosen profile", "profiles": "Profiles searched",
    "best": "best (asymmetric allowed)", "best_symmetric": "best symmetric",
    "case_max": "case I (all maxima)", "chosen_profile": "chosen profile",
    "index_moves": "A/C index moves in the rough programs",
    "machine_time_s": "All index moves, machine limits (s)",
    "longest_move_s": "Longest index move (s)", "largest_A_deg": "Largest A turn (deg)",
    "largest_C_deg": "Largest C turn (deg)", "stroke_basis": "Stroke basis",
    "plant": "Table model", "grid": "Search grid", "grid_note": "Search grid note",
    "case_I_s": "Case I positioning time (s)",
    "best_symmetric_s": "Best symmetric positioning time (s)",
    "best_asymmetric_s": "Best asymmetric positioning time (s)",
    "improvement_vs_case_I": "Improvement over case I (fraction)",
    "total_case_I_s": "All index moves, case I (s)",
    "total_chosen_s": "All index moves, chosen profile (s)", "optimisation": "search",
    "dt_s": "Simulation step (s)", "reference_axis": "Reference axis",
    "omega_rad_s": "Characteristic angular velocity (rad/s)",
    "max_deviation_best_kffp_mm": "Largest deviation with Best K_FFP (mm)",
    "rms_deviation_best_kffp_mm": "RMS deviation with Best K_FFP (mm)",
    "ideal_axes": "Axes without servo data (follow the command)",
    "max_contour_um": "Largest contour error, all programs (um)",
    "max_contour_best_kffp_um": "Largest contour error with Best K_FFP, all programs (um)",
    "kffp_machine": "Machine K_FFP (%)", "saturated": "Torque saturation", "note": "Note",
}


def label_of(key: str) -> str:
    """``"max_deviation_mm"`` -> ``"max deviation (mm)"``; ``"a.b_s"`` -> ``"a / b (s)"``;
    known keys (``LABELS``) by name, also as the first part of a dotted key."""
    head, _, rest = key.partition(".")
    if head in LABELS:
        return LABELS[head] + (f" / {label_of(rest)}" if rest else "")
    unit = ""
    for suffix, name in UNITS:
        if key.endswith(suffix):
            key, unit = key[: -len(suffix)], name
            break
    text = key.replace(".", " / ").replace("_", " ")
    return f"{text} ({unit})" if unit else text


def flat_rows(document: dict[str, Any], prefix: str = "",
              skip: tuple[str, ...] = ()) -> list[tuple[str, Cell]]:
    """Scalars of a nested dict as (label, value) rows; lists of scalars joined."""
    rows: list[tuple[str, Cell]] = []
    for key, value in document.items():
        if key in skip:
            continue
        name = f"{prefix}{key}"
        if isinstance(value, dict) and set(value) == {"first", "last", "count"}:
            rows.append((label_of(name), f"{_short(value['first'])} .. "
                         f"{_short(value['last'])} ({_short(value['count'])} values)"))
        elif isinstance(value, dict):
            rows += flat_rows(value, f"{name}.")
        elif isinstance(value, list):
            if all(not isinstance(v, dict | list) for v in value):
                rows.append((label_of(name), ", ".join(_short(v) for v in value)))
        elif isinstance(value, bool):
            rows.append((label_of(name), "yes" if value else "no"))
        else:
            rows.append((label_of(name), value))
    return rows


def record_tables(document: dict[str, Any], skip: tuple[str, ...] = ()) -> list[str]:
    """Lists of JSON objects in ``document`` as tables (one column per scalar key, in
    first-seen order); what ``flat_rows`` leaves out."""
    out = []
    for key, value in document.items():
        if key in skip or not isinstance(value, list) or not value or \
                not all(isinstance(v, dict) for v in value):
            continue
        columns: list[str] = []
        for record in value:
            columns += [k for k, v in record.items() if k not in columns
                        and not isinstance(v, dict | list)]
        rows: list[list[Cell]] = [[_cell_value(record.get(c)) for c in columns]
                                  for record in value]
        out.append(table([label_of(c) for c in columns], rows, digits=4,
                         caption=label_of(key)))
    return out


def _yes_no(value: Any) -> str | None:
    return None if value is None else ("yes" if value else "no")


def _cell_value(value: Any) -> Cell:
    if value is None or isinstance(value, int | float | str):
        return value
    return _short(value)


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _pngs(document: Any) -> list[str]:
    """File names ending in .png anywhere in a JSON value, in document order."""
    if isinstance(document, str):
        return [document] if document.lower().endswith(".png") else []
    if isinstance(document, dict):
        return [p for v in document.values() for p in _pngs(v)]
    if isinstance(document, list):
        return [p for v in document for p in _pngs(v)]
    return []


def _motion_png(folder: RunFolder, name: str) -> str:
    return name if name.startswith("motion/") else f"motion/{name}"


def umr_section(folder: RunFolder) -> Section:
    """Section 7: the UMRs of the roughing plan with their A/C (rough.json "umrs")."""
    rough = folder.json("rough/rough.json")
    if rough is None:
        text = folder.why_missing("rough/rough.json")
        return Section("umr", "Unit machining regions (UMR)", missing(text), [text])
    umrs = [u for u in rough.get("umrs") or [] if isinstance(u, dict)]
    rows: list[list[Cell]] = []
    for u in umrs:
        times = u.get("time_min") or {}
        rows.append([u.get("index"), u.get("lane"), u.get("A_deg"), u.get("C_deg"),
                     u.get("alpha_deg"), u.get("beta_deg"), u.get("area_mm2"),
                     *[times.get(f) for f in FEEDS]])
    parts = []
    if rows:
        parts.append(table(["UMR", "Lane", "A (deg)", "C (deg)", "alpha (deg)", "beta (deg)",
                            "Floor area (mm²)", *[f"time at {f} (min)" for f in FEEDS]],
                           rows))
    else:
        parts.append(missing("rough/rough.json lists no UMRs"))
    context: list[tuple[str, Cell]] = [
        (label, rough.get(key)) for key, label in (
            ("d_min_mm", "Minimum passage width d_min (mm)"),
            ("r_max_mm", "Largest ball radius r_max (mm)"),
            ("finishing_allowance_mm", "Finishing allowance (mm)"),
            ("min_allowance_mm", "Smallest allowance left by roughing (mm)"),
            ("passage_floor_mm2", "Passage floor area (mm²)"),
            ("covered_floor_mm2", "Floor area covered by UMRs (mm²)"),
            ("collisions", "3+2 collisions found (python-fcl)"),
            ("min_clearance_mm", "Smallest shank/holder clearance (mm)"))
        if key in rough]
    tool = rough.get("tool")
    if isinstance(tool, dict):
        context.insert(0, ("Roughing tool", f"{tool.get('name')} (D {tool.get('diameter_mm')}"
                                            " mm)"))
    parts.append(definition_table(context))
    parts.append(note("A and C: the machine's inverse kinematics for each UMR's fixed tool "
                      "axis (passage 0); time: nominal minutes of the UMR over all passages. "
                      "From rough/rough.json \"umrs\"."))
    return Section("umr", "Unit machining regions (UMR)", "\n".join(parts))


def _comparison_table(nominal: dict[str, Any], limited: dict[str, Any],
                      paper: dict[str, Any]) -> list[str]:
    """Table 1 of the paper for a ``rough --compare`` run: 3+2 vs five-axis by feed."""
    rows: list[list[Cell]] = []
    for f in FEEDS:
        rows.append([int(f), (nominal.get("3axis") or {}).get(f),
                     (nominal.get("5axis") or {}).get(f),
                     (limited.get("3axis") or {}).get(f) if limited else None,
                     (limited.get("5axis") or {}).get(f) if limited else None,
                     (paper.get("3axis") or {}).get(f), (paper.get("5axis") or {}).get(f)])
    return [table(["Feed (mm/min)", "3-axis UMR (min)", "5-axis (min)",
                   "3-axis UMR, machine limits (min)", "5-axis, machine limits (min)",
                   "Paper: 3-axis UMR (min)", "Paper: 5-axis (min)"], rows, digits=2,
                  caption="Roughing time: 3+2 UMR roughing vs simultaneous 5-axis "
                          "roughing of the same regions"),
            note("From rough/rough.json: \"time_min\" (nominal: path length / "
                 "feed, rapids at the axis velocity limits), \"time_limited_min\" "
                 "(the machine's velocity, acceleration and jerk limits and A/C "
                 "indexing), \"paper_table1_min\" (the paper's Table 1, for "
                 "comparison; a different impeller).")]


def cycle_time_section(folder: RunFolder) -> Section:
    """Section 8: 3-axis UMR vs 5-axis roughing times at four feeds; program times."""
    parts: list[str] = []
    lost: list[str] = []
    rough = folder.json("rough/rough.json")
    if rough is None:
        lack(parts, lost, folder.why_missing("rough/rough.json"))
    else:
        nominal = rough.get("time_min") or {}
        limited = rough.get("time_limited_min") or {}
        paper = rough.get("paper_table1_min") or {}
        if "5axis" in nominal:
            parts += _comparison_table(nominal, limited, paper)
        else:  # the chain's main job: no research baseline
            rows: list[list[Cell]] = [
                [int(f), (nominal.get("3axis") or {}).get(f),
                 (limited.get("3axis") or {}).get(f) if limited else None] for f in FEEDS]
            parts.append(table(["Feed (mm/min)", "3-axis UMR (min)",
                                "3-axis UMR, machine limits (min)"], rows, digits=2,
                               caption="Roughing time of the 3+2 UMR plan"))
            parts.append(note("From rough/rough.json \"time_min\" (nominal: path length / "
                              "feed, rapids at the axis velocity limits) and "
                              "\"time_limited_min\" (the machine's limits and A/C "
                              "indexing). The comparison with simultaneous five-axis "
                              "roughing (the paper's Table 1) is made by `impeller-cam "
                              "rough --compare`."))
    motion = folder.json("motion/motion.json")
    if motion is None:
        lack(parts, lost, folder.why_missing("motion/motion.json"))
    else:
        programs = [p for p in motion.get("programs") or [] if isinstance(p, dict)]

        def share(p: dict[str, Any]) -> Cell:
            value = p.get("air_share")
            return 100.0 * value if isinstance(value, int | float) else None

        rows = [[str(p.get("nc", p.get("name", ""))), str(p.get("operation", "")),
                 p.get("blocks"), p.get("nominal_s"), p.get("cycle_time_s"),
                 p.get("cutting_s"), p.get("air_s"), share(p), p.get("rotary_link_s"),
                 p.get("exact_stop_s")] for p in programs]
        total = motion.get("total_s")
        rows.append(["total", "", None, motion.get("total_nominal_s"), total,
                     _total(programs, "cutting_s"), _total(programs, "air_s"), None,
                     _total(programs, "rotary_link_s"), motion.get("total_exact_stop_s")])
        parts.append(table(["NC program", "Operation", "Blocks", "Nominal (s)",
                            "Cycle time (s)", "Cutting (s)", "Air (s)", "Air (%)",
                            "Rotary links (s)", "Exact stop (s)"], rows, digits=1,
                           caption="NC program cycle times"))
        basis = motion.get("cycle_time_basis")
        parts.append(note("From motion/motion.json \"programs\" and \"total_s\": cycle time "
                          "= look-ahead blending within the program's path tolerance under "
                          "the machine's axis limits; air = rapids, approaches, departures "
                          "and links (rotary links: rapids that turn A or C); exact stop = "
                          "a stop at every block (upper bound); nominal = length / feed"
                          + (f" (basis: {basis})." if basis else ".")))
    return Section("cycle-time", "Cycle time", "\n".join(parts), lost)


def _total(programs: list[dict[str, Any]], key: str) -> Cell:
    """Sum of ``key`` over the programs, or None when a program lacks it."""
    values = [p.get(key) for p in programs]
    if not values or not all(isinstance(v, int | float) for v in values):
        return None
    return float(sum(v for v in values if isinstance(v, int | float)))


def _candidates(document: dict[str, Any], prefix: str = "", depth: int = 2
                ) -> list[tuple[str, dict[str, Any]]]:
    """(key path, profile) of the dicts holding ``positioning_time_s``, depth first."""
    found: list[tuple[str, dict[str, Any]]] = []
    for key, value in document.items():
        if not isinstance(value, dict):
            continue
        if "positioning_time_s" in value and not isinstance(value["positioning_time_s"], dict):
            found.append((f"{prefix}{key}", value))
        elif depth > 1:
            found += _candidates(value, f"{prefix}{key}.", depth - 1)
    return found


def _without(document: dict[str, Any], paths: set[str], prefix: str = "") -> dict[str, Any]:
    """``document`` without the entries at the given dotted key paths."""
    out: dict[str, Any] = {}
    for key, value in document.items():
        path = f"{prefix}{key}"
        if path in paths:
            continue
        out[key] = _without(value, paths, f"{path}.") if isinstance(value, dict) else value
    return out


def indexing_section(folder: RunFolder) -> Section:
    """Section 9: the S-curve optimisation of the A/C index moves (motion.json "indexing")."""
    return _motion_part(folder, "indexing", "Indexing-time optimisation", _indexing_body)


#: Order of the indexing profiles (case I first, the chosen one last).
PROFILE_ORDER = ("case_max", "best_symmetric", "best", "chosen_profile")


def _indexing_body(folder: RunFolder, document: dict[str, Any]) -> list[str]:
    parts = []
    found = _candidates(document)
    found.sort(key=lambda kv: PROFILE_ORDER.index(kv[0].rsplit(".", 1)[-1])
               if kv[0].rsplit(".", 1)[-1] in PROFILE_ORDER else len(PROFILE_ORDER))
    rows: list[list[Cell]] = []
    listed: list[dict[str, Any]] = []
    for path, profile in found:
        name = label_of(path.rsplit(".", 1)[-1])
        if profile in listed:  # the chosen profile is one of the others: mark it
            rows[listed.index(profile)][0] = f"{rows[listed.index(profile)][0]} (chosen)"
            continue
        listed.append(profile)
        rows.append([name, profile.get("positioning_time_s"), profile.get("access_time_s"),
                     profile.get("settling_time_s"), profile.get("amax_up_mm_s2"),
                     profile.get("amax_down_mm_s2"), profile.get("vmax_mm_s"),
                     profile.get("s_factor")])
    if rows:
        parts.append(table(["Profile", "Positioning time (s)", "Access (s)", "Settling (s)",
                            "Amax up (mm/s²)", "Amax down (mm/s²)", "Vmax (mm/s)",
                            "S factor"], rows, digits=(0, 4, 4, 4, 0, 0, 1, 1),
                           caption="Positioning time of one index move"))
    if not rows:
        reason = document.get("note") or "motion.json \"indexing\" holds no profile results"
        parts.append(missing(f"No S-curve optimisation of the index moves: {reason}"))
    hidden = {path for path, _ in found} | {k for k, v in document.items() if v is None}
    if not rows:
        hidden.add("note")  # said in the notice above
    hidden |= {f"{path.rsplit('.', 1)[0]}.positioning_time_s" for path, _ in found
               if "." in path} | ({"positioning_time_s"} if found else set())
    rest = _without(document, hidden)
    other = flat_rows(rest, skip=("plot", "plots"))
    if other:
        parts.append(definition_table(other, digits=4))
    parts += record_tables(rest)
    parts.append(note("From motion/motion.json \"indexing\": positioning time = access "
                      "(S-curve move) + settling of the two-mass table model; case I = all "
                      "maxima at the default S factor; best symmetric (Amax up = Amax down) "
                      "and best asymmetric profiles from the grid search."))
    return parts


def servo_section(folder: RunFolder) -> Section:
    """Section 10: predicted contour error of the finishing programs (all axes modelled).

    A result from a partly modelled machine (an older ``motion.json`` whose
    ``ideal_axes`` followed their command) is not shown: its numbers and figure turn
    the modelled axes' lag into contour error.
    """
    title = "Predicted servo deviation"
    motion = folder.json("motion/motion.json")
    document = motion.get("servo") if isinstance(motion, dict) else None
    if isinstance(document, dict) and document.get("ideal_axes"):
        axes = ", ".join(str(a) for a in document["ideal_axes"])
        text = (f"motion/motion.json \"servo\" comes from a partly modelled machine (axes "
                f"{axes} followed their command): not shown; rerun the motion stage")
        return Section("servo", title, missing(text), [text])
    return _motion_part(folder, "servo", title, _servo_body)


def _um(value: Any) -> Cell:
    return float(value) if isinstance(value, int | float) else None


def _servo_body(folder: RunFolder, document: dict[str, Any]) -> list[str]:
    parts: list[str] = []
    if document.get("program") is None:
        reason = document.get("note") or "no program simulated"
        parts.append(missing(f"No servo prediction: {reason} (motion/motion.json \"servo\")"))
        return parts
    programs = document.get("programs")
    if isinstance(programs, list) and programs:
        rows: list[list[Cell]] = []
        for p in programs:
            if not isinstance(p, dict):
                continue
            rows.append([str(p.get("program")), _um(p.get("max_contour_um")),
                         _um(p.get("rms_contour_um")), _um(p.get("median_contour_um")),
                         _um(p.get("max_contour_best_kffp_um")),
                         _um(p.get("rms_contour_best_kffp_um")),
                         _um(p.get("median_contour_best_kffp_um")),
                         _um(p.get("max_tool_axis_deg")), p.get("worst_line"),
                         ", ".join(p.get("saturated_in_feed") or []) or "none"])
        parts.append(table(["Program", "Max (um)", "RMS (um)", "Median (um)",
                            "Max, Best K_FFP (um)", "RMS, Best K_FFP (um)",
                            "Median, Best K_FFP (um)", "Max tool axis (deg)", "Worst line",
                            "Torque saturation in feed"], rows,
                           digits=(0, 1, 1, 1, 1, 1, 1, 3, 0, 0)))
        parts.extend(_on_the_part(programs))
    models, machine = document.get("axis_models"), document.get("kffp_machine")
    if isinstance(models, dict) and models:
        parts.append(table(["Axis", "Feed-drive model", "Machine K_FFP (%)"],
                           [[str(a), str(src), (machine or {}).get(a)]
                            for a, src in models.items()], digits=(0, 0, 2)))
    parts.append(definition_table(flat_rows(document, skip=(
        "plot", "plots", "programs", "axis_models", "kffp_machine")), digits=4))
    parts.append(note("From motion/motion.json \"servo\": every finishing program run "
                      "through the feed-drive models of all five axes (position loop, "
                      "Pre-Control K_FFP, velocity PI, torque limit); contour error = "
                      "distance of the simulated tool tip from the commanded tip path, "
                      "normal to it, largest per NC line (per line in motion/contour_*.csv); "
                      "Best K_FFP matches each axis' lag to the most lagging rotary axis. "
                      "The map shows each feed block's tip in the meridional plane."))
    return parts


def _on_the_part(programs: list[Any]) -> list[str]:
    """Where the error shapes the part (ball on the design surface) and the air blocks,
    apart (motion.json ``on_the_part``, ``cam.motion.surface_error``)."""
    rows: list[list[Cell]] = []
    for p in programs:
        part = p.get("on_the_part") if isinstance(p, dict) else None
        if not isinstance(part, dict):
            continue
        rows.append([str(p.get("program")), part.get("contact_blocks"),
                     _um(part.get("surface_max_um")), _um(part.get("surface_p99_um")),
                     _um(part.get("surface_median_um")),
                     _um(part.get("surface_best_kffp_max_um")),
                     _um(part.get("into_part_max_um")), part.get("air_blocks"),
                     _um(part.get("contour_air_max_um")),
                     part.get("air_blocks_error_over_gap")])
    if not rows:
        return []
    return [table(["Program", "Blocks on the part", "Normal to surface: max (um)",
                   "p99 (um)", "median (um)", "max, Best K_FFP (um)",
                   "into the part: max (um)", "Air blocks", "Air: max contour (um)",
                   "Air blocks with error > gap"], rows,
                  digits=(0, 0, 1, 1, 1, 1, 1, 0, 1, 0)),
            note("Blocks on the part: the commanded ball within 0.02 mm of the design "
                 "surface; there the part shows the ball centre's deviation along the "
                 "surface normal (a deviation along the surface leaves no mark; "
                 "into the part: a gouge, otherwise material left standing). Air "
                 "blocks (approaches, departures, links) keep their full contour error.")]


def _motion_part(folder: RunFolder, key: str, title: str, body: Any) -> Section:
    motion = folder.json("motion/motion.json")
    if motion is None:
        text = folder.why_missing("motion/motion.json")
        return Section(key, title, missing(text), [text])
    document = motion.get(key)
    if not isinstance(document, dict) or not document:
        text = f"motion/motion.json has no \"{key}\" result"
        return Section(key, title, missing(text), [text])
    parts: list[str] = body(folder, document)
    lost: list[str] = []
    names = _pngs({k: v for k, v in document.items() if k in ("plot", "plots")}) \
        or _pngs(document)
    for name in names:
        relative = _motion_png(folder, name)
        png = folder.png(relative)
        if png is None:
            lack(parts, lost, folder.why_missing(relative))
        else:
            parts.append(figure(png, relative, css="half"))
    return Section(key, title, "\n".join(parts), lost)
