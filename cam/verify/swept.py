"""Programs a verification already swept: the record it leaves, and a later run that
takes them over instead of sweeping them again.

The chain verifies the rest operation's programs twice: the finish stage sweeps them
on the rough stock (``verify/rest``, to plan the finishing passes again against what
they leave), and the verify stage sweeps the rest and the finish programs on the same
rough stock. A run asked to (``VerifyOptions.record``) writes ``swept.json`` beside its
final ``stock.npz``: per program its NC file's SHA-256, tool, exact cycle time,
verify.json summary and every event (exact, not capped), and how it started (the
start stock file's SHA-256, resolution, tolerances, machine). ``resume`` reads such a
record back as a ``Swept`` when it swept exactly the programs a later run begins with,
with the same tools, settings and machine, starting from the same stock file; that
run (``run_verify(..., swept=...)``) then starts from the record's final stock and
reports the head programs from the record, with the same results as sweeping them
(tests/cam/run/test_rest.py compares the two runs' outputs).

The machine scenes of the later run are built from the stock the record started from,
as the full run builds them from its initial stock.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cam.verify.events import Event

__all__ = ["FORMAT", "SWEPT", "Swept", "file_digest", "record", "resume"]

#: The record's file name, beside the run's ``stock.npz``.
SWEPT = "swept.json"
#: Format tag of the record.
FORMAT = "impeller-cam swept 1"


def file_digest(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _exact(value: Any) -> Any:
    """JSON-ready without rounding (floats keep every digit through ``json``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_exact(v) for v in value]
    return value


@dataclass(frozen=True)
class Swept:
    """What an earlier run found on the programs a run begins with.

    Attributes
    ----------
    programs : list of str
        Their NC file names, in order.
    summaries : list of dict
        Their verify.json ``programs`` entries.
    durations : list of float
        Their exact cycle times, s.
    events : list of Event
        Every motion and machine event of theirs, exact, in the record's order.
    renders : list of bytes
        Per program, the PNG of its machine render (``b""``: none).
    """

    programs: list[str]
    summaries: list[dict[str, Any]]
    durations: list[float]
    events: list[Event]
    renders: list[bytes]


def record(programs: list[Path], tools: list[str], durations: list[float],
           summaries: list[dict[str, Any]], events: list[Event],
           renders: list[str], settings: dict[str, Any]) -> str:
    """``swept.json`` text of a run.

    Parameters
    ----------
    programs : list of Path
        The run's NC files, in order.
    tools : list of str
        The tool name of each.
    durations : list of float
        Exact cycle time of each, s.
    summaries : list of dict
        The run's verify.json ``programs`` entries.
    events : list of Event
        The programs' motion and machine events (not the deviation's), exact.
    renders : list of str
        Per program, the file name of its machine render in the run's folder ("":
        none).
    settings : dict
        How the run started: ``start_sha256`` (its stock file), ``resolution_mm``,
        ``sweep_tolerance_mm``, ``contact_tolerance_mm``, ``machine_sha256``,
        ``start_owners``, ``render``.

    Returns
    -------
    str
    """
    document = {
        "format": FORMAT,
        **settings,
        "programs": [{"name": p.name, "sha256": file_digest(p), "tool": t, "duration_s": d,
                      "summary": s, "render": r}
                     for p, t, d, s, r in zip(programs, tools, durations, summaries, renders,
                                              strict=True)],
        "events": [{"type": e.type, "line": int(e.line), "program": e.program,
                    "position": [float(v) for v in e.position], "amount": float(e.amount),
                    "message": e.message, "details": _exact(e.details)} for e in events],
    }
    return json.dumps(document, indent=1, sort_keys=True) + "\n"


def resume(folder: Path, programs: list[Path], tools: list[str], start: Any,
           start_file: Path, settings: dict[str, Any]) -> Swept | None:
    """The record in ``folder`` as a ``Swept`` for a run of ``programs``, else None.

    Parameters
    ----------
    folder : Path
        An earlier run's output folder (``swept.json``, ``stock.npz``, renders).
    programs : list of Path
        The later run's NC files: the record must have swept its first ones, byte for
        byte.
    tools : list of str
        The later run's tool name of each program (the same for the head).
    start : Stock
        The later run's initial stock (the stock the record must have started from;
        the later run builds its machine scenes from it).
    start_file : Path
        The file ``start`` was loaded from: the record must have started from the same
        bytes.
    settings : dict
        The later run's ``resolution_mm``, ``sweep_tolerance_mm``,
        ``contact_tolerance_mm``, ``machine_sha256`` and ``render``, which must be the
        record's.

    Returns
    -------
    Swept or None
        None when anything differs or a file is missing (the run then sweeps all).
    """
    try:
        data = json.loads((folder / SWEPT).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    entries = data.get("programs") or []
    if (data.get("format") != FORMAT or not entries or len(entries) > len(programs)
            or not (folder / "stock.npz").is_file()
            or any(data.get(k) != v for k, v in settings.items())
            or data.get("start_owners") != len(start.owners)
            or data.get("start_sha256") != file_digest(start_file)):
        return None
    for entry, path, tool in zip(entries, programs, tools, strict=False):
        if (entry["name"] != path.name or entry["tool"] != tool
                or entry["sha256"] != file_digest(path)):
            return None
    renders = []
    for entry in entries:
        name = entry.get("render") or ""
        if name and not (folder / name).is_file():
            return None
        renders.append((folder / name).read_bytes() if name else b"")
    events = [Event(e["type"], e["line"], e["program"], tuple(e["position"]), e["amount"],
                    e["message"], e["details"]) for e in data.get("events", [])]
    return Swept([e["name"] for e in entries], [e["summary"] for e in entries],
                 [float(e["duration_s"]) for e in entries], events, renders)
