"""APT CLDATA files: read them into toolpaths, write toolpaths as CL text.

The public face of the CL reader (``postproc.apt_reader``, bulk GOTO scan in
``postproc.apt_scan``) and writer (``postproc.apt_writer``). Files are in the
workpiece frame W, lengths in mm (inch files are converted), feeds in mm/min.
See docs/formats.md for the records read and written.

Examples
--------
>>> from postproc.apt import format_apt, parse_apt
>>> toolpaths = parse_apt("MULTAX/ON\\nFEDRAT/MMPM,500\\nGOTO/1,2,3,0,0,1\\nFINI\\n")
>>> toolpaths[0].tip.tolist(), toolpaths[0].feed.tolist()
([[1.0, 2.0, 3.0]], [500.0])
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from impeller_cam.atomic import write_text_atomic
from impeller_cam.errors import InputError
from postproc.apt_reader import AptDocument, AptNote, parse_apt_document
from postproc.apt_writer import format_apt
from postproc.toolpath import Toolpath

__all__ = [
    "AptDocument",
    "AptNote",
    "format_apt",
    "parse_apt",
    "parse_apt_document",
    "read_apt",
    "read_apt_document",
    "write_apt",
]


def read_apt_document(path: str | Path) -> AptDocument:
    """Read a CL file into its operations and the notes made while reading.

    Raises
    ------
    InputError
        The file cannot be read, or holds a malformed or unsupported record.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as error:
        raise InputError(f"cannot read the CL file: {error.strerror}", file=path,
                         accepted="a readable APT CLDATA file") from error
    return parse_apt_document(data, source=str(path))


def read_apt(path: str | Path) -> list[Toolpath]:
    """Read a CL file: one ``Toolpath`` per operation (LOADTL or ``$$ OPERATION/``).

    Parameters
    ----------
    path : str or Path
        APT CLDATA file (any case, blanks, ``$`` continuations, ``$$`` comments).

    Returns
    -------
    list of Toolpath
        Operations in file order; empty when the file holds no GOTO record.

    Raises
    ------
    InputError
        A malformed record or value, named by file, line, record and value.
    """
    return read_apt_document(path).toolpaths


def parse_apt(text: str, source: str = "<string>") -> list[Toolpath]:
    """Parse CL text (see ``read_apt``).

    Parameters
    ----------
    text : str
        APT CLDATA.
    source : str
        Name of the text in error messages.

    Returns
    -------
    list of Toolpath
        One per operation, poses in W (mm; inch files converted).
    """
    return parse_apt_document(text, source=source).toolpaths


def write_apt(path: str | Path, toolpaths: Sequence[Toolpath], decimals: int = 6,
              header: str | None = None) -> Path:
    """Write ``toolpaths`` as a CL file atomically (see ``format_apt``).

    Parameters
    ----------
    path : str or Path
        The APT file.
    toolpaths : sequence of Toolpath
        Operations in order, poses in W (mm).
    decimals : int
        Digits after the point of coordinates (mm) and axis components.
    header : str, optional
        A ``$$`` comment line at the top.

    Returns
    -------
    Path
        ``path``.
    """
    return write_text_atomic(path, format_apt(toolpaths, decimals=decimals, header=header))
