"""Run LinuxCNC's stand-alone RS274/NGC interpreter on a program and read its output.

``rs274`` (LinuxCNC's ``rs274`` binary, /usr/bin/rs274) interprets a program without
a machine and prints the canonical machining calls it would make
(``STRAIGHT_TRAVERSE(x, y, z, a, b, c)``, ``STRAIGHT_FEED(...)``, ...). Used with
``-n 2`` it stops at the first error and exits non-zero. The ini and remap subs in
tests/postproc/rs274/ make it accept LinuxCNC's switchkins M-codes M428/M429; each
sub leaves a comment in the output, so the kinematics mode of every move is known.

Reusable by any test that writes RS274/NGC: ``run_rs274(path)`` raises
``Rs274Error`` with the interpreter's message when the program is rejected.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

RS274_DIR = Path(__file__).resolve().parent / "postproc" / "rs274"
DEFAULT_INI = RS274_DIR / "rs274.ini"
DEFAULT_TOOLS = RS274_DIR / "tools.tbl"

_MOVE = re.compile(r"STRAIGHT_(TRAVERSE|FEED)\(([^)]*)\)")
_FEED_RATE = re.compile(r"SET_FEED_RATE\(([^)]*)\)")
_COMMENT = re.compile(r'COMMENT\("(.*)"\)')
_TCP_ON = "impeller-cam: kinematics xyzac-trt TCP"
_TCP_OFF = "impeller-cam: kinematics identity joint"


class Rs274Error(RuntimeError):
    """The interpreter rejected the program (message: its stderr)."""


def rs274_path() -> str | None:
    """The ``rs274`` executable, or None when LinuxCNC's interpreter is not installed."""
    return shutil.which("rs274") or ("/usr/bin/rs274" if Path("/usr/bin/rs274").exists()
                                     else None)


@dataclass
class Rs274Run:
    """What the interpreter made of a program.

    Attributes
    ----------
    feed : (n,) bool
        True for ``STRAIGHT_FEED`` (G1), False for ``STRAIGHT_TRAVERSE`` (G0).
    position : (n, 6) float64
        End of each move: x, y, z (mm), a, b, c (deg), as the interpreter reports
        them (program coordinates plus work offsets; tool-length offsets excluded).
    tcp : (n,) bool
        The move ran after ``M428`` (TCP kinematics) rather than ``M429``.
    feed_rate : (n,) float64
        Feed rate in force for the move as the interpreter converted it (mm/min).
    comments : list of str
        Comment texts in order.
    output : str
        The full canonical output.
    """

    feed: NDArray[np.bool_]
    position: NDArray[np.float64]
    tcp: NDArray[np.bool_]
    feed_rate: NDArray[np.float64]
    comments: list[str]
    output: str


def parse_canon(text: str) -> Rs274Run:
    """Parse rs274's canonical output (see ``Rs274Run``)."""
    feed, position, tcp, rate, comments = [], [], [], [], []
    in_tcp = False
    current_rate = float("nan")
    for line in text.splitlines():
        move = _MOVE.search(line)
        if move:
            feed.append(move.group(1) == "FEED")
            position.append([float(v) for v in move.group(2).split(",")])
            tcp.append(in_tcp)
            rate.append(current_rate)
            continue
        found = _FEED_RATE.search(line)
        if found:
            current_rate = float(found.group(1))
            continue
        found = _COMMENT.search(line)
        if found:
            comments.append(found.group(1))
            if found.group(1) == _TCP_ON:
                in_tcp = True
            elif found.group(1) == _TCP_OFF:
                in_tcp = False
    return Rs274Run(
        feed=np.array(feed, dtype=bool),
        position=np.array(position, dtype=np.float64).reshape(-1, 6),
        tcp=np.array(tcp, dtype=bool),
        feed_rate=np.array(rate, dtype=np.float64),
        comments=comments,
        output=text,
    )


def run_rs274(
    program: str | Path,
    *,
    ini: str | Path = DEFAULT_INI,
    tool_table: str | Path = DEFAULT_TOOLS,
    timeout: float = 300.0,
) -> Rs274Run:
    """Interpret ``program`` with ``rs274 -i ini -t tools -n 2 -g`` and parse the output.

    Raises
    ------
    Rs274Error
        Non-zero exit or an error message from the interpreter.
    FileNotFoundError
        rs274 is not installed.
    """
    exe = rs274_path()
    if exe is None:
        raise FileNotFoundError("LinuxCNC's rs274 interpreter is not installed")
    ini = Path(ini).resolve()
    # rs274 keeps its tool table in $HOME/.tool.mmap (opened with O_TRUNC, then
    # mmapped): two runs sharing a HOME (the pytest workers) truncate each other's
    # map and one dies of SIGBUS (exit -7). Each run gets a HOME of its own.
    with tempfile.TemporaryDirectory(prefix="rs274-home-") as home:
        result = subprocess.run(
            [exe, "-i", str(ini), "-t", str(Path(tool_table).resolve()), "-n", "2", "-g",
             str(Path(program).resolve())],
            cwd=ini.parent, capture_output=True, text=True, timeout=timeout, check=False,
            env={**os.environ, "HOME": home},
        )
    errors = result.stderr.replace("executing", "").strip()
    if result.returncode != 0 or errors:
        raise Rs274Error(f"rs274 exit {result.returncode}: {errors}")
    return parse_canon(result.stdout)
