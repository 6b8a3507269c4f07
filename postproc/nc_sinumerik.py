"""SINUMERIK 840D sl programs -> ``Canon`` lines for the NC reader.

Accepted (Siemens mode, the words the ``sinumerik`` post writes and common variants):
``N`` numbers, ``;`` comments, ``%_N_..._MPF`` headers, ``G0 G1 G2 G3 G17 G40 G53
G54..G57 G500 G90 G91 G93 G94``, ``G70/G700`` inch, ``G71/G710`` metric, blending and
exact stop ``G60 G64 G641 G642 G645 G9`` (no path meaning here), ``X Y Z`` and ``A C``
(also written ``A=``), direction vectors ``A3= B3= C3=``, ``F S M D``, ``T="name"`` /
``T=n`` / ``Tn``, ``TRAORI`` / ``TRAORI(n)`` (tool-centre-point on), ``TRAFOOF``,
``ORIWKS ORIAXES ORIVECT SOFT BRISK FFWON FFWOF UPATH SPATH COMPCAD COMPCURV COMPOF
G4``, ``CYCLE832(...)``, ``MSG(...)``. Refused with a message: arithmetic and
parameters (``R1=``, ``IC()``, ``DC()``), program flow (``GOTOF``, ``REPEAT``, labels),
frames (``TRANS``, ``ROT``), ``CYCLE800`` other than the direct rotary-axis swivel the
post writes (``_MODE`` 192, no offsets; ``CYCLE800()`` resets it), ``ORIMKS`` and other
cycles.
"""

from __future__ import annotations

import re

from postproc.nc_controls import TCP_OFF_M, TCP_ON_M, Canon, refuse

_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)"
_TOKEN = re.compile(
    rf"\s*(?:(?P<name>[A-Z_$][A-Z0-9_]*)\s*=\s*(?P<val>\"[^\"]*\"|{_NUM}|[A-Z_]+\s*\([^)]*\)|\S+)"
    rf"|(?P<call>[A-Z_][A-Z0-9_]*)\s*\((?P<args>[^)]*)\)"
    rf"|(?P<letter>[A-Z])\s*(?P<num>{_NUM})"
    rf"|(?P<kw>[A-Z_][A-Z0-9_]*))",
    re.IGNORECASE,
)

#: A plain motion line (most of a posted program): read without the tokenizer.
_SIMPLE = re.compile(
    r"(?:N\d+\s+)?(?:(?P<m>G0?[0-3])\s+)?(?:(?P<f>G9[34])\s+)?"
    + "".join(rf"(?:{k}\s*=?\s*(?P<{k}>{_NUM})\s*)?" for k in "XYZAC")
    + "".join(rf"(?:{k}3\s*=\s*(?P<{k}3>{_NUM})\s*)?" for k in "ABC")
    + rf"(?:F\s*=?\s*(?P<F>{_NUM}))?")
_VECTOR_GROUPS = ("A3", "B3", "C3")
#: The same without vectors (lines kept as text in programs without vectors).
_PLAIN = re.compile(
    r"(?:N\d+\s+)?(?:G0?[0-3]\s+)?(?:G9[34]\s+)?"
    + "".join(rf"(?:{k}\s*=?\s*{_NUM}\s*)?" for k in "XYZAC") + rf"(?:F\s*=?\s*{_NUM})?")

#: Siemens G code -> the RS274 word with the same meaning ('' = no meaning here).
_G: dict[str, str] = {
    **{g: g for g in ("G0", "G1", "G2", "G3", "G17", "G18", "G19", "G40", "G53", "G54",
                      "G55", "G56", "G57", "G90", "G91", "G93", "G94")},
    "G70": "G20", "G700": "G20", "G71": "G21", "G710": "G21", "G500": "G54",
    **{g: "" for g in ("G9", "G60", "G64", "G641", "G642", "G645", "G4", "G601", "G602")},
}
#: Keywords without a path meaning for the verifier.
_SILENT = frozenset({"ORIWKS", "ORIAXES", "ORIVECT", "SOFT", "BRISK", "FFWON", "FFWOF",
                     "UPATH", "SPATH", "COMPCAD", "COMPCURV", "COMPOF", "DIAMOF", "CFC",
                     "CFTCP", "ORIEULER", "ORIRPY", "RET"})
_CALLS_SILENT = frozenset({"CYCLE832", "MSG", "CYCLE800RESET"})
_ACCEPTED = ("G0 G1 G2 G3 G17 G40 G54 G90 G91 G93 G94 G64 G642, X Y Z A= C= A3= B3= C3= "
             "F S M D T=, TRAORI TRAFOOF ORIWKS ORIAXES ORIVECT SOFT FFWON CYCLE832")


def _number(source: str, line: int, name: str, value: str) -> str:
    if re.fullmatch(_NUM, value.strip()) is None:
        raise refuse(source, line, f"{name}= with an expression is not supported", name,
                     value, "a plain number (no IC(), AC(), DC(), parameters or arithmetic)")
    return value.strip()


class SinumerikLines:
    """Parser state across lines (tool names -> numbers)."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.tools: dict[str, int] = {}

    def tool_number(self, name: str) -> int:
        """``"T12"``, ``"12"`` -> 12; other names get 1001, 1002, ... by first use."""
        match = re.fullmatch(r"T?(\d+)", name.strip().upper())
        if match:
            return int(match.group(1))
        return self.tools.setdefault(name, 1001 + len(self.tools))

    def parse(self, text: str, line: int) -> Canon | None:
        """The ``Canon`` of one source line (None: nothing to do)."""
        code = text.split(";", 1)[0].strip()
        if not code or code.startswith("%"):
            return None
        if code.startswith("/"):
            code = code[1:]
        upper = code.upper()
        simple = _SIMPLE.fullmatch(upper)
        if simple is not None:
            g = [f"G{int(x[1:])}" for x in (simple.group("m"), simple.group("f")) if x]
            found = simple.groupdict()
            parts = [found.pop(k) for k in _VECTOR_GROUPS]
            direction = None if parts == [None] * 3 else (
                float(parts[0] or 0.0), float(parts[1] or 0.0), float(parts[2] or 0.0))
            return Canon(g=g, words={k: v for k, v in found.items()
                                     if v is not None and k not in ("m", "f")},
                         vector=direction)
        canon = Canon()
        vector: dict[str, float] = {}
        pos = 0
        while pos < len(upper):
            match = _TOKEN.match(upper, pos)
            if match is None or match.end() == pos:
                rest = code[pos:].strip()
                if not rest:
                    break
                raise refuse(self.source, line, "malformed Sinumerik word", "word", rest[:20],
                             _ACCEPTED)
            pos = match.end()
            self.token(canon, vector, match, code[match.start():match.end()].strip(), line)
        if vector:
            if "G91" in canon.g:
                raise refuse(self.source, line, "tool vectors in incremental mode", "G91",
                             "G91", "G90 with A3= B3= C3=")
            canon.vector = (vector.get("A3", 0.0), vector.get("B3", 0.0),
                            vector.get("C3", 0.0))
        return canon

    def token(self, canon: Canon, vector: dict[str, float], match: re.Match[str],
              raw: str, line: int) -> None:
        """Apply one token to the line's ``Canon``."""
        src = self.source
        if match.group("name"):
            name, value = match.group("name"), match.group("val")
            if name in ("X", "Y", "Z", "A", "C", "F", "S"):
                canon.words[name] = _number(src, line, name, value)
            elif name in ("A3", "B3", "C3"):
                vector[name] = float(_number(src, line, name, value))
            elif name == "T":
                tool = raw.split("=", 1)[1].strip().strip('"')
                canon.words["T"] = str(self.tool_number(tool))
            else:
                raise refuse(src, line, f"assignment {name}= is not supported (parameters, "
                             "system variables and other axes)", name, raw, _ACCEPTED)
        elif match.group("call"):
            name = match.group("call")
            if name == "TRAORI":
                canon.m.append(TCP_ON_M)
            elif name == "CYCLE800":
                canon.frame = self.swivel(match.group("args"), raw, line)
            elif name not in _CALLS_SILENT:
                raise refuse(src, line, f"{name}(...) is not supported", name, raw, _ACCEPTED)
        elif match.group("letter"):
            self.word(canon, match.group("letter"), match.group("num"), line)
        else:
            keyword = match.group("kw")
            if keyword == "TRAORI":
                canon.m.append(TCP_ON_M)
            elif keyword == "TRAFOOF":
                canon.m.append(TCP_OFF_M)
            elif keyword not in _SILENT:
                what = {"ORIMKS": "orientation in the machine frame (ORIMKS)"}.get(
                    keyword, f"{keyword} (program flow, frames or an unknown keyword)")
                raise refuse(src, line, f"{what} is not supported", "word", keyword,
                             _ACCEPTED)

    def swivel(self, args: str, raw: str, line: int) -> tuple[object, ...]:
        """``CYCLE800()`` (reset) or the direct rotary-axis form the post writes."""
        values = [a.strip() for a in args.split(",")] if args.strip() else []
        if not values:
            return ("reset",)
        accepted = ('CYCLE800(_FR,"TC",0,192,0,0,0,<axis 1>,<axis 2>,0,0,0,0,_DIR,_FR_I,'
                    '_DMODE): rotary axes direct, no offsets; CYCLE800() to reset')
        try:
            numbers = [float(v) if v and not v.startswith('"') else 0.0 for v in values]
        except ValueError:
            raise refuse(self.source, line, "CYCLE800 with expressions", "CYCLE800", raw,
                         accepted) from None
        if len(numbers) < 10 or numbers[2] != 0 or numbers[3] != 192 or any(
                numbers[k] != 0 for k in (4, 5, 6, 10, 11, 12) if k < len(numbers)):
            raise refuse(self.source, line, "only the direct rotary-axis swivel (_MODE 192, "
                         "new plane, no offsets) is read", "CYCLE800", raw, accepted)
        return ("axial", numbers[7], numbers[8])

    def word(self, canon: Canon, letter: str, number: str, line: int) -> None:
        """A plain ``letter number`` word."""
        if letter == "G":
            key = "G" + str(int(float(number))) if float(number).is_integer() else "G" + number
            if key not in _G:
                raise refuse(self.source, line, f"{key} is not supported", "G", key, _ACCEPTED)
            if _G[key]:
                canon.g.append(_G[key])
            if key == "G4":
                canon.words.pop("F", None)
                canon.g.append("G4-dwell")
        elif letter == "M":
            canon.m.append(int(float(number)))
        elif letter in "XYZACFSIJK":
            if "G4-dwell" in canon.g and letter == "F":
                return  # G4 F: dwell seconds, not a feed
            canon.words[letter] = number
        elif letter == "T":
            canon.words["T"] = str(self.tool_number(number))
        elif letter in "ND":
            return  # block number; cutting edge (its length is the programmed tip's)
        else:
            raise refuse(self.source, line, f"address {letter} is not supported", letter,
                         f"{letter}{number}", _ACCEPTED)


def sinumerik_canons(text_lines: list[str], source: str,
                     plain: bool = False) -> list[Canon | str | None]:
    """One ``Canon`` (or None) per physical line of a Sinumerik program.

    With ``plain`` (a program without vectors and frames) a plain motion line comes
    back as its RS274 text (``=`` dropped), which is much faster.

    Raises
    ------
    impeller_cam.errors.InputError
        An unsupported word, naming the file, line, word and what is accepted.
    """
    parser = SinumerikLines(source)
    out: list[Canon | str | None] = []
    for index, text in enumerate(text_lines):
        if plain:
            code = text.split(";", 1)[0].strip()
            if code and code[0] not in "%/" and _PLAIN.fullmatch(code.upper()):
                out.append(code.replace("=", ""))
                continue
        canon = parser.parse(text, index + 1)
        if canon is not None:
            if "G4-dwell" in canon.g:
                canon.g = [g for g in canon.g if g != "G4-dwell"]
            if canon.g or canon.words or canon.m or canon.vector or canon.frame:
                out.append(canon)
                continue
        out.append(None)
    return out
