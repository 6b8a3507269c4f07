"""Reading Sinumerik and Heidenhain programs: line-for-line translation to RS274 blocks.

The NC reader (``postproc.nc_reader``) interprets RS274 blocks. A Siemens or
Heidenhain program is first translated line for line (line ``k`` stays line ``k``, so
every block, note and event keeps its source line) into the few RS274 words that
carry the same meaning: ``TRAORI`` / ``FUNCTION TCPM`` / ``M128`` become the reader's
TCP-on code ``M428``, ``TRAFOOF`` / ``FUNCTION RESET TCPM`` / ``M129`` its TCP-off
``M429``, ``FMAX`` a ``G0``, ``TOOL CALL 3`` a ``T3 M6``. The dialect parsers
(``postproc.nc_sinumerik``, ``postproc.nc_heidenhain``) turn each line into a
``Canon`` record; ``emit_rs274`` writes them, after turning tool-direction vectors
(``A3= B3= C3=``, ``TX TY TZ``) into rotary joints with the machine's inverse
kinematics (continuous from the joints before, as the post chose them).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from impeller_cam.errors import InputError

if TYPE_CHECKING:
    from postproc.machine import Machine

#: Dialects the reader knows.
DIALECTS = ("gcode", "sinumerik", "heidenhain")

#: RS274 codes the translation uses for tool-centre-point control on / off.
TCP_ON_M, TCP_OFF_M = 428, 429

#: Words whose translation needs the positions (vectors, tilted frames).
_NEEDS_TRACKING = re.compile(r"[ABC]3[ \t]*=|CYCLE800|LN[ \t]|PLANE|T[XYZ][ \t]*[-+\d.]")
_HEIDENHAIN_START = re.compile(r"^\s*\d*\s*BEGIN\s+PGM\b", re.IGNORECASE)
_COMMENTS = re.compile(r"\([^)\n]*\)|;[^\n]*")
_SINUMERIK_HINT = re.compile(
    r"^\s*%_N_|\b(TRAORI|TRAFOOF|CYCLE8\d\d|ORIWKS|[XYZAC]3?\s*=)|T\s*=\s*\"",
    re.IGNORECASE | re.MULTILINE)


@dataclass
class Canon:
    """One source line in RS274 terms.

    Attributes
    ----------
    g : list of str
        G words in order (``"G1"``, ``"G94"``).
    words : dict of str to str
        X Y Z A C F S T I J K values as written (signs kept), by letter.
    m : list of int
        M codes (``428``/``429`` for tool-centre-point on / off).
    vector : tuple of float or None
        Tool-direction vector of the block (workpiece frame), when programmed.
    frame : tuple or None
        A tilted frame set on this line: ``("axial", a, c)`` (rotary positions, deg)
        or ``("spatial", spa, spb, spc)`` (spatial angles, deg); ``("reset",)`` ends it.
    """

    g: list[str] = field(default_factory=list)
    words: dict[str, str] = field(default_factory=dict)
    m: list[int] = field(default_factory=list)
    vector: tuple[float, float, float] | None = None
    frame: tuple[Any, ...] | None = None

    def text(self) -> str:
        """The RS274 line (axis words in X Y Z A C order for the reader's fast path)."""
        parts = list(self.g)
        parts += [f"{k}{self.words[k]}" for k in "XYZACIJKFST" if k in self.words]
        parts += [f"M{code}" for code in self.m]
        return " ".join(parts)


def detect_dialect(text: str, source: str | Path = "") -> str:
    """``gcode``, ``sinumerik`` or ``heidenhain`` from the file extension and text."""
    suffix = Path(str(source)).suffix.lower()
    if suffix in (".h",):
        return "heidenhain"
    if suffix in (".mpf", ".spf"):
        return "sinumerik"
    if suffix in (".ngc", ".gcode", ".tap"):
        return "gcode"
    head = text.lstrip("\ufeff").lstrip()[:200]
    if _HEIDENHAIN_START.match(head):
        return "heidenhain"
    code = _COMMENTS.sub("", text[:200_000])  # words in comments say nothing
    if _SINUMERIK_HINT.search(code):
        return "sinumerik"
    return "gcode"


def refuse(source: str, line: int, message: str, field: str, value: object,
           accepted: str) -> InputError:
    """The error of an unsupported word, naming file, line, word and what is accepted."""
    return InputError(f"line {line}: {message}", file=source, field=field, value=value,
                      accepted=accepted)


def number_text(value: float, decimals: int = 9) -> str:
    """A plain decimal (no exponent) with trailing zeros dropped."""
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def emit_rs274(canons: list[Canon | str | None], source: str,
               machine: Machine | None) -> str:
    """RS274 text, one line per entry (``None``: an empty line, ``str``: as it is).

    Text entries come only from programs without vectors and frames (the positions
    they would move are then not needed).

    Tool-direction vectors become ``A`` and ``C`` words: runs of vector blocks are
    solved with the machine's inverse kinematics (tip: the programmed X, Y, Z in the
    world frame), continuous from the rotary joints in force before the run.

    Raises
    ------
    InputError
        Vectors without a machine, or vector blocks programmed incrementally.
    """
    position = {letter: 0.0 for letter in "XYZAC"}
    tilted = _Tilted(machine, source)
    run: list[int] = []
    tips: list[tuple[float, float, float]] = []
    incremental = False

    def close_run() -> None:
        if not run:
            return
        joints = vector_joints(machine, np.array(tips),
                               np.array([canons[i].vector for i in run]),  # type: ignore[union-attr]
                               (position["A"], position["C"]), source, run[0] + 1)
        for i, (a, c) in zip(run, joints, strict=True):
            entry = canons[i]
            assert isinstance(entry, Canon)
            entry.words["A"] = number_text(a)
            entry.words["C"] = number_text(c)
        position["A"], position["C"] = joints[-1]
        run.clear()
        tips.clear()

    for index, entry in enumerate(canons):
        if entry is None or isinstance(entry, str):
            continue
        if "G91" in entry.g:
            incremental = True
        elif "G90" in entry.g:
            incremental = False
        if entry.frame is not None or tilted.active:
            close_run()
            tilted.apply(entry, index + 1, incremental, (position["A"], position["C"]))
            for letter in "XYZAC":
                if letter in entry.words:
                    position[letter] = float(entry.words[letter])
            continue
        if entry.vector is not None and ("A" in entry.words or "C" in entry.words):
            raise refuse(source, index + 1, "a block with both rotary positions and a tool "
                         "vector", "A3/TX", entry.text(), "rotary positions or a vector")
        if ("A" in entry.words or "C" in entry.words) and run:
            close_run()
        for letter in "XYZAC":
            if letter in entry.words and not incremental:
                position[letter] = float(entry.words[letter])
        if entry.vector is not None:
            if incremental:
                raise refuse(source, index + 1, "tool vectors in incremental mode (G91)",
                             "G91", "G91", "absolute coordinates (G90) with tool vectors")
            if machine is None:
                raise refuse(source, index + 1, "tool-direction vectors need the machine's "
                             "kinematics to be read", "A3/TX", list(entry.vector),
                             "read the program with the machine (impeller-cam verify -m)")
            run.append(index)
            tips.append((position["X"], position["Y"], position["Z"]))
    close_run()
    return "\n".join("" if entry is None else entry if isinstance(entry, str) else entry.text()
                      for entry in canons)


def vector_joints(machine: Machine | None, tips: np.ndarray, vectors: np.ndarray,
                  previous: tuple[float, float], source: str, line: int) -> np.ndarray:
    """Rotary joints (degrees, ``(n, 2)``) of tool vectors, continuous from ``previous``.

    ``tips`` (n, 3) are the programmed X, Y, Z (world frame, mm). Where the machine's
    limits admit no branch the limits are dropped (the verifier then reports the
    over-travel of the block instead of refusing the program).
    """
    from postproc.kinematics import kinematics_for
    from postproc.machine import ideal_machine

    assert machine is not None
    norm = np.linalg.norm(vectors, axis=1)
    if not np.all(norm > 1e-9):
        raise refuse(source, line, "a zero tool vector", "A3/TX", vectors[int(np.argmin(norm))]
                     .tolist(), "a non-zero direction vector")
    kins: Any = kinematics_for(machine)
    offset = np.asarray(kins.world_from_workpiece(np.zeros((1, 3))))[0]
    start = np.array([0.0, 0.0, 0.0, np.radians(previous[0]), np.radians(previous[1])])
    try:
        joints = kins.inverse(tips - offset, vectors, previous=start)
    except InputError:
        free = ideal_machine(machine.kinematics, machine.pivot, machine.conventional_directions)
        joints = kinematics_for(free).inverse(tips - offset, vectors, previous=start)
    return np.degrees(joints[:, 3:])


def translate(text: str, dialect: str, source: str, machine: Machine | None) -> str:
    """A Sinumerik or Heidenhain program as RS274 text with the same line numbers."""
    from postproc.nc_heidenhain import heidenhain_canons
    from postproc.nc_sinumerik import sinumerik_canons

    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    plain = _NEEDS_TRACKING.search(text.upper()) is None  # no vectors, no frames: fast
    canons = (sinumerik_canons if dialect == "sinumerik" else heidenhain_canons)(
        lines, source, plain)
    return emit_rs274(canons, source, machine)


class _Tilted:
    """The tilted frame in force (Sinumerik CYCLE800, Heidenhain PLANE) while translating.

    Blocks in the frame program the tip in frame coordinates ``p'``; they are written
    as tool-centre-point blocks (the reader's ``M428``): X, Y, Z the world tip
    ``R p'`` (plus the world offset of W), A, C the frame's rotary positions.
    """

    def __init__(self, machine: Machine | None, source: str) -> None:
        self.machine = machine
        self.source = source
        self.active = False
        self.rotation = np.eye(3)
        self.rotary = (0.0, 0.0)
        self.point = np.full(3, np.nan)  # p' in force
        self.offset = np.zeros(3)  # world position of the workpiece zero

    def apply(self, entry: Canon, line: int, incremental: bool,
              rotary_before: tuple[float, float]) -> None:
        frame = entry.frame
        if frame is not None and frame[0] == "reset":
            if not self.active:
                entry.frame = None
                return
            self.active = False
            entry.m.append(TCP_OFF_M)
            return
        if frame is not None:
            self.start(frame, line, rotary_before)
            entry.m.append(TCP_ON_M)
        bad = [k for k in ("A", "C") if k in entry.words] + (
            ["vector"] if entry.vector is not None else []) + (
            ["G91"] if incremental else []) + [f"M{m}" for m in entry.m
                                               if m in (TCP_ON_M, TCP_OFF_M) and frame is None]
        if bad:
            raise refuse(self.source, line, "rotary words, vectors, incremental moves or TCP "
                         "switches inside a tilted frame are not supported", "word", bad[0],
                         "X Y Z moves in the tilted frame, then the frame reset")
        moved = [k for k in "XYZ" if k in entry.words]
        if not moved:
            return
        for j, letter in enumerate("XYZ"):
            if letter in entry.words:
                self.point[j] = float(entry.words[letter])
        if not np.isfinite(self.point).all():
            raise refuse(self.source, line, "the first move in a tilted frame must program X, "
                         "Y and Z", "word", moved, "X.. Y.. Z.. after CYCLE800 / PLANE")
        world = self.rotation @ self.point + self.offset
        for j, letter in enumerate("XYZ"):
            entry.words[letter] = number_text(world[j])
        entry.words["A"] = number_text(self.rotary[0])
        entry.words["C"] = number_text(self.rotary[1])

    def start(self, frame: tuple[Any, ...], line: int, before: tuple[float, float]) -> None:
        from postproc.kinematics import kinematics_for
        from postproc.posts.frames import frame_rotation, rotation_from_spatial

        if self.machine is None:
            raise refuse(self.source, line, "tilted frames need the machine's kinematics to "
                         "be read", "frame", frame[0], "read the program with the machine "
                         "(impeller-cam verify -m)")
        kins: Any = kinematics_for(self.machine)
        self.offset = np.asarray(kins.world_from_workpiece(np.zeros((1, 3))))[0]
        if frame[0] == "axial":
            self.rotary = (float(frame[1]), float(frame[2]))
            self.rotation = frame_rotation(kins, np.radians([self.rotary]))[0]
        else:
            self.rotation = rotation_from_spatial(np.array(frame[1:4], dtype=np.float64))
            axis = self.rotation @ np.array([0.0, 0.0, 1.0])
            joints = vector_joints(self.machine, np.zeros((1, 3)), axis[None, :], before,
                                   self.source, line)[0]
            self.rotary = (float(joints[0]), float(joints[1]))
        self.active = True
        self.point = np.full(3, np.nan)
