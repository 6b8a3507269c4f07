"""NC reader: ISO / LinuxCNC G-code -> joint-space blocks (``MachineProgram``).

Reads the dialects this project writes and typical ISO G-code, block by block, with
the modal state of an RS274 interpreter: motion G0/G1/G2/G3/G80, distance G90/G91,
arc centres G90.1/G91.1, feed mode G93/G94, units G20/G21, tool-centre-point control
(Fanuc G43.4 ... G49, LinuxCNC switchable kinematics M428 = TCP kins, M429 = identity
kins), tool length G43 H (the programmed point stays the tool tip), tool changes T..M6,
F and S words, G53 machine-coordinate moves (a joint move, never TCP), G28 (a note at
the end of a program, an error when motion follows it). Arcs in the XY plane are
linearised within a chordal tolerance (``postproc.gcode_arcs``); every block keeps
its source line. Angles come in degrees and leave as radians; inches leave as mm.
See docs/formats.md for the full list.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES
from postproc.gcode_arcs import arc_block_points
from postproc.gcode_words import (
    AXIS_COLUMNS,
    SILENT_G,
    SILENT_M,
    UNSUPPORTED_G,
    WORK_OFFSET_G,
    Block,
    parse_block,
)
from postproc.nc_controls import DIALECTS, TCP_OFF_M, TCP_ON_M, detect_dialect, translate
from postproc.nc_fast import SimpleLines, read_run, split_lines
from postproc.program import FeedMode, MachineProgram, Motion

if TYPE_CHECKING:
    from postproc.machine import Machine

MM_PER_INCH = 25.4

#: LinuxCNC switchable kinematics (configs/sim/axis/vismach/5axis/table-rotary-tilting,
#: remap_subs/428remap.ngc, 429remap.ngc, kins loaded with sparm=identityfirst):
#: M428 selects kinstype 1 (xyzac-trt, tool-centre-point), M429 kinstype 0 (identity).
#: M430 (kinstype 2, user kinematics) is refused: its joint meaning is unknown.
SWITCHKINS_TCP: dict[int, bool] = {428: True, 429: False}

#: Shortest run of plain motion lines worth reading in bulk.
_MIN_RUN = 8

#: Motion codes: G0, G1, G2 (clockwise arc), G3, G80 (no motion mode).
_MOTION: dict[int, Motion | str | None] = {
    0: Motion.RAPID, 10: Motion.LINEAR, 20: "cw", 30: "ccw", 800: None,
}

@dataclass(frozen=True)
class NcNote:
    """A word or block accepted with a caveat or ignored (no motion meaning)."""

    line: int
    message: str


@dataclass
class NcDocument:
    """An NC file's joint-space blocks and the notes made while reading it."""

    program: MachineProgram
    notes: list[NcNote] = field(default_factory=list)


class _State:
    """Modal state of the interpreter (internal units: mm, rad)."""

    def __init__(self, start: np.ndarray) -> None:
        self.position = start.copy()
        self.motion: Motion | str | None = None  # G80: no motion mode until G0/G1/G2/G3
        self.incremental = False
        self.arc_incremental = True
        self.inverse_time = False
        self.inch = False
        self.feed_rate: float | None = None  # mm/min (G94) or 1/min (G93)
        self.tcp_g43 = False
        self.tcp_kins = False
        self.selected_tool = 0
        self.tool = 0
        self.plane_xy = True
        self.home_line: int | None = None


class _Reader:
    def __init__(self, source: str, tolerance: float, start: np.ndarray,
                 switchkins: Mapping[int, bool], home: np.ndarray | None) -> None:
        self.source = source
        self.home_position = home
        self.tolerance = tolerance
        self.switchkins = switchkins
        self.state = _State(start)
        self.notes: list[NcNote] = []
        self.rows: list[tuple[float, ...]] = []  # x y z a c motion mode feed line tcp tool
        self.chunks: list[np.ndarray] = []
        self.ended: int | None = None

    def error(self, block: Block, message: str, field: str, value: object,
              accepted: str) -> InputError:
        return InputError(f"line {block.line}: {message}", file=self.source, field=field,
                          value=value, accepted=accepted)

    def run(self, text: str) -> None:
        """Read every line: plain motion runs in bulk (``nc_fast``), the rest block by block."""
        text = text.removeprefix("\ufeff")  # a UTF-8 byte-order mark
        if "\r" in text:
            text = text.replace("\r\n", "\n").replace("\r", "\n")
        physical = text.split("\n")
        columns = split_lines(text, physical)
        if columns is None:
            self.slow(physical, 0, len(physical))
            return
        simple = columns.simple
        edges = np.flatnonzero(np.diff(simple.astype(np.int8))) + 1
        bounds = [0, *edges.tolist(), len(physical)]
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            if simple[a] and b - a >= _MIN_RUN and not self.fast(columns, a, b):
                self.slow(physical, a, b)
            elif not simple[a] or b - a < _MIN_RUN:
                self.slow(physical, a, b)

    def slow(self, physical: list[str], a: int, b: int) -> None:
        """Interpret lines ``a..b-1`` (0-based) block by block."""
        for index in range(a, b):
            block = parse_block(physical[index], index + 1, self.source)
            if block is None:
                continue
            if self.ended is not None:
                self.notes.append(NcNote(index + 1, f"block after program end (line "
                                         f"{self.ended}) ignored"))
                continue
            self.block(block)

    def fast(self, columns: SimpleLines, a: int, b: int) -> bool:
        """Read plain lines ``a..b-1`` in bulk; False when they need the slow path."""
        st = self.state
        if self.ended is not None or st.home_line is not None:
            return False
        motion = st.motion if isinstance(st.motion, Motion) else None
        result = read_run(columns, a, b, motion=None if motion is None else int(motion),
                          position=st.position, feed_rate=st.feed_rate,
                          incremental=st.incremental, inch=st.inch,
                          inverse_time=st.inverse_time)
        if result is None:
            return False
        k = len(result.index)
        mode = FeedMode.INVERSE_TIME if st.inverse_time else FeedMode.UNITS_PER_MINUTE
        table = np.empty((k, 11))
        table[:, :5] = result.joints
        table[:, 5] = result.motion
        table[:, 6] = int(mode)
        table[:, 7] = result.feed
        table[:, 8] = result.index + 1
        table[:, 9] = st.tcp_g43 or st.tcp_kins
        table[:, 10] = st.tool
        self.flush()
        self.chunks.append(table)
        if result.last_motion is not None:
            st.motion = Motion(result.last_motion)
        st.position = result.position
        st.feed_rate = result.feed_rate
        return True

    def flush(self) -> None:
        if self.rows:
            self.chunks.append(np.array(self.rows, dtype=np.float64).reshape(-1, 11))
            self.rows = []

    def block(self, block: Block) -> None:
        st = self.state
        words = block.words
        if block.block_delete:
            self.notes.append(NcNote(block.line, "block-delete '/' block read as executed"))
        if "O" in words and (len(words) > 1 or block.g or block.m):
            raise self.error(block, "program number O shares its line with other words", "O",
                             words["O"], "O1234 alone on its line")
        inch_before = st.inch  # RS274 order: F (step 3) is read before G20/G21 (step 14)
        inverse_before = st.inverse_time
        motion = self.modal_codes(block)
        if st.inverse_time != inverse_before:
            st.feed_rate = None  # a feed mode change leaves no feed rate in force
        if "F" in words:
            if not words["F"] >= 0.0:
                raise self.error(block, "negative feed", "F", words["F"], "F >= 0")
            scale = MM_PER_INCH if (inch_before and not st.inverse_time) else 1.0
            st.feed_rate = words["F"] * scale
        if "T" in words:
            st.selected_tool = int(words["T"])
        if 60 in block.m:
            st.tool = st.selected_tool
        for code in block.m:
            self.m_code(block, code)
        axes = [letter for letter in AXIS_COLUMNS if letter in words]
        bad_axes = [letter for letter in "BUVW" if letter in words]
        if bad_axes:
            raise self.error(block, f"axis {bad_axes[0]} is not a joint of an XYZAC machine",
                             bad_axes[0], words[bad_axes[0]], "axis words X Y Z A C")
        if 280 in block.g or 300 in block.g:
            self.home(block, axes)
        elif axes or (20 in block.g or 30 in block.g):  # "G2 I5": a full circle in place
            self.move(block, motion, axes)
        if any(code in (20, 300) for code in block.m):
            self.ended = block.line

    def modal_codes(self, block: Block) -> Motion | str | None:
        """Apply the block's G codes; return the motion mode for this block."""
        st = self.state
        motions = [g for g in block.g if g in _MOTION]
        if len(motions) > 1:
            raise self.error(block, "two motion codes in one block", "G",
                             [f"G{m / 10:g}" for m in motions], "one of G0, G1, G2, G3, G80")
        for g in block.g:
            if g in UNSUPPORTED_G:
                raise self.error(block, f"G{g / 10:g} ({UNSUPPORTED_G[g]}) is not supported",
                                 "G", f"G{g / 10:g}", "G0 G1 G2 G3 G17 G20 G21 G28 G40 G43 "
                                 "G43.4 G49 G53 G54-G59 G61 G64 G80 G90 G91 G93 G94")
            elif g == 930:
                st.inverse_time = True
            elif g == 940:
                st.inverse_time = False
            elif g in (200, 210):
                st.inch = g == 200
            elif g in (900, 910):
                st.incremental = g == 910
            elif g in (901, 911):
                st.arc_incremental = g == 911
            elif g in (180, 190):
                st.plane_xy = False
            elif g == 170:
                st.plane_xy = True
            elif g == 434:
                st.tcp_g43 = True
            elif g in (430, 490):
                st.tcp_g43 = False
                if g == 430:
                    self.notes.append(NcNote(block.line, "G43 tool length offset: X Y Z stay "
                                             "the programmed tool tip"))
            elif g in WORK_OFFSET_G:
                self.notes.append(NcNote(block.line, f"G{g / 10:g}: work offset taken as the "
                                         "workpiece frame (offset zero)"))
            elif g == 40:
                self.notes.append(NcNote(block.line, "G4 dwell ignored (no motion)"))
            elif g in (280, 300, 530, 0, 10, 20, 30) or g in SILENT_G:
                pass
            else:
                raise self.error(block, f"unknown G code G{g / 10:g}", "G", f"G{g / 10:g}",
                                 "the G codes listed in docs/formats.md")
        if motions:
            st.motion = _MOTION[motions[0]]
        return st.motion

    def m_code(self, block: Block, code: int) -> None:
        if code % 10:
            raise self.error(block, f"unknown M code M{code / 10:g}", "M", f"M{code / 10:g}",
                             "integer M codes")
        number = code // 10
        if number in self.switchkins:
            self.state.tcp_kins = self.switchkins[number]
        elif number == 430:
            raise self.error(block, "M430 selects user kinematics whose joints are unknown",
                             "M", "M430", "M428 (TCP kinematics) or M429 (identity kinematics)")
        elif number in (2, 30, 6) or number in SILENT_M:
            pass
        else:
            self.notes.append(NcNote(block.line, f"M{number} ignored (no motion meaning)"))

    def home(self, block: Block, axes: list[str]) -> None:
        """G28/G30: through the intermediate point to the machine's reference position."""
        st = self.state
        if self.home_position is None:
            st.home_line = block.line
            self.notes.append(NcNote(block.line, "G28/G30 reference return: the reference "
                                     "position is not known; no motion may follow it"))
            return
        if st.home_line is not None:
            raise self.error(block, "motion after a reference return with no known "
                             f"reference position (line {st.home_line})", "G28", st.home_line,
                             "a reference position (home) given to the reader")
        via = self.target(block, axes, machine=False)
        goal = via.copy()
        homed = [AXIS_COLUMNS[a] for a in axes] if axes else list(range(5))
        goal[homed] = self.home_position[homed]
        mode = FeedMode.INVERSE_TIME if st.inverse_time else FeedMode.UNITS_PER_MINUTE
        self.emit(np.stack([via, goal]), Motion.RAPID, mode, math.nan, block.line, False)

    def target(self, block: Block, axes: list[str], machine: bool) -> np.ndarray:
        st = self.state
        end = st.position.copy()
        scale = MM_PER_INCH if st.inch else 1.0
        for letter in axes:
            j = AXIS_COLUMNS[letter]
            value = block.words[letter]
            value = value * scale if j < 3 else math.radians(value)
            end[j] = end[j] + value if (st.incremental and not machine) else value
        return end

    def move(self, block: Block, motion: Motion | str | None, axes: list[str]) -> None:
        st = self.state
        if st.home_line is not None:
            raise self.error(block, f"motion after the G28/G30 reference return on line "
                             f"{st.home_line}", "G28", st.home_line,
                             "G28/G30 only at the end of the program")
        if motion is None:
            raise self.error(block, "axis words without a motion mode (G80 in force)", "G",
                             "G80", "G0, G1, G2 or G3 before or in this block")
        machine = 530 in block.g
        if machine and (motion not in (Motion.RAPID, Motion.LINEAR) or st.incremental):
            raise self.error(block, "G53 needs G0 or G1 in absolute mode (G90)", "G53",
                             "G53", "G53 G0/G1 with G90")
        end = self.target(block, axes, machine)
        tcp = (st.tcp_g43 or st.tcp_kins) and not machine
        mode = FeedMode.INVERSE_TIME if st.inverse_time else FeedMode.UNITS_PER_MINUTE
        if motion == Motion.RAPID:
            self.emit(end[None, :], Motion.RAPID, mode, math.nan, block.line, tcp)
            return
        feed = self.feed(block)
        if motion == Motion.LINEAR:
            self.emit(end[None, :], Motion.LINEAR, mode, feed, block.line, tcp)
            return
        points = self.arc(block, end, motion == "cw")
        if st.inverse_time:
            feed *= len(points)  # each chord takes its share of the block's 1/F minutes
        self.emit(points, Motion.LINEAR, mode, feed, block.line, tcp)

    def feed(self, block: Block) -> float:
        st = self.state
        if st.inverse_time:
            if "F" not in block.words or not block.words["F"] > 0.0:
                raise self.error(block, "inverse-time (G93) feed move without its own F word",
                                 "F", block.words.get("F"), "F > 0 on every G93 G1/G2/G3 block")
            return block.words["F"]
        if st.feed_rate is None or not st.feed_rate > 0.0:
            raise self.error(block, "feed move with no feed rate in force", "F", st.feed_rate,
                             "an F word > 0 before or in this block")
        return st.feed_rate

    def arc(self, block: Block, end: np.ndarray, clockwise: bool) -> np.ndarray:
        st = self.state
        if not st.plane_xy:
            raise self.error(block, "arcs outside the XY plane (G18/G19) are not supported",
                             "G", "G18/G19", "G17 arcs")
        return arc_block_points(block.words, st.position, end, clockwise=clockwise,
                                scale=MM_PER_INCH if st.inch else 1.0,
                                centre_incremental=st.arc_incremental,
                                tolerance=self.tolerance, line=block.line, source=self.source)

    def emit(self, points: np.ndarray, motion: Motion, mode: FeedMode, feed: float, line: int,
             tcp: bool) -> None:
        tool = self.state.tool
        for p in points.tolist():
            self.rows.append((*p, int(motion), int(mode), feed, line, tcp, tool))
        self.state.position = points[-1].copy()

    def program(self, start: np.ndarray) -> MachineProgram:
        self.flush()
        table = np.concatenate(self.chunks) if self.chunks else np.zeros((0, 11))
        return MachineProgram(
            joints=table[:, :5], motion=table[:, 5].astype(np.int8),
            feed_mode=table[:, 6].astype(np.int16), feed=table[:, 7],
            line=table[:, 8].astype(np.int64), tcp=table[:, 9].astype(bool),
            tool_number=table[:, 10].astype(np.int32),
            start=start,
        )


def parse_nc_document(text: str, source: str = "<string>", *,
                      chordal_tolerance: float | None = None,
                      start: Sequence[float] | None = None,
                      switchkins: Mapping[int, bool] | None = None,
                      home: Sequence[float] | None = None,
                      dialect: str | None = None,
                      machine: Machine | None = None) -> NcDocument:
    """Parse G-code text into joint-space blocks and notes (see ``parse_nc``).

    ``dialect`` (``gcode``, ``sinumerik``, ``heidenhain``; default: detected from the
    file name and text) selects a line-for-line translation to RS274 first
    (``postproc.nc_controls``); ``machine`` is needed for tool-direction vectors.
    """
    text = text.removeprefix("\ufeff")
    kind = detect_dialect(text, source) if dialect is None else dialect
    if kind not in DIALECTS:
        raise InputError("unknown NC dialect", field="dialect", value=dialect,
                         accepted=", ".join(DIALECTS))
    if kind != "gcode":
        text = translate(text, kind, source, machine)
        switchkins = {TCP_ON_M: True, TCP_OFF_M: False}
    tolerance = DEFAULT_TOLERANCES.chordal if chordal_tolerance is None else chordal_tolerance
    if not tolerance > 0.0:
        raise ValueError(f"chordal_tolerance must be positive, not {tolerance}")
    origin = np.zeros(5) if start is None else np.asarray(start, dtype=np.float64).reshape(5)
    reference = None if home is None else np.asarray(home, dtype=np.float64).reshape(5)
    reader = _Reader(source, tolerance, origin,
                     SWITCHKINS_TCP if switchkins is None else switchkins, reference)
    collecting = gc.isenabled()
    gc.disable()  # one tuple per slow block: the cyclic collector would rescan them all
    try:
        reader.run(text)
    finally:
        if collecting:
            gc.enable()
    return NcDocument(reader.program(origin), reader.notes)


def parse_nc(text: str, source: str = "<string>", *, chordal_tolerance: float | None = None,
             start: Sequence[float] | None = None,
             switchkins: Mapping[int, bool] | None = None,
             home: Sequence[float] | None = None, dialect: str | None = None,
             machine: Machine | None = None) -> MachineProgram:
    """Parse G-code text into a ``MachineProgram`` whose blocks keep their source lines.

    Parameters
    ----------
    text : str
        The program.
    source : str
        Name used in error messages.
    chordal_tolerance : float, optional
        Largest distance, mm, between a G2/G3 arc and its chords. Default
        ``DEFAULT_TOLERANCES.chordal`` (0.01 mm).
    start : (5,) sequence of float, optional
        Joints before the first block, X Y Z mm and A C rad. Default zeros.
    switchkins : mapping of int to bool, optional
        M code -> tool-centre-point on/off. Default ``SWITCHKINS_TCP`` (M428 on, M429 off).
    home : (5,) sequence of float, optional
        Machine reference position (joints, mm and rad) for G28/G30. Without it a
        reference return is a note when nothing moves after it, an error otherwise.
    dialect : str, optional
        ``gcode``, ``sinumerik`` or ``heidenhain``; default: detected (``.mpf``/``.spf``
        and Siemens words -> sinumerik, ``.h`` and ``BEGIN PGM`` -> heidenhain).
    machine : Machine, optional
        Needed to read tool-direction vectors (``A3= B3= C3=``, ``LN ... TX TY TZ``):
        they become rotary joints through its inverse kinematics.

    Returns
    -------
    MachineProgram
        One row per motion block (several per linearised arc, all with the arc's line).

    Raises
    ------
    InputError
        A malformed or unsupported word or block, named by file, line, word and value.
    """
    return parse_nc_document(text, source, chordal_tolerance=chordal_tolerance, start=start,
                             switchkins=switchkins, home=home, dialect=dialect,
                             machine=machine).program


def read_nc(path: str | Path, **options: object) -> MachineProgram:
    """Read an NC file.

    Parameters
    ----------
    path : str or Path
        The NC program.
    **options
        Keyword options of ``parse_nc`` (``chordal_tolerance`` mm, ``start``,
        ``switchkins``, ``home``, ``dialect``, ``machine``).

    Returns
    -------
    MachineProgram
    """
    return read_nc_document(path, **options).program


def read_nc_document(path: str | Path, **options: object) -> NcDocument:
    """Read an NC file into blocks and notes (see ``parse_nc`` for ``options``)."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
    except OSError as error:
        raise InputError(f"cannot read the NC file: {error.strerror}", file=path,
                         accepted="a readable G-code file") from error
    return parse_nc_document(text, str(path), **options)  # type: ignore[arg-type]
