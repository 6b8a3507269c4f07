"""Sanitising text that is copied into NC comments.

Operation names, file names and header lines come from users and other programs.
Inside a G-code comment a ``)`` would end the comment and let the rest of the text
run as a block, a ``;`` starts a comment of its own, ``%`` ends a Fanuc tape, and
control characters (newline, carriage return) would start a new block. LinuxCNC
also gives some comments a meaning (``(MSG,...)``, ``(DEBUG,...)``,
``(LOGOPEN,file)``, ``(PROBEOPEN file)``, ...); such text is defused by a prefix.
"""

from __future__ import annotations

import re

#: Characters removed from comment text (besides anything outside printable ASCII).
FORBIDDEN = frozenset("();%\\")

#: Longest comment body kept, characters.
MAX_COMMENT = 72

_ACTIVE = re.compile(r"^\s*(msg|debug|print|log|logopen|logappend|logclose|probeopen"
                     r"|probeclose|abort|py|pyrun)\b", re.IGNORECASE)


def sanitise_comment(text: object, *, upper: bool = False, limit: int = MAX_COMMENT) -> str:
    """Make ``text`` safe to place between ``(`` and ``)`` in any dialect.

    Parameters
    ----------
    text : object
        Anything; converted with ``str``.
    upper : bool
        Upper-case the result (controls that reject lower-case comments).
    limit : int
        Longest result, characters; longer text is cut.

    Returns
    -------
    str
        Printable ASCII (codes 32..126) without ``( ) ; % \\``; other characters
        become ``?``; runs of white space collapse to one space; text that a
        LinuxCNC controller would act on (``MSG,``, ``DEBUG,``, ``LOGOPEN``, ...)
        is prefixed with ``_``.
    """
    out = []
    for char in str(text):
        code = ord(char)
        if char in "\t\r\n\x0b\x0c":
            out.append(" ")
        elif 32 <= code <= 126 and char not in FORBIDDEN:
            out.append(char)
        elif 32 <= code <= 126 or code > 126:
            out.append("?")
        # other control characters are dropped
    clean = re.sub(r" {2,}", " ", "".join(out)).strip()
    if _ACTIVE.match(clean):
        clean = "_" + clean
    if upper:
        clean = clean.upper()
    return clean[:limit].rstrip()
