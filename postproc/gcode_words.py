"""The word level of ISO / RS274 G-code: one source line -> the words of its block.

Comments ``( ... )`` and ``; ...`` are removed, blanks are dropped (RS274 ignores
them, also inside numbers), letters are upper-cased, and the rest must be a run of
``letter number`` words. Parameters (``#``), expressions (``[...]``) and LinuxCNC
O-word control flow are rejected with an ``InputError`` naming the line; a plain
Fanuc program number (``O1234``) alone on its line is accepted.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from impeller_cam.errors import InputError

_COMMENT_RE = re.compile(r"\([^)]*\)")
_WORD_RE = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+))")
_BLOCK_RE = re.compile(r"(?:[A-Z][-+]?(?:\d+\.?\d*|\.\d+))*")
_BLANKS = str.maketrans("", "", " \t\f\v")

def gcode_key(value: float) -> int:
    """``G43.4`` -> 434, ``G1`` -> 10: an exact key for a G or M number."""
    return int(round(value * 10.0))


@dataclass
class Block:
    """The words of one block.

    Attributes
    ----------
    line : int
        1-based source line number.
    g : list of int
        G codes as ``gcode_key`` (ten times the number).
    m : list of int
        M codes as ``gcode_key``.
    words : dict of str to float
        Every other word, letter -> value as written (program units, degrees).
    block_delete : bool
        The line started with ``/``.
    """

    line: int
    g: list[int] = field(default_factory=list)
    m: list[int] = field(default_factory=list)
    words: dict[str, float] = field(default_factory=dict)
    block_delete: bool = False


def strip_comments(text: str, line: int, source: str) -> str:
    """Remove ``( ... )`` and ``; ...`` comments; an unclosed ``(`` is an error."""
    if "(" in text:
        text = _COMMENT_RE.sub("", text)
        if "(" in text or ")" in text:
            raise InputError(f"line {line}: unbalanced comment parentheses", file=source,
                             field="comment", value=text.strip()[:60],
                             accepted="comments written as ( text ) on one line")
    elif ")" in text:
        raise InputError(f"line {line}: ')' without '('", file=source, field="comment",
                         value=text.strip()[:60], accepted="comments written as ( text )")
    at = text.find(";")
    return text if at < 0 else text[:at]


def parse_block(text: str, line: int, source: str) -> Block | None:
    """Parse one source line into a ``Block``; None for a blank, ``%`` or comment line.

    Raises
    ------
    InputError
        Unsupported syntax (parameters, expressions, O-word control flow), a malformed
        word, or a letter repeated in one block.
    """
    code = strip_comments(text, line, source).translate(_BLANKS).upper()
    if not code or code == "%":
        return None
    block = Block(line)
    if code.startswith("/"):
        block.block_delete = True
        code = code[1:]
    if _BLOCK_RE.fullmatch(code) is None:
        _raise_malformed(code, line, source)
    for letter, number in _WORD_RE.findall(code):
        value = float(number)
        if letter == "G":
            block.g.append(gcode_key(value))
        elif letter == "M":
            block.m.append(gcode_key(value))
        elif letter in block.words:
            raise InputError(f"line {line}: word {letter} appears twice in one block",
                             file=source, field=letter, value=code,
                             accepted=f"one {letter} word per block")
        else:
            block.words[letter] = value
    return block


def _raise_malformed(code: str, line: int, source: str) -> None:
    """Name the first character of ``code`` that does not start a valid word."""
    position = 0
    for match in _WORD_RE.finditer(code):
        if match.start() != position:
            break
        position = match.end()
    rest = code[position:]
    if rest[:1] in ("#", "["):
        hint = "numeric words only: parameters (#) and expressions ([...]) are not supported"
    elif rest[:1] == "O" or code.startswith("O"):
        hint = "a program number O1234 alone; O-word subroutines and loops are not supported"
    else:
        hint = "words made of a letter and a number, such as G1 X10.5 F500"
    raise InputError(f"line {line}: malformed G-code word", file=source, field="word",
                     value=rest[:20] or code[:20], accepted=hint)


# Word tables of the NC reader (codes as ``gcode_key``: ten times the number).

#: Axis letters of an XYZAC machine -> column of ``MachineProgram.joints``.
AXIS_COLUMNS = {"X": 0, "Y": 1, "Z": 2, "A": 3, "C": 4}

#: G codes read silently: planes G17 (arcs check the plane), G40, G49, path control
#: G61/G61.1/G64, G69, canned-cycle return G98/G99, G15/G50 cancels, G80.
SILENT_G = frozenset({170, 400, 490, 610, 611, 640, 690, 980, 990, 150, 500, 800})

#: Work offsets G54..G59.3: read as the workpiece frame (offset zero), with a note.
WORK_OFFSET_G = frozenset({540, 550, 560, 570, 580, 590, 591, 592, 593})

#: M codes with no effect on positions, read silently: spindle, coolant, overrides.
SILENT_M = frozenset({3, 4, 5, 7, 8, 9, 48, 49, 50, 51, 52, 53})

#: G codes that change the tool path in ways this reader does not model -> refused.
UNSUPPORTED_G: dict[int, str] = {
    **{k: "canned cycles" for k in (730, 740, 760, 810, 820, 830, 840, 850, 860, 870, 880, 890)},
    **{k: "cutter radius compensation" for k in (410, 411, 420, 421)},
    **{k: "coordinate system changes" for k in (100, 520, 920, 921, 922, 923, 681, 682, 531)},
    **{k: "dynamic tool length offsets" for k in (431, 432, 435)},
    **{k: "probing" for k in (382, 383, 384, 385)},
    **{k: "splines, threading and rigid tapping" for k in (50, 51, 52, 330, 331)},
    **{k: "feed per revolution" for k in (950,)},
    **{k: "polar and scaled coordinates" for k in (160, 510, 511)},
    **{k: "rotated coordinates" for k in (680,)},
}
