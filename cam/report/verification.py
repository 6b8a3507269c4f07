"""Report sections from run.json and the verification results: summary and events.

Numbers are copied from the JSON files (run.json, verify/*/verify.json,
finish.json); the only arithmetic is adding the per-stage event counts and
comparing the largest deviation with allowance + scallop, both stated on the page.
"""

from __future__ import annotations

import html
from pathlib import PurePosixPath
from typing import Any

from cam.report.html import (
    Cell,
    Section,
    checks_list,
    definition_table,
    format_number,
    missing,
    note,
    paragraph,
    table,
)
from cam.report.inputs import RunFolder
from cam.report.machine import machine_check, machine_clearance_part

__all__ = ["REGIONS", "VERIFY_RUNS", "events_section", "summary_checks", "summary_section"]

#: The two verification runs of the chain: (label, verify.json path).
VERIFY_RUNS = (("rough", "verify/rough/verify.json"), ("finish", "verify/finish/verify.json"))
#: Per-face deviation of the verified stocks (written by the chain's verify stage).
REGIONS = "verify/regions.json"
#: Event checks of the summary: (event type, what "no event" means).
EVENT_CHECKS = (
    ("stock_short", "No stock short of the design"),
    ("gouge", "No gouge"),
    ("holder_collision", "No shank/holder collision"),
    ("overtravel", "No over-travel"),
    ("rapid_in_stock", "No rapid move in stock"),
)
#: Stages listed in the stage table (the report stage is the one writing this page).
STAGE_ORDER = ("geometry", "rough", "finish", "post", "verify", "motion")


def _text(value: Any) -> str:
    if isinstance(value, dict):
        return ", ".join(f"{k}: {_text(v)}" for k, v in value.items())
    if isinstance(value, list):
        return ", ".join(_text(v) for v in value)
    return "" if value is None else str(value)


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value)


def _context_rows(folder: RunFolder) -> list[tuple[str, Cell]]:
    run = folder.run
    rough = folder.json("rough/rough.json") or {}
    finish = folder.json("finish/finish.json") or {}
    post = folder.json("nc/post.json") or {}
    geometry = folder.json("geometry/geometry.json") or {}
    impeller = run.get("impeller") or run.get("name")
    spec = run.get("spec") or rough.get("spec") or finish.get("spec")
    rows: list[tuple[str, Cell]] = []
    if impeller:
        rows.append(("Impeller", _text(impeller)))
    rows.append(("Spec", _text(spec) if spec else "unknown (run.json has no spec)"))
    if "blades" in geometry:
        rows.append(("Blades", _text(geometry["blades"])))
    machine = run.get("machine") or post.get("machine") or rough.get("machine")
    rows.append(("Machine", _text(machine) if machine else "unknown"))
    tools = run.get("tools")
    if tools:
        rows.append(("Tools", _text(tools)))
    else:
        for label, document in (("Roughing tool", rough), ("Finishing tool", finish)):
            tool = document.get("tool")
            if isinstance(tool, dict):
                rows.append((label, f"{tool.get('name')} (D {tool.get('diameter_mm')} mm)"))
    post_name = post.get("post") or run.get("post")
    rows.append(("Post-processor", _text(post_name) if post_name else "unknown"))
    for key in ("settings", "options", "versions"):
        value = run.get(key)
        if isinstance(value, dict):  # unset entries (e.g. no --post given) say nothing
            value = {k: v for k, v in value.items() if v is not None}
        if value:
            rows.append((key.capitalize(), _text(value)))
    return rows


def _stage_table(folder: RunFolder) -> str:
    records = [folder.stage(name) for name in STAGE_ORDER]
    extra = [r for r in (folder.run.get("stages") or []) if isinstance(r, dict)
             and r.get("name") not in (*STAGE_ORDER, "report")]
    rows: list[list[Cell]] = []
    for name, record in zip(STAGE_ORDER, records, strict=True):
        if record is None:
            continue
        rows.append([name, _text(record.get("status")), _number(record.get("seconds")),
                     _number(record.get("peak_mb")), _text(record.get("error")) or None])
    for record in extra:
        rows.append([_text(record.get("name")), _text(record.get("status")),
                     _number(record.get("seconds")), _number(record.get("peak_mb")),
                     _text(record.get("error")) or None])
    if not rows:
        return missing(folder.why_missing("run.json") if folder.json("run.json") is None
                       else "run.json lists no stages")
    times = [row[2] for row in rows if isinstance(row[2], float)]
    if times:
        rows.append(["total", "", sum(times), None, None])
    return table(["Stage", "Status", "Time (s)", "Peak memory (MB)", "Error"], rows,
                 digits=1, caption="Stages (run.json)")


def _verify_documents(folder: RunFolder) -> list[tuple[str, dict[str, Any] | None, str]]:
    return [(label, folder.json(path), path) for label, path in VERIFY_RUNS]


def summary_checks(folder: RunFolder) -> list[tuple[str, bool | None, str]]:
    """The acceptance checks: (name, passed or None when not checked, detail)."""
    documents = _verify_documents(folder)
    absent = [folder.why_missing(path) for _, doc, path in documents if doc is None]
    checks: list[tuple[str, bool | None, str]] = []
    for kind, name in EVENT_CHECKS:
        per_stage = [(label, int((doc.get("event_counts") or {}).get(kind, 0)))
                     for label, doc, _ in documents if doc is not None]
        total = sum(n for _, n in per_stage)
        detail = f"{total} {kind} event{'' if total == 1 else 's'} (" + ", ".join(
            f"{label} {n}" for label, n in per_stage) + ")" if per_stage else ""
        if absent:
            checks.append((name, None if total == 0 else False,
                           "; ".join(filter(None, [detail, *absent]))))
        else:
            checks.append((name, total == 0, detail))
    checks.append(_excess_check(folder))
    machine = machine_check(folder)
    if machine is not None:
        checks.append(machine)
    return checks


def _excess_check(folder: RunFolder) -> tuple[str, bool | None, str]:
    """Every milled face within allowance + scallop: verify/regions.json (per face
    group: blade sides, hub, fillets, edges, the strips next to the fillets; lathe
    faces apart) when the chain wrote it, else the excess events of
    verify/finish/verify.json (whole part, against the allowance verify was given)."""
    name = "Every milled face within allowance + scallop"
    regions = folder.json(REGIONS)
    if regions is not None:
        finish = regions.get("finish") or {}
        acceptance = finish.get("acceptance") or {}
        limit = _number(finish.get("limit_mm"))
        if not acceptance or limit is None:
            return name, None, f"{REGIONS} has no finish acceptance table"
        failed = [role for role, t in acceptance.items() if not t.get("within_limit", True)]
        worst = ", ".join(f"{role} {_text(table.get('max_mm'))} mm"
                          + (" (over)" if role in failed else "")
                          for role, table in acceptance.items())
        short = int(finish.get("stock_short_samples") or 0)
        passed = not failed and not short and not finish.get("gouge")
        verdict = (f"not passed on {len(failed)} of {len(acceptance)} milled faces "
                   f"({', '.join(failed)})" if failed else
                   f"all {len(acceptance)} milled faces within the limit")
        if short:
            verdict += f"; {short} unmachined samples inside the design (stock short)"
        return name, passed, (
            f"{verdict}. Largest material left after finishing per milled face: {worst}; "
            f"limit {format_number(limit)} mm = allowance "
            f"{_text(finish.get('allowance_mm'))} + tolerance "
            f"{_text(finish.get('tolerance_mm'))} mm ({REGIONS}; lathe faces listed apart "
            "in the deviation section)")
    path = "verify/finish/verify.json"
    document = folder.json(path)
    if document is None:
        return name, None, f"{folder.why_missing(REGIONS)}; {folder.why_missing(path)}"
    deviation = document.get("deviation") or {}
    allowance = _number(deviation.get("allowance_mm"))
    if allowance is None:
        return name, None, f"{path} has no deviation from the design (run without a design?)"
    excess = int((document.get("event_counts") or {}).get("excess", 0))
    return name, excess == 0, (
        f"{excess} excess events (material beyond allowance {format_number(allowance)} + "
        f"gouge tolerance {_text(document.get('gouge_tolerance_mm'))} mm, whole part); "
        f"largest material left {_text(deviation.get('max_mm'))} mm ({path}; "
        f"{folder.why_missing(REGIONS)}: no per-face figures)")


def summary_section(folder: RunFolder) -> Section:
    """Section 1: verdict and checks first, then what was run and the stage table."""
    checks = summary_checks(folder)
    failed = sum(passed is False for _, passed, _ in checks)
    unknown = sum(passed is None for _, passed, _ in checks)
    verdict = (f"{failed} of {len(checks)} checks failed" if failed else
               f"{unknown} of {len(checks)} checks could not be made" if unknown else
               f"all {len(checks)} checks passed")
    state = "fail" if failed else "unknown" if unknown else "pass"
    parts = [f'<p class="verdict {state}">Verification: {html.escape(verdict)}</p>',
             checks_list(checks)]
    chain_checks = folder.run.get("checks")
    if isinstance(chain_checks, dict) and chain_checks:
        rows: list[tuple[str, Cell]] = [(str(k), _text(v)) for k, v in chain_checks.items()]
        parts.append(definition_table(rows))
        parts.append(note("The table above is run.json \"checks\" as the chain wrote it."))
    parts.append(note("Event counts: verify/rough/verify.json and verify/finish/verify.json "
                      "\"event_counts\" (all events found, before the per-type cap). Material "
                      "left: verify/regions.json \"finish\" \"acceptance\" (largest deviation "
                      "per milled face, limit = allowance + scallop + tolerance; the verdict "
                      "passes only when every milled face passes and no stock is short)."))
    parts.append('<div class="cols">' + definition_table(_context_rows(folder))
                 + _stage_table(folder) + "</div>")
    return Section("summary", "Summary", "\n".join(parts))


def _nc_line(folder: RunFolder, program: str, line: int,
             cache: dict[str, list[str] | None]) -> str | None:
    relative = _nc_path(folder, program)
    if relative not in cache:
        cache[relative] = folder.text_lines(relative)
    lines = cache[relative]
    if lines is None or not 1 <= line <= len(lines):
        return None
    return lines[line - 1].strip()


def _nc_path(folder: RunFolder, program: str) -> str:
    post = folder.json("nc/post.json") or {}
    for entry in post.get("programs") or []:
        if isinstance(entry, dict) and PurePosixPath(str(entry.get("nc", ""))).name == program:
            return str(entry["nc"])
    return f"nc/{PurePosixPath(program).name}"


def events_section(folder: RunFolder) -> Section:
    """Section 11: every verification event with its NC file, line and block."""
    from cam.verify.events import EVENT_TYPES

    parts: list[str] = []
    lost: list[str] = []
    found = []
    for label, document, path in _verify_documents(folder):
        if document is None:
            lost.append(folder.why_missing(path))
        else:
            found.append((label, document))
    parts += [missing(message) for message in lost]
    kinds = list(EVENT_TYPES)
    for _, document in found:
        kinds += [str(k) for k in document.get("event_counts") or {} if k not in kinds]
    counts_rows: list[list[Cell]] = []
    groups: list[str] = []
    cache: dict[str, list[str] | None] = {}
    for label, document in found:
        counts = document.get("event_counts") or {}
        events = [e for e in document.get("events") or [] if isinstance(e, dict)]
        counts_rows.append([label, *[int(counts.get(k, 0)) for k in kinds],
                            sum(int(v) for v in counts.values()), len(events)])
        if not events:
            groups.append(paragraph(f"Verification of the {label} programs: no events (no "
                                    "rapid in stock, no holder collision, no gouge, no "
                                    "over-travel, no excess material)."))
        for kind in kinds:
            listed = [e for e in events if e.get("type") == kind]
            if listed:
                groups.append(_event_group(folder, label, kind, listed,
                                           int(counts.get(kind, len(listed))), cache))
    if counts_rows:
        parts.append(table(["Verification", *kinds, "all events", "listed"], counts_rows,
                           caption="Events found per type"))
    parts += groups
    clearance = machine_clearance_part(folder)
    if clearance:
        parts.append(clearance)
    if any(row[-1] for row in counts_rows):
        parts.append(note("Events as listed in verify/*/verify.json \"events\" (at most 200 "
                          "per program and type, largest first); the NC block is that line "
                          "of the NC file. Line 0: material on a surface no block touched. "
                          f"Groups of more than {OPEN_GROUP} events start folded: click "
                          "to unfold."))
    return Section("events", "Verification events", "\n".join(parts), lost)


#: Event groups up to this size are shown unfolded.
OPEN_GROUP = 25


def _event_group(folder: RunFolder, label: str, kind: str, events: list[dict[str, Any]],
                 total: int, cache: dict[str, list[str] | None]) -> str:
    rows: list[list[Cell]] = []
    for event in events:
        program = str(event.get("program", ""))
        line = int(event.get("line", 0))
        block = _nc_line(folder, program, line, cache) if line > 0 else None
        where = event.get("position_mm")
        position = ", ".join(f"{float(v):.2f}" for v in where) if isinstance(where, list) \
            else None
        rows.append([_nc_path(folder, program), line or None, _number(event.get("amount")),
                     position, block, str(event.get("message", ""))])
    body = table(["NC file", "Line", "Amount (mm or deg)", "Position x, y, z (mm)",
                  "NC block", "Message"], rows, digits=(0, 0, 3, 0, 0, 0), css="events")
    summary = f"{label}: {kind}, {len(events)} listed" + \
        (f" of {total} found" if total != len(events) else "")
    opened = " open" if len(events) <= OPEN_GROUP else ""
    return f"<details{opened}><summary>{html.escape(summary)}</summary>{body}</details>"
