"""HEIDENHAIN TNC Klartext programs -> ``Canon`` lines for the NC reader.

Accepted (the blocks the ``heidenhain`` post writes and common variants): block
numbers, ``;`` and ``*`` comments, ``BEGIN PGM ... MM|INCH``, ``END PGM``, ``BLK FORM``,
``TOOL DEF``, ``TOOL CALL n Z S.. F..`` (spindle axis Z), ``TOOL CALL S..``, ``CYCL
DEF 32`` (tolerance: no path meaning), ``FUNCTION TCPM F TCP|F CONT AXIS POS PATHCTRL
AXIS|VECTOR`` and ``FUNCTION RESET TCPM``, ``L`` blocks with ``X Y Z A C``, ``R0``,
``F``, ``FMAX`` (rapid in its block only), ``M`` functions (``M128``/``M129``: TCP
on/off, ``M91``: machine coordinates), ``LN`` blocks with tool vectors ``TX TY TZ``,
``STOP``. Refused with a message: ``LBL`` / ``CALL LBL`` repeats and subprograms,
``Q`` parameters and ``FN``, arcs and approach/departure (``CC C CR CT RND CHF APPR
DEP``), radius compensation ``RL``/``RR``, incremental ``IX..``, ``PLANE`` other than
``SPATIAL`` / ``AXIAL`` / ``RESET`` (3+2 frames: the rotary axes are taken at the frame's
positions, ``TURN``/``STAY`` alike),
``FUNCTION TCPM ... AXIS SPAT``, other cycles, 3-D compensation ``NX NY NZ``.
"""

from __future__ import annotations

import re

from postproc.nc_controls import TCP_OFF_M, TCP_ON_M, Canon, refuse

_NUMBERED = re.compile(r"^\s*(\d+)\s*(.*)$")
_WORD = re.compile(r"^([A-Z]+)([-+]?(?:\d+\.?\d*|\.\d+))?$")
_ACCEPTED = ("BEGIN/END PGM, TOOL CALL, CYCL DEF 32, FUNCTION TCPM / RESET TCPM, L and LN "
             "blocks with X Y Z A C TX TY TZ R0 F FMAX M, STOP, comments")
#: Block openings refused, with the reason.
_REFUSED = {
    "LBL": "labels and LBL repeats are not supported",
    "CALL": "CALL LBL / CALL PGM (subprograms and repeats) are not supported",
    "FN": "FN parameter functions are not supported",
    "CC": "circle centres and arcs are not supported", "C": "arcs are not supported",
    "CR": "arcs are not supported", "CT": "arcs are not supported",
    "CP": "helices are not supported", "RND": "roundings are not supported",
    "CHF": "chamfers are not supported", "APPR": "approach contours are not supported",
    "DEP": "departure contours are not supported",
    "CYCL": "cycles other than CYCL DEF 32 are not supported",
}


#: A plain straight line (most of a posted program): read without the word loop.
_SIMPLE_L = re.compile(
    "".join(rf"(?: {k}(?P<{k}>[-+]?(?:\d+\.?\d*|\.\d+)))?" for k in "XYZAC")
    + r"(?P<rapid> R0 FMAX)?(?: F(?P<F>\d+\.?\d*|\.\d+))?")


def _plain_l(rest: str) -> str | None:
    """``" X+1 Y-2 R0 FMAX"`` -> ``"G0 X+1 Y-2"``; None unless a plain straight line."""
    simple = _SIMPLE_L.fullmatch(rest)
    if simple is None or not any(simple.group(k) for k in "XYZAC"):
        return None
    if simple.group("rapid"):
        return None if simple.group("F") else "G0" + rest.replace(" R0 FMAX", "")
    return "G1" + rest


_SIMPLE_LN = re.compile(
    "".join(rf"(?: {k}(?P<{k}>[-+]?(?:\d+\.?\d*|\.\d+)))?" for k in "XYZ")
    + "".join(rf" {k}(?P<{k}>[-+]?(?:\d+\.?\d*|\.\d+))" for k in ("TX", "TY", "TZ"))
    + r"(?P<rapid> R0 FMAX)?(?: F(?P<F>\d+\.?\d*|\.\d+))?")


def _l_block(words: list[str], line: int, source: str, vector_block: bool) -> Canon:
    if vector_block:
        simple = _SIMPLE_LN.fullmatch(" " + " ".join(words))
        if simple is not None and (simple.group("rapid") is None or simple.group("F") is None):
            found = {k: v for k, v in simple.groupdict().items()
                     if v is not None and k in "XYZF"}
            direction = (float(simple.group("TX")), float(simple.group("TY")),
                      float(simple.group("TZ")))
            return Canon(g=["G0" if simple.group("rapid") else "G1"], words=found,
                         vector=direction)
    else:
        simple = _SIMPLE_L.fullmatch(" " + " ".join(words))
        if simple is not None and (simple.group("rapid") is None or simple.group("F") is None):
            found = {k: v for k, v in simple.groupdict().items()
                     if v is not None and k != "rapid"}
            if any(k in found for k in "XYZAC"):
                return Canon(g=["G0" if simple.group("rapid") else "G1"], words=found)
    canon = Canon()
    vector: dict[str, float] = {}
    rapid = False
    for word in words:
        match = _WORD.match(word)
        if match is None:
            raise refuse(source, line, "malformed word in an L block", "word", word, _ACCEPTED)
        address, number = match.group(1), match.group(2)
        if address in ("X", "Y", "Z", "A", "C", "B") and number is not None:
            canon.words[address] = number
        elif address in ("TX", "TY", "TZ") and number is not None and vector_block:
            vector[address] = float(number)
        elif address == "FMAX" and number is None:
            rapid = True
        elif address == "F" and number is not None:
            canon.words["F"] = number
        elif address == "R" and number == "0":
            continue
        elif address == "M" and number is not None:
            code = int(float(number))
            if code == 128:
                canon.m.append(TCP_ON_M)
            elif code == 129:
                canon.m.append(TCP_OFF_M)
            elif code == 91:
                canon.g.append("G53")
            elif code in (126, 127, 136, 137):
                continue  # rotary shortest path / feed unit switches read as written
            else:
                canon.m.append(code)
        else:
            what = {"RL": "radius compensation", "RR": "radius compensation",
                    "IX": "incremental coordinates", "IY": "incremental coordinates",
                    "IZ": "incremental coordinates", "IA": "incremental coordinates",
                    "IC": "incremental coordinates", "NX": "3-D tool compensation",
                    "NY": "3-D tool compensation", "NZ": "3-D tool compensation",
                    "FAUTO": "FAUTO feed", "FU": "feed per revolution",
                    "FZ": "feed per tooth"}.get(address, f"the word {word}")
            raise refuse(source, line, f"{what} is not supported", "word", word, _ACCEPTED)
    if "F" in canon.words and rapid:
        raise refuse(source, line, "F and FMAX in one block", "F", canon.words["F"],
                     "F or FMAX")
    if vector:
        canon.vector = (vector.get("TX", 0.0), vector.get("TY", 0.0), vector.get("TZ", 0.0))
    if any(k in canon.words for k in "XYZABC") or canon.vector is not None:
        canon.g.insert(0, "G0" if rapid else "G1")
    return canon


def _plane(words: list[str], line: int, source: str, text: str) -> tuple[object, ...]:
    """``PLANE RESET``, ``PLANE SPATIAL SPA SPB SPC``, ``PLANE AXIAL A C`` (+ TURN/STAY)."""
    accepted = "PLANE SPATIAL SPA.. SPB.. SPC.., PLANE AXIAL A.. C.., PLANE RESET"
    if not words or words[0] not in ("RESET", "SPATIAL", "AXIAL"):
        raise refuse(source, line, "this PLANE function is not supported", "PLANE", text[:40],
                     accepted)
    if words[0] == "RESET":
        return ("reset",)
    names = ("SPA", "SPB", "SPC") if words[0] == "SPATIAL" else ("A", "C")
    values: dict[str, float] = {}
    for word in words[1:]:
        match = _WORD.match(word)
        if match and match.group(1) in names and match.group(2) is not None:
            values[match.group(1)] = float(match.group(2))
        elif word in ("TURN", "MOVE", "STAY", "MB", "MAX", "FMAX", "MB0", "SEQ+", "SEQ-",
                      "SYM+", "SYM-", "TABLE", "ROT", "COORD") or re.fullmatch(
                          r"(MB|F|DIST)\+?\d*\.?\d*", word):
            continue
        else:
            raise refuse(source, line, "unknown PLANE word", "PLANE", word, accepted)
    if words[0] == "SPATIAL":
        return ("spatial", values.get("SPA", 0.0), values.get("SPB", 0.0),
                values.get("SPC", 0.0))
    return ("axial", values.get("A", 0.0), values.get("C", 0.0))


def _tool_call(rest: list[str], line: int, source: str) -> Canon:
    canon = Canon()
    for word in rest:
        if re.fullmatch(r"\d+", word):
            canon.words["T"] = word
            canon.m.append(6)
        elif word.startswith('"'):
            raise refuse(source, line, "tools called by name are not supported", "TOOL CALL",
                         word, "TOOL CALL <number> Z S<rpm>")
        elif word in ("X", "Y"):
            raise refuse(source, line, "spindle axis other than Z", "TOOL CALL", word,
                         "TOOL CALL n Z")
        elif word == "Z":
            continue
        elif re.fullmatch(r"S[-+]?\d+\.?\d*", word):
            canon.words["S"] = word[1:]
        elif re.fullmatch(r"(F|DL|DR|DR2)[-+]?\d*\.?\d*", word):
            if word.startswith("DL") and float(word[2:] or 0) != 0.0:
                raise refuse(source, line, "a tool length delta DL is not supported",
                             "TOOL CALL", word, "DL+0 or no DL")
        else:
            raise refuse(source, line, "unknown TOOL CALL word", "TOOL CALL", word,
                         "TOOL CALL n Z S.. F.. DL.. DR..")
    return canon


def heidenhain_canons(text_lines: list[str], source: str,
                      plain: bool = False) -> list[Canon | str | None]:
    """One ``Canon`` (or None) per physical line of a Klartext program.

    With ``plain`` (a program without vectors and frames) a plain ``L`` line comes
    back as its RS274 text, which is much faster.

    Raises
    ------
    impeller_cam.errors.InputError
        An unsupported block, naming the file, line, word and what is accepted.
    """
    out: list[Canon | str | None] = []
    for index, raw in enumerate(text_lines):
        line = index + 1
        text = raw.strip()
        match = _NUMBERED.match(text)
        if match:
            text = match.group(2).strip()
        if plain and text[:2] == "L " and ";" not in text:
            quick = _plain_l(text[1:])
            if quick is not None:
                out.append(quick)
                continue
        code = text.split(";", 1)[0].strip().upper()
        words = code.split()
        if not words or code.startswith("*"):
            out.append(None)
            continue
        head = words[0]
        canon: Canon | None = None
        if head in ("L", "LN"):
            canon = _l_block(words[1:], line, source, head == "LN")
        elif code.startswith("BEGIN PGM"):
            canon = Canon(g=["G20"]) if words[-1] == "INCH" else None
        elif code.startswith("END PGM"):
            canon = Canon(m=[2])
        elif code.startswith(("BLK FORM", "TOOL DEF")) or head == "STOP" and len(words) == 1:
            canon = None
        elif code.startswith("TOOL CALL"):
            canon = _tool_call(words[2:], line, source)
        elif code.startswith("CYCL DEF 32"):
            canon = None
        elif head == "PLANE":
            canon = Canon(frame=_plane(words[1:], line, source, text))
        elif code.startswith("FUNCTION RESET TCPM"):
            canon = Canon(m=[TCP_OFF_M])
        elif code.startswith("FUNCTION TCPM"):
            if "AXIS SPAT" in code:
                raise refuse(source, line, "spatial angles (AXIS SPAT) are not supported",
                             "FUNCTION TCPM", "AXIS SPAT", "AXIS POS")
            canon = Canon(m=[TCP_ON_M])
        elif head in _REFUSED or re.match(r"Q\d+", head):
            reason = _REFUSED.get(head, "Q parameters are not supported")
            raise refuse(source, line, reason, "block", text[:40], _ACCEPTED)
        else:
            raise refuse(source, line, "unknown block", "block", text[:40], _ACCEPTED)
        out.append(canon)
    return out
