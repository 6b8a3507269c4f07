"""APT CLDATA writer: ``Sequence[Toolpath]`` -> CL text that ``apt_reader`` reads back.

Runs of GOTO records with no record between them are formatted with one
``%``-operation per run (one format string repeated over the run's numbers), so a
million poses are written in about a second. The writer mirrors the reader's modal
rules: it emits FEDRAT/ only when the feed changes, RAPID before each rapid GOTO,
``$$ LINK`` before the RAPID of a checked link (``Toolpath.link``),
``$$ MOVE/...`` when the non-rapid move kind changes, ``$$ SEGMENT/...`` when the
fixed-orientation segment changes, and SPINDL/, COOLNT/ and CUTTER/ per operation.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from postproc.toolpath import Cutter, MoveKind, Toolpath

_CONTROL_RE = re.compile(r"[\x00-\x1f\x7f$]+")
_CHUNK = 65536  # rows formatted per %-operation (bounds the temporary tuple)


def sanitise(text: str) -> str:
    """Make ``text`` safe inside one ``$$`` comment: no control characters, no ``$``."""
    return " ".join(_CONTROL_RE.sub(" ", text).split())


def _number(value: float, decimals: int) -> str:
    """Shortest fixed-point text of ``value`` rounded to ``decimals`` (no ``-0``)."""
    text = f"{round(value, decimals) + 0.0:.{decimals}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _goto_block(tip: NDArray[np.float64], axis: NDArray[np.float64], decimals: int,
                axis_decimals: int) -> str:
    """GOTO/x,y,z,i,j,k lines for all rows, newline-terminated."""
    values = np.empty((len(tip), 6))
    values[:, :3] = np.round(tip, decimals) + 0.0  # + 0.0 turns -0.0 into 0.0
    values[:, 3:] = np.round(axis, axis_decimals) + 0.0
    p = f"%.{decimals}f"
    a = f"%.{axis_decimals}f"
    line = f"GOTO/{p},{p},{p},{a},{a},{a}\n"
    parts = []
    for start in range(0, len(values), _CHUNK):
        chunk = values[start : start + _CHUNK]
        parts.append((line * len(chunk)) % tuple(chunk.ravel().tolist()))
    return "".join(parts)


def _check(toolpath: Toolpath, index: int) -> None:
    """Refuse poses that cannot be written faithfully (in-memory data, so ValueError)."""
    if len(toolpath) == 0:
        raise ValueError(f"toolpath {index} ({toolpath.name!r}) has no poses; a CL operation "
                         "needs at least one GOTO")
    if not np.all(np.isfinite(toolpath.tip)) or not np.all(np.isfinite(toolpath.axis)):
        raise ValueError(f"toolpath {index} ({toolpath.name!r}) has non-finite poses")
    cutting = toolpath.kind != MoveKind.RAPID
    feed = toolpath.feed[cutting]
    if not np.all(np.isfinite(feed) & (feed > 0.0)):
        row = int(np.flatnonzero(cutting)[np.flatnonzero(~(np.isfinite(feed) & (feed > 0)))[0]])
        raise ValueError(f"toolpath {index} ({toolpath.name!r}) row {row}: a non-rapid move "
                         f"needs a positive feed, got {toolpath.feed[row]!r}")
    if np.any(toolpath.segment < -1):
        raise ValueError(f"toolpath {index} ({toolpath.name!r}): segment indices must be >= -1")


def _cutter_record(cutter: Cutter, decimals: int) -> str:
    d = _number(cutter.diameter, decimals)
    r = _number(cutter.corner_radius, decimals)
    if cutter.length > 0.0:
        e = _number(0.5 * cutter.diameter - cutter.corner_radius, decimals)
        h = _number(cutter.length, decimals)
        return f"CUTTER/{d},{r},{e},{r},0,0,{h}"
    return f"CUTTER/{d},{r}"


class _FileState:
    """What a reader has in force at this point of the file."""

    def __init__(self) -> None:
        self.feed: float | None = None
        self.kind = int(MoveKind.FEED)
        self.segment = -1
        self.spindle: float | None = None
        self.coolant = False


def _operation(toolpath: Toolpath, state: _FileState, decimals: int, axis_decimals: int,
               out: list[str]) -> None:
    """Append one operation's records to ``out``."""
    name = sanitise(toolpath.name) or "operation"
    out.append(f"$$ OPERATION/{name}\n")
    out.append(f"LOADTL/{int(toolpath.tool_number)}\n")
    if toolpath.cutter is not None:
        out.append(_cutter_record(toolpath.cutter, decimals) + "\n")
    if toolpath.spindle_rpm is not None:
        rpm = float(toolpath.spindle_rpm)
        turn = "CCLW" if rpm < 0 else "CLW"
        out.append(f"SPINDL/RPM,{_number(abs(rpm), decimals)},{turn}\n")
    elif state.spindle is not None:
        out.append("SPINDL/OFF\n")
    state.spindle = toolpath.spindle_rpm
    if toolpath.coolant != state.coolant:
        out.append("COOLNT/ON\n" if toolpath.coolant else "COOLNT/OFF\n")
        state.coolant = bool(toolpath.coolant)

    n = len(toolpath)
    prefixes: dict[int, list[str]] = {}
    kind = toolpath.kind.astype(np.int64)
    rapid = kind == MoveKind.RAPID
    feed = np.round(toolpath.feed, decimals)
    segment = toolpath.segment.astype(np.int64)
    previous_segment = np.concatenate([[state.segment], segment[:-1]])
    cutting = np.flatnonzero(~rapid)
    kind_change = cutting[kind[cutting] != np.concatenate([[state.kind], kind[cutting][:-1]])]
    last_feed = np.nan if state.feed is None else state.feed
    feed_change = cutting[feed[cutting] != np.concatenate([[last_feed], feed[cutting][:-1]])]
    for row in np.flatnonzero(segment != previous_segment).tolist():
        seg = int(segment[row])
        prefixes.setdefault(row, []).append(
            "$$ SEGMENT/5AXIS\n" if seg < 0 else f"$$ SEGMENT/3+2,{seg}\n")
    for row in kind_change.tolist():
        prefixes.setdefault(row, []).append(f"$$ MOVE/{MoveKind(int(kind[row])).name}\n")
    for row in feed_change.tolist():
        prefixes.setdefault(row, []).append(f"FEDRAT/MMPM,{_number(float(feed[row]), decimals)}\n")
    for row in np.flatnonzero(rapid).tolist():
        if toolpath.link[row]:
            prefixes.setdefault(row, []).append("$$ LINK\n")
        prefixes.setdefault(row, []).append("RAPID\n")
    if n:
        state.segment = int(segment[-1])
        if cutting.size:
            state.kind = int(kind[cutting[-1]])
            state.feed = float(feed[cutting[-1]])

    breaks = sorted(prefixes)
    bounds = [*breaks, n] if breaks and breaks[0] == 0 else [0, *breaks, n]
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        out.extend(prefixes.get(a, []))
        if b > a:
            out.append(_goto_block(toolpath.tip[a:b], toolpath.axis[a:b], decimals, axis_decimals))


def format_apt(toolpaths: Sequence[Toolpath], decimals: int = 6,
               header: str | None = None) -> str:
    """CL text for ``toolpaths``, deterministic for given inputs.

    Parameters
    ----------
    toolpaths : sequence of Toolpath
        Operations in order; each becomes ``$$ OPERATION/name`` + ``LOADTL/n`` + records.
    decimals : int
        Decimals of positions (mm) and feeds (mm/min), 0..12. Tool axes get
        ``max(decimals, 6)`` decimals so they stay unit vectors within 1e-6.
    header : str, optional
        Text written as ``$$`` comment lines at the top (sanitised).

    Raises
    ------
    ValueError
        ``decimals`` out of range, an empty toolpath, non-finite poses, or a non-rapid
        move without a positive feed.
    """
    if not 0 <= int(decimals) <= 12:
        raise ValueError(f"decimals must be within 0..12, not {decimals}")
    decimals = int(decimals)
    axis_decimals = max(decimals, 6)
    for index, toolpath in enumerate(toolpaths):
        _check(toolpath, index)
    out: list[str] = []
    if header:
        out.extend(f"$$ {sanitise(line)}".rstrip() + "\n" for line in header.splitlines())
    out.append("UNITS/MM\nMULTAX/ON\n")
    state = _FileState()
    for toolpath in toolpaths:
        _operation(toolpath, state, decimals, axis_decimals, out)
    if state.spindle is not None:
        out.append("SPINDL/OFF\n")
    if state.coolant:
        out.append("COOLNT/OFF\n")
    out.append("FINI\n")
    return "".join(out)
