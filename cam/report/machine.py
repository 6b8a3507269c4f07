"""Report part: the machine's own components - smallest clearance per program.

Numbers are copied from verify/*/verify.json (``programs[].machine_clearance_*``,
written by ``cam.verify.machine_check``); the pictures are the verify runs'
``machine_<i>_<program>.png`` (the machine in each program's worst pose).
"""

from __future__ import annotations

from typing import Any

from cam.report.html import Cell, figure, note, paragraph, table
from cam.report.inputs import RunFolder

__all__ = ["machine_check", "machine_clearance_part"]


def _documents(folder: RunFolder) -> list[tuple[str, str, dict[str, Any]]]:
    from cam.report.verification import VERIFY_RUNS

    found = []
    for label, path in VERIFY_RUNS:
        document = folder.json(path)
        if document is not None:
            found.append((label, path.rsplit("/", 1)[0], document))
    return found


def machine_check(folder: RunFolder) -> tuple[str, bool | None, str] | None:
    """The summary card "No machine collision" with the smallest clearance, or None
    when no verification had a machine model."""
    documents = [(label, doc) for label, _, doc in _documents(folder)
                 if "machine_model" in doc]
    if not documents:
        return None
    total = sum(int((doc.get("event_counts") or {}).get("machine_collision", 0))
                for _, doc in documents)
    smallest = []
    for label, doc in documents:
        values = [(p.get("machine_clearance_mm"), p.get("name")) for p in doc["programs"]
                  if p.get("machine_clearance_mm") is not None]
        if values:
            value, name = min(values, key=lambda v: float(v[0]))
            smallest.append(f"{label} {value} mm ({name})")
    detail = f"{total} machine_collision event{'' if total == 1 else 's'}; smallest " \
        "machine clearance: " + (", ".join(smallest) or "no checked pair")
    return "No machine collision", total == 0, detail


def machine_clearance_part(folder: RunFolder) -> str:
    """HTML: per program the smallest clearance, its pair, line and pose; pictures."""
    rows: list[list[Cell]] = []
    pictures: list[str] = []
    for label, base, doc in _documents(folder):
        if "machine_model" not in doc:
            continue
        for index, program in enumerate(doc.get("programs") or [], 1):
            value = program.get("machine_clearance_mm")
            joints = program.get("machine_clearance_joints") or [None] * 5
            pair = program.get("machine_clearance_pair") or ["", ""]
            rows.append([label, str(program.get("name")), value, " - ".join(pair),
                         program.get("machine_clearance_line"), joints[3], joints[4]])
            name = str(program.get("name", ""))
            stem = name.rsplit(".", 1)[0]
            png = folder.png(f"{base}/machine_{index}_{stem}.png")
            if png is not None:
                pictures.append(figure(png, f"{label} {name}: the machine at its smallest "
                                       f"clearance ({base}/machine_{index}_{stem}.png)",
                                       css="half"))
    if not rows:
        return ""
    parts = [
        "<h3>Machine clearance</h3>",
        paragraph("The machine's own components (spindle head, cradle, table, fixture, "
                  "trunnions; machine file [model]) with the tool, holder and part, checked "
                  "in every block; the smallest distance between any checked pair."),
        table(["Verification", "Program", "Smallest clearance (mm)", "Pair", "Line",
               "A (deg)", "C (deg)"], rows, digits=(0, 0, 2, 0, 0, 1, 1),
              caption="Smallest machine clearance per program"),
        *pictures,
        note("verify/*/verify.json \"programs\" machine_clearance_mm, _pair, _line, _joints "
             "and \"machine_model\" (the components, the pairs checked and the pairs left "
             "out with their reasons)."),
    ]
    return "\n".join(parts)
