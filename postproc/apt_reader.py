"""APT CLDATA reader: CL text -> ``list[Toolpath]`` (one per operation) and notes.

The GOTO records are found and parsed in bulk (``postproc.apt_scan``). The few other
records are interpreted one by one in file order; each modal change is stored as
"from GOTO number g on, value v", and the modal values are then spread over the
GOTO arrays with ``numpy.searchsorted``. So the Python loop runs over the non-GOTO
records only.

Semantics (see docs/formats.md): FEDRAT is modal; RAPID applies to the next GOTO
only, and so does ``$$ LINK`` (a rapid the planner checked as a joint move); a
three-number GOTO keeps the last tool axis (+Z before any); each LOADTL or
``$$ OPERATION/name`` (CATIA ``$$ OPERATION NAME : name``, NX ``TOOL PATH/name``)
starts an operation once the current one has motion; fixed-orientation segments come
from ``$$ SEGMENT/3+2,n`` ... ``$$ SEGMENT/5AXIS`` or ``MULTAX/OFF`` + ``TLAXIS/i,j,k``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from postproc.apt_records import (
    AXIS_NORM_TOLERANCE,
    MM_PER_INCH,
    NO_MOTION,
    UNSUPPORTED_MOTION,
    Record,
    bad,
    logical_records,
    parse_axis,
    parse_cutter,
    parse_fedrat,
    parse_record,
    parse_spindl,
    parse_tldata,
    parse_tool_number,
    split_args,
)
from postproc.apt_scan import (
    GOTO_COUNTS,
    ScannedLines,
    normalise_newlines,
    parse_numbers,
    scan_lines,
)
from postproc.toolpath import MoveKind, Toolpath


@dataclass(frozen=True)
class AptNote:
    """A record that was accepted but ignored or interpreted with a caveat."""

    line: int
    record: str
    message: str


@dataclass
class AptDocument:
    """What a CL file holds: its operations and the notes made while reading it."""

    toolpaths: list[Toolpath]
    notes: list[AptNote] = field(default_factory=list)
    partno: str | None = None


class _Changes:
    """A modal value that changes at given GOTO indices: ``(g, value)`` pairs."""

    def __init__(self, initial: Any) -> None:
        self.at: list[int] = [-1]
        self.values: list[Any] = [initial]

    def set(self, g: int, value: Any) -> None:
        self.at.append(g)
        self.values.append(value)

    @property
    def current(self) -> Any:
        return self.values[-1]

    def index_at(self, g: NDArray[np.int64]) -> NDArray[np.int64]:
        """Index into ``values`` of the value in force at each GOTO index ``g``."""
        return np.searchsorted(np.asarray(self.at), g, side="right") - 1

    def spread(self, g: NDArray[np.int64], dtype: Any) -> NDArray[Any]:
        return np.asarray(self.values, dtype=dtype)[self.index_at(g)]


class _Interpreter:
    """Walks the non-GOTO records in order, recording modal changes by GOTO index."""

    def __init__(self, source: str, goto_lines: NDArray[np.int64]) -> None:
        self.source = source
        self.goto_lines = goto_lines  # 1-based, ascending
        self.notes: list[AptNote] = []
        self.partno: str | None = None
        self.feed = _Changes(np.nan)
        self.scale = _Changes(1.0)
        self.kind = _Changes(int(MoveKind.FEED))
        self.segment = _Changes(-1)
        self.tool = _Changes(1)
        self.cutter = _Changes(None)
        self.spindle = _Changes(None)
        self.coolant = _Changes(False)
        self.axis_at: list[int] = []
        self.axis_values: list[tuple[float, float, float]] = []
        self.rapid_at: list[int] = []
        self.link_at: list[int] = []
        self.op_start: list[int] = [0]
        self.op_name: list[str | None] = [None]
        self.op_segments: set[int] = set()
        self.multax_on = True
        self.cutter_given_at = -2
        self.last_rpm: float | None = None
        self.fini_line: int | None = None
        self.fini_g: int | None = None

    def note(self, record: Record, message: str) -> None:
        self.notes.append(AptNote(record.line, record.major or "$$", message))

    def in_operation(self, g: int) -> bool:
        """True when the current operation already holds GOTO records."""
        return g > self.op_start[-1]

    def start_operation(self, g: int, name: str | None) -> None:
        if self.in_operation(g):
            self.op_start.append(g)
            self.op_name.append(name)
            self.op_segments = set()
        elif name is not None:
            self.op_name[-1] = name

    def handle(self, record: Record, g: int) -> None:
        """Interpret one record; ``g`` = number of GOTO records before it."""
        major = record.major
        if self.fini_line is not None:
            if major:
                self.note(record, f"record after FINI (line {self.fini_line}) ignored")
            return
        if not major:
            self.comment(record, g)
        elif major == "RAPID":
            self.rapid_at.append(g)
        elif major == "FEDRAT":
            self.feed.set(g, parse_fedrat(record, self.source, self.scale.current != 1.0,
                                          self.spindle.current))
        elif major == "MULTAX":
            self.multax_record(record, g)
        elif major == "TLAXIS":
            self.tlaxis(record, g)
        elif major in ("LOADTL", "LOAD"):
            self.loadtl(record, g)
        elif major in ("CUTTER", "TLDATA"):
            self.cutter_record(record, g)
        elif major == "SPINDL":
            self.spindl(record, g)
        elif major == "COOLNT":
            self.coolnt(record, g)
        elif major == "UNITS":
            self.units(record, g)
        elif major == "FINI":
            self.fini_line, self.fini_g = record.line, g
        elif major == "TOOL PATH":
            args = record.args.split(",")
            self.start_operation(g, args[0].strip() or None)
        elif major == "MSYS":
            self.msys(record)
        elif major == "CUTCOM":
            if split_args(record) not in (["OFF"], []):
                raise bad(record, self.source, "cutter compensation changes the tool path",
                          "CUTCOM/OFF; export the tool path without cutter compensation")
            self.note(record, "CUTCOM/OFF ignored")
        elif major in UNSUPPORTED_MOTION or (major == "CYCLE" and split_args(record) != ["OFF"]):
            raise bad(record, self.source, f"{major}/ has a motion meaning this reader does not "
                      "interpret", "a CL file with linear GOTO/ moves only")
        elif major == "PARTNO":
            self.partno = record.args.strip().strip("'\"") or None
            self.note(record, "PARTNO recorded as the part name; no motion meaning")
        elif major in NO_MOTION:
            self.note(record, f"{major} has no motion meaning; ignored")
        else:
            self.note(record, f"unrecognised record {major} ignored")

    def comment(self, record: Record, g: int) -> None:
        text = (record.comment or "").strip()
        upper = text.upper()
        if upper.startswith("OPERATION/"):
            self.start_operation(g, text[len("OPERATION/") :].strip() or None)
        elif upper.startswith("OPERATION NAME") and ":" in text:
            self.start_operation(g, text.split(":", 1)[1].strip() or None)
        elif upper.startswith("SEGMENT/"):
            self.segment_marker(record, upper[len("SEGMENT/") :].replace(" ", ""), g)
        elif upper == "LINK":
            self.link_at.append(g)
        elif upper.startswith("MOVE/"):
            word = upper[len("MOVE/") :].strip()
            if word not in ("FEED", "PLUNGE", "RETRACT"):
                raise InputError(f"line {record.line}: unknown move kind marker",
                                 file=self.source, field="$$ MOVE", value=text,
                                 accepted="$$ MOVE/FEED, $$ MOVE/PLUNGE, $$ MOVE/RETRACT")
            self.kind.set(g, int(MoveKind[word]))

    def segment_marker(self, record: Record, body: str, g: int) -> None:
        if body in ("5AXIS", "END", "OFF"):
            self.segment.set(g, -1)
            return
        parts = body.split(",")
        if len(parts) != 2 or parts[0] != "3+2" or not parts[1].isdigit():
            raise InputError(f"line {record.line}: malformed fixed-orientation marker",
                             file=self.source, field="$$ SEGMENT", value=record.comment,
                             accepted="$$ SEGMENT/3+2,n (n >= 0) or $$ SEGMENT/5AXIS")
        self.segment.set(g, int(parts[1]))
        self.op_segments.add(int(parts[1]))

    def multax_record(self, record: Record, g: int) -> None:
        args = split_args(record)
        if args in ([], ["ON"]):
            self.multax_on = True
            if self.segment.current != -1:
                self.segment.set(g, -1)
        elif args == ["OFF"]:
            self.multax_on = False
        else:
            raise bad(record, self.source, "unknown MULTAX/ form", "MULTAX, MULTAX/ON, MULTAX/OFF")

    def tlaxis(self, record: Record, g: int) -> None:
        axis = parse_axis(record, self.source)
        if axis is None:
            self.note(record, "TLAXIS/ without a vector has no motion meaning here; ignored")
            return
        self.axis_at.append(g)
        self.axis_values.append(axis)
        if not self.multax_on:
            number = max(self.op_segments, default=-1) + 1
            self.op_segments.add(number)
            self.segment.set(g, number)

    def loadtl(self, record: Record, g: int) -> None:
        number = parse_tool_number(record, self.source)
        self.start_operation(g, None)
        if self.cutter_given_at != g and number != self.tool.current:
            self.cutter.set(g, None)  # another tool, and no CUTTER/ given for it
        self.tool.set(g, number)

    def cutter_record(self, record: Record, g: int) -> None:
        scale = self.scale.current
        if record.major == "TLDATA":
            cutter = parse_tldata(record, self.source, scale)
            if cutter is None:
                self.note(record, "TLDATA/ for a non-milling tool ignored")
                return
        else:
            cutter = parse_cutter(record, self.source, scale)
        if self.in_operation(g) and cutter != self.cutter.current:
            self.note(record, "cutter changed after the operation's first GOTO; the operation "
                      "keeps the cutter in force at its first GOTO")
        self.cutter_given_at = g
        self.cutter.set(g, cutter)

    def spindl(self, record: Record, g: int) -> None:
        rpm = parse_spindl(record, self.source, self.last_rpm)
        words = split_args(record)
        if rpm is None and ("SFM" in words or "SMM" in words):
            self.note(record, "surface-speed spindle request recorded as no speed")
        if rpm is not None:
            self.last_rpm = rpm
            if self.in_operation(g) and rpm != self.spindle.current:
                self.note(record, "spindle speed changed inside an operation; the operation "
                          "keeps the speed in force at its first GOTO")
        self.spindle.set(g, rpm)

    def coolnt(self, record: Record, g: int) -> None:
        args = split_args(record)
        if not args:
            raise bad(record, self.source, "COOLNT/ needs a state", "COOLNT/ON, COOLNT/OFF")
        self.coolant.set(g, args[0] != "OFF")

    def units(self, record: Record, g: int) -> None:
        args = split_args(record)
        if args in (["MM"], ["MILLIMETERS"], ["METRIC"]):
            self.scale.set(g, 1.0)
            self.note(record, "lengths are mm (the internal unit); nothing to convert")
        elif args in (["INCHES"], ["INCH"], ["IN"]):
            self.scale.set(g, MM_PER_INCH)
            self.note(record, "lengths from here on are inches, converted to mm")
        else:
            raise bad(record, self.source, "unknown length unit", "UNITS/MM or UNITS/INCHES")

    def msys(self, record: Record) -> None:
        args = split_args(record)
        identity = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        try:
            same = [float(a) for a in args] == identity
        except ValueError:
            same = False
        if not same:
            raise bad(record, self.source, "a machine coordinate system other than the "
                      "identity would move the path", "MSYS/0,0,0,1,0,0,0,1,0 or no MSYS")
        self.note(record, "identity MSYS/ ignored")


def parse_apt_document(text: str | bytes, source: str = "<string>") -> AptDocument:
    """Parse CL text into operations and notes. See the module docstring for semantics.

    Raises
    ------
    InputError
        A malformed record or value (the message names file, line, record, value), a
        record with a motion meaning that is not supported, a cutting GOTO before any
        FEDRAT, a GOTO after FINI, a tool axis that is not a unit vector, or a
        fixed-orientation segment whose poses do not share one axis.
    """
    buf = text.encode("utf-8") if isinstance(text, str) else text
    buf = buf.removeprefix(b"\xef\xbb\xbf")  # a UTF-8 byte-order mark from Windows exporters
    scanned = scan_lines(normalise_newlines(buf))
    slow_gotos, records, consumed = logical_records(scanned, source)

    keep = ~np.isin(scanned.goto_line, np.fromiter(consumed, np.int64, len(consumed)))
    fast_lines = scanned.goto_line[keep] + 1
    if scanned.bulk_ok:
        fast_values = scanned.goto_values[keep]
    else:
        fast_values = _reparse(scanned, scanned.goto_line[keep], source)
    slow_values = np.full((len(slow_gotos), 6), np.nan)
    for row, rec in enumerate(slow_gotos):
        numbers = parse_numbers(rec.args, source=source, line=rec.line, record="GOTO",
                                allowed=GOTO_COUNTS)
        slow_values[row, : len(numbers)] = numbers
    lines = np.concatenate([fast_lines, np.array([r.line for r in slow_gotos], np.int64)])
    order = np.argsort(lines, kind="stable")
    lines = lines[order]
    values = np.concatenate([fast_values, slow_values])[order]

    interp = _Interpreter(source, lines)
    before = np.searchsorted(lines, np.array([r.line for r in records], np.int64))
    for record, g in zip(records, before.tolist(), strict=True):
        interp.handle(record, g)
    toolpaths = _assemble(interp, lines, values)
    return AptDocument(toolpaths, interp.notes, interp.partno)


def _reparse(scanned: ScannedLines, line_index: NDArray[np.int64], source: str) -> NDArray[Any]:
    """Record-by-record parse of plain GOTO lines (after the bulk parse failed)."""
    out = np.full((len(line_index), 6), np.nan)
    for row, index in enumerate(line_index.tolist()):
        record = parse_record(index + 1, scanned.line_text(index), None, source)
        numbers = parse_numbers(record.args, source=source, line=index + 1, record="GOTO",
                                allowed=GOTO_COUNTS)
        if not all(np.isfinite(numbers)):
            raise InputError(f"line {index + 1}: GOTO/ value is not finite", file=source,
                             field="GOTO", value=record.args, accepted="finite numbers")
        out[row, : len(numbers)] = numbers
    return out


def _assemble(
    interp: _Interpreter, lines: NDArray[np.int64], values: NDArray[np.float64]
) -> list[Toolpath]:
    """Spread the modal changes over the GOTO arrays and cut them into operations."""
    source = interp.source
    n = len(lines)
    g = np.arange(n, dtype=np.int64)
    if interp.fini_g is not None and interp.fini_g < n:
        line = int(lines[interp.fini_g])
        raise InputError(f"line {line}: GOTO/ after FINI (line {interp.fini_line})",
                         file=source, field="GOTO", value=line, accepted="FINI as the last record")
    if interp.rapid_at and interp.rapid_at[-1] >= n:
        interp.notes.append(AptNote(0, "RAPID", "RAPID with no GOTO after it ignored"))

    tip = values[:, :3] * interp.scale.spread(g, np.float64)[:, None]
    axis = _axes(interp, lines, values, g)
    kind = interp.kind.spread(g, np.int8)
    rapid = np.zeros(n, bool)
    rapid[[r for r in interp.rapid_at if r < n]] = True
    kind[rapid] = MoveKind.RAPID
    link = np.zeros(n, bool)
    link[[r for r in interp.link_at if r < n]] = True
    link &= rapid  # a $$ LINK marks the next GOTO's rapid; without RAPID it means nothing
    feed = interp.feed.spread(g, np.float64)
    feed[rapid] = np.nan
    missing = np.flatnonzero(~rapid & np.isnan(feed))
    if missing.size:
        line = int(lines[missing[0]])
        raise InputError(f"line {line}: cutting GOTO/ before any FEDRAT/", file=source,
                         field="GOTO", value=line,
                         accepted="a FEDRAT/ record before the first cutting move, or RAPID")
    segment = interp.segment.spread(g, np.int32)

    starts = np.asarray(interp.op_start, np.int64)
    ends = np.append(starts[1:], n)
    out: list[Toolpath] = []
    for k, (a, b) in enumerate(zip(starts.tolist(), ends.tolist(), strict=True)):
        if b <= a:
            continue
        _check_segments(segment[a:b], axis[a:b], lines[a:b], source)
        at = np.array([a])
        name = interp.op_name[k] or f"operation-{len(out) + 1}"
        out.append(Toolpath(
            tip=tip[a:b], axis=axis[a:b], feed=feed[a:b], kind=kind[a:b], segment=segment[a:b],
            name=name,
            tool_number=int(interp.tool.spread(at, np.int64)[0]),
            cutter=_object_at(interp.cutter, a),
            spindle_rpm=_object_at(interp.spindle, a),
            coolant=bool(interp.coolant.spread(at, bool)[0]),
            source_records=lines[a:b].astype(np.int32), link=link[a:b],
        ))  # fmt: skip
    return out


def _object_at(changes: _Changes, g: int) -> Any:
    return changes.values[int(changes.index_at(np.array([g]))[0])]


def _axes(
    interp: _Interpreter, lines: NDArray[np.int64], values: NDArray[np.float64],
    g: NDArray[np.int64],
) -> NDArray[np.float64]:
    """Tool axis of every GOTO: its own i,j,k, else the last axis given (+Z at first)."""
    own = ~np.isnan(values[:, 3])
    raw = values[own, 3:]
    norm = np.linalg.norm(raw, axis=1)
    off = np.flatnonzero(np.abs(norm - 1.0) > AXIS_NORM_TOLERANCE)
    if off.size:
        row = np.flatnonzero(own)[off[0]]
        raise InputError(f"line {int(lines[row])}: GOTO/ tool axis has length "
                         f"{norm[off[0]]:.6g}, not 1", file=interp.source, field="GOTO",
                         value=values[row, 3:].tolist(), accepted="a unit vector i,j,k")
    # Axis sources ordered by key: TLAXIS before GOTO g -> 2g, a six-number GOTO g -> 2g+1.
    keys = np.concatenate([2 * np.asarray(interp.axis_at, np.int64), 2 * g[own] + 1])
    vecs = np.concatenate([np.asarray(interp.axis_values, np.float64).reshape(-1, 3),
                           raw / norm[:, None]])
    order = np.argsort(keys, kind="stable")
    keys, vecs = keys[order], vecs[order]
    source = np.searchsorted(keys, 2 * g + 1, side="right") - 1
    axis = np.tile(np.array([0.0, 0.0, 1.0]), (len(g), 1))
    has = source >= 0
    axis[has] = vecs[source[has]]
    return axis


#: Largest component difference between poses of one fixed-orientation segment.
SEGMENT_AXIS_TOLERANCE = 1e-5


def _check_segments(
    segment: NDArray[np.int32], axis: NDArray[np.float64], lines: NDArray[np.int64], source: str
) -> None:
    """Every pose of one fixed-orientation segment must have the same tool axis."""
    fixed = np.flatnonzero(segment >= 0)
    if not fixed.size:
        return
    ids, first = np.unique(segment[fixed], return_index=True)
    reference = axis[fixed[first]][np.searchsorted(ids, segment[fixed])]
    deviation = np.max(np.abs(axis[fixed] - reference), axis=1)
    bad_rows = np.flatnonzero(deviation > SEGMENT_AXIS_TOLERANCE)
    if bad_rows.size:
        row = fixed[bad_rows[0]]
        raise InputError(f"line {int(lines[row])}: tool axis changes inside fixed-orientation "
                         f"segment {int(segment[row])}", file=source, field="GOTO",
                         value=axis[row].tolist(),
                         accepted="one tool axis per $$ SEGMENT/3+2 or TLAXIS/ segment")


__all__ = ["AptDocument", "AptNote", "parse_apt_document"]
