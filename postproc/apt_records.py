"""Record-level grammar of APT CLDATA: split a logical record, parse its arguments.

Functions here read one non-GOTO record (``FEDRAT/``, ``SPINDL/``, ``CUTTER/``, ...)
into plain values and raise ``InputError`` naming the file, line, record and value
when it is malformed. The modal interpretation lives in ``postproc.apt_reader``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from impeller_cam.errors import InputError
from postproc.apt_scan import NUMBER_RE, ScannedLines
from postproc.toolpath import Cutter

MM_PER_INCH = 25.4

#: Records whose whole remainder is free text (it may contain slashes).
FREE_TEXT_RECORDS = frozenset({"PARTNO", "PPRINT", "INSERT", "REMARK"})

#: Records with a motion meaning this reader does not interpret: an error, never skipped.
UNSUPPORTED_MOTION = frozenset({
    "CIRCLE", "GODLTA", "GOFWD", "GOLFT", "GORGT", "GOBACK", "GOUP", "GODOWN", "GO",
    "INDIRV", "INDIRP", "CYCLE", "ORIGIN", "TRANS", "COPY", "INDEX", "ROTABL", "ROTATE",
    "ROTHED", "REFSYS", "RETRCT", "MATRIX", "ARCSLP", "THREAD", "TURRET",
})  # fmt: skip

#: Records known to carry no motion meaning: ignored with a note.
NO_MOTION = frozenset({
    "PARTNO", "PPRINT", "INSERT", "REMARK", "CLRSRF", "TPRINT", "REWIND", "END", "PAINT",
    "OPSKIP", "SEQNO", "DISPLY", "DELAY", "STOP", "OPSTOP", "AUXFUN", "PREFUN", "SELCTL",
    "MODE", "CLEARP", "FROM", "END-OF-PATH", "MACHIN", "HEAD", "PITCH", "PLABEL", "TITLES",
    "PPLOT", "PLOT", "SET", "TOLER", "INTOL", "OUTTOL", "CUTTER_COMP", "LINTOL", "DRAFT",
    "MCHTOL", "LEADER", "PUNCH", "CLAMP", "UNCLAMP", "RESET", "ISTOP", "TMARK", "CHECK",
    "UNITS", "COOLNT", "TLAXIS", "MSYS", "CUTCOM", "TLDATA", "TOOL PATH", "SPINDL",
})  # fmt: skip


_WORD_RE = re.compile(r"\s*([A-Za-z][A-Za-z0-9_\-]*)")
_HEAD_RE = re.compile(r"[A-Za-z0-9_\- \t]*")


@dataclass(frozen=True)
class Record:
    """One logical CL record (continuations joined).

    Attributes
    ----------
    line : int
        1-based line number of its first physical line.
    major : str
        Major word, upper case, inner blanks collapsed (``GOTO``, ``TOOL PATH``);
        empty for a comment-only line.
    args : str
        Text after the slash (or after the word for free-text records), original case.
    comment : str or None
        Text after ``$$``, original case, or None.
    """

    line: int
    major: str
    args: str
    comment: str | None


def split_comment(text: str) -> tuple[str, str | None]:
    """Split a physical line into its code part and its ``$$`` comment (or None)."""
    at = text.find("$$")
    if at < 0:
        return text, None
    return text[:at], text[at + 2 :]


def parse_record(line: int, code: str, comment: str | None, source: str) -> Record:
    """Parse the code part of a logical record into its major word and arguments."""
    stripped = code.strip()
    if not stripped:
        return Record(line, "", "", comment)
    match = _WORD_RE.match(stripped)
    if match is None:
        raise InputError(
            f"line {line}: a CL record must start with a major word",
            file=source,
            field="record",
            value=stripped[:60],
            accepted="records such as GOTO/x,y,z,i,j,k, FEDRAT/f, RAPID, LOADTL/n, $$ comment",
        )
    word = match.group(1).upper()
    rest = stripped[match.end() :]
    if word in FREE_TEXT_RECORDS:
        return Record(line, word, rest.strip().removeprefix("/").strip(), comment)
    slash = rest.find("/")
    if slash < 0:
        return Record(line, word, rest.strip(), comment)
    head = rest[:slash]
    if head.strip() and _HEAD_RE.fullmatch(head):
        word = " ".join([word, *head.upper().split()])
    elif head.strip():
        raise InputError(
            f"line {line}: unexpected text before the slash of {word}/",
            file=source,
            field=word,
            value=stripped[:60],
            accepted=f"{word}/arguments",
        )
    return Record(line, word, rest[slash + 1 :].strip(), comment)


def split_args(record: Record) -> list[str]:
    """Comma-separated arguments of a record, blanks stripped, words upper-cased."""
    if not record.args:
        return []
    return [a.strip().upper() for a in record.args.split(",")]


def is_number(token: str) -> bool:
    """True when ``token`` is an APT decimal number."""
    return NUMBER_RE.fullmatch(token) is not None


def bad(record: Record, source: str, message: str, accepted: str) -> InputError:
    """An ``InputError`` about ``record`` (its line, major word and arguments)."""
    return InputError(
        f"line {record.line}: {message}",
        file=source,
        field=record.major,
        value=record.args if record.args else record.major,
        accepted=accepted,
    )


def parse_fedrat(record: Record, source: str, inch: bool, spindle_rpm: float | None) -> float:
    """``FEDRAT/f``, ``FEDRAT/MMPM,f``, ``FEDRAT/f,MMPM`` (also IPM, MMPR, IPR) -> mm/min.

    A feed without a unit word is in the file's length unit per minute. Per-revolution
    feeds are multiplied by the spindle speed in force (an error when there is none).
    """
    accepted = "FEDRAT/f, FEDRAT/MMPM,f, FEDRAT/f,MMPM (or IPM, MMPR, IPR) with f > 0"
    args = split_args(record)
    numbers = [a for a in args if is_number(a)]
    words = [a for a in args if not is_number(a)]
    if len(numbers) != 1 or len(words) > 1 or (words and words[0] not in _FEED_UNITS):
        raise bad(record, source, "FEDRAT/ needs one feed value and at most one unit", accepted)
    value = float(numbers[0])
    if not value > 0.0:
        raise bad(record, source, "FEDRAT/ feed must be positive", accepted)
    unit = words[0] if words else ("IPM" if inch else "MMPM")
    value *= _FEED_UNITS[unit]
    if unit in ("MMPR", "IPR"):
        if spindle_rpm is None:
            raise bad(
                record,
                source,
                "a per-revolution feed needs a SPINDL/ speed in force",
                "a SPINDL/RPM,n record before it, or FEDRAT/MMPM,f",
            )
        value *= abs(spindle_rpm)
    return value


_FEED_UNITS = {"MMPM": 1.0, "IPM": MM_PER_INCH, "MMPR": 1.0, "IPR": MM_PER_INCH}


def parse_spindl(record: Record, source: str, last_rpm: float | None) -> float | None:
    """``SPINDL/RPM,n,CLW``, ``SPINDL/n,RPM,CCLW``, ``SPINDL/n``, ``SPINDL/OFF|ON``.

    Returns
    -------
    float or None
        Speed in rev/min, negative for counter-clockwise (CCLW); None for OFF or for a
        surface-speed request (SFM/SMM), which the caller records as a note.
    """
    accepted = "SPINDL/RPM,n[,CLW|CCLW], SPINDL/n[,RPM][,CLW|CCLW], SPINDL/OFF, SPINDL/ON"
    args = split_args(record)
    if args in (["OFF"], ["LOCK"]):
        return None
    if args == ["ON"]:
        return last_rpm
    numbers = [a for a in args if is_number(a)]
    words = [a for a in args if not is_number(a)]
    if len(numbers) != 1 or any(w not in _SPINDLE_WORDS for w in words):
        raise bad(record, source, "SPINDL/ needs one speed and known words", accepted)
    if "SFM" in words or "SMM" in words:
        return None
    speed = float(numbers[0])
    if speed < 0.0:
        raise bad(record, source, "SPINDL/ speed must not be negative (use CCLW)", accepted)
    return -speed if "CCLW" in words else speed


_SPINDLE_WORDS = frozenset({"RPM", "CLW", "CCLW", "SFM", "SMM", "MAXRPM", "ON", "RANGE"})


def parse_cutter(record: Record, source: str, scale: float) -> Cutter:
    """``CUTTER/d``, ``CUTTER/d,r`` or the seven-parameter ``CUTTER/d,r,e,f,a,b,h``.

    ``d`` diameter, ``r`` corner radius, ``h`` height (kept as ``Cutter.length``); all
    in the file's length unit, returned in mm.
    """
    accepted = "CUTTER/d, CUTTER/d,r or CUTTER/d,r,e,f,a,b,h with d > 0 and 0 <= r <= d/2"
    args = split_args(record)
    if not args or len(args) not in (1, 2, 7) or not all(is_number(a) for a in args):
        raise bad(record, source, "CUTTER/ needs 1, 2 or 7 numbers", accepted)
    values = [float(a) * scale for a in args]
    return _checked_cutter(record, source, values[0], values[1] if len(values) > 1 else 0.0,
                           values[6] if len(values) == 7 else 0.0, accepted)


def parse_tldata(record: Record, source: str, scale: float) -> Cutter | None:
    """NX ``TLDATA/MILL,d,r,length,...``; None for non-milling tool data."""
    args = split_args(record)
    if not args or args[0] != "MILL":
        return None
    accepted = "TLDATA/MILL,d,r[,length,...] with d > 0 and 0 <= r <= d/2"
    numbers = args[1:]
    if len(numbers) < 2 or not all(is_number(a) for a in numbers):
        raise bad(record, source, "TLDATA/MILL needs the diameter and corner radius", accepted)
    values = [float(a) * scale for a in numbers]
    return _checked_cutter(record, source, values[0], values[1],
                           values[2] if len(values) > 2 else 0.0, accepted)


def _checked_cutter(
    record: Record, source: str, diameter: float, corner: float, length: float, accepted: str
) -> Cutter:
    if not diameter > 0.0 or not 0.0 <= corner <= 0.5 * diameter + 1e-9 or length < 0.0:
        raise bad(record, source, f"{record.major}/ describes an impossible cutter", accepted)
    return Cutter(diameter=diameter, corner_radius=min(corner, 0.5 * diameter), length=length)


def parse_tool_number(record: Record, source: str) -> int:
    """``LOADTL/n[,...]`` or NX ``LOAD/TOOL,n[,...]`` -> n."""
    args = split_args(record)
    if record.major == "LOAD":
        args = args[1:] if args and args[0] == "TOOL" else []
    if not args or re.fullmatch(r"[+]?\d+(\.0*)?", args[0]) is None:
        raise bad(record, source, "tool number must be a non-negative integer",
                  "LOADTL/n or LOAD/TOOL,n with n an integer")
    return int(float(args[0]))


def parse_axis(record: Record, source: str) -> tuple[float, float, float] | None:
    """``TLAXIS/i,j,k`` -> a unit vector; None for non-numeric forms (NORMPS, ...)."""
    args = split_args(record)
    if not args or not all(is_number(a) for a in args):
        return None
    if len(args) != 3:
        raise bad(record, source, "TLAXIS/ with numbers needs exactly i,j,k", "TLAXIS/i,j,k")
    i, j, k = (float(a) for a in args)
    norm = (i * i + j * j + k * k) ** 0.5
    if abs(norm - 1.0) > AXIS_NORM_TOLERANCE:
        raise bad(record, source, f"TLAXIS/ vector has length {norm:.6g}, not 1",
                  "a unit vector i,j,k")
    return i / norm, j / norm, k / norm


#: How far from 1 the length of a written tool axis may be (rounding in the file).
AXIS_NORM_TOLERANCE = 1e-3


def logical_records(
    scanned: ScannedLines, source: str
) -> tuple[list[Record], list[Record], set[int]]:
    """Join ``$`` continuations of the non-plain lines; split GOTOs from the rest.

    Parameters
    ----------
    scanned : ScannedLines
        The file's lines as ``postproc.apt_scan.scan_lines`` found them.
    source : str
        File name for messages.

    Returns
    -------
    gotos : list of Record
        The GOTO records that need a record-by-record parse.
    others : list of Record
        The other records, in file order.
    consumed : set of int
        0-based indices of the lines consumed as continuations.
    """
    gotos: list[Record] = []
    others: list[Record] = []
    consumed: set[int] = set()
    nlines = len(scanned.line_start)
    for index in scanned.other_lines.tolist():
        if index in consumed:
            continue
        code, comment = split_comment(scanned.line_text(index))
        last = index
        while code.rstrip().endswith("$"):
            last += 1
            if last >= nlines:
                raise InputError(f"line {index + 1}: '$' continuation at the end of the file",
                                 file=source, field="$", value=code.strip()[-40:],
                                 accepted="a continued record followed by its next line")
            more, more_comment = split_comment(scanned.line_text(last))
            code = code.rstrip()[:-1] + more
            comment = more_comment if comment is None else comment
            consumed.add(last)
        record = parse_record(index + 1, code, comment, source)
        (gotos if record.major == "GOTO" else others).append(record)
    return gotos, others, consumed
