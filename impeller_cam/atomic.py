"""Atomic, all-or-nothing output.

Result files are written to a temporary file in the destination folder and
renamed into place only when complete, so a failure never leaves half a file.
``staged_directory`` does the same for a whole output folder.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (UTF-8, ``\\n`` line ends)."""
    return write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _umask() -> int:
    """The process umask (read by setting and restoring it)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def staged_directory(out: str | Path) -> Iterator[Path]:
    """Stage a command's outputs in a hidden sibling folder; publish on success.

    Files are moved into ``out`` only when the block completes without an
    exception. On failure the staging folder is removed, ``out`` is left as it
    was (and is removed if this call created it and it is empty).

    Yields
    ------
    Path
        The staging folder to write into.
    """
    out = Path(out)
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".staging-", dir=out))
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        if created and not any(out.iterdir()):
            out.rmdir()
        raise
    for item in sorted(stage.iterdir()):
        replace_path(item, out / item.name)
    stage.rmdir()


def replace_path(source: str | Path, target: str | Path) -> None:
    """Rename ``source`` to ``target``, replacing a file or a whole folder there.

    ``os.replace`` cannot replace a non-empty folder (a rerun's sub-folder): an
    existing ``target`` folder is renamed aside into a hidden sibling first, the new
    one renamed into place, then the old one removed.
    """
    source, target = Path(source), Path(target)
    if not target.is_dir() or target.is_symlink():
        os.replace(source, target)
        return
    aside = Path(tempfile.mkdtemp(prefix=f".{target.name}-old-", dir=target.parent))
    os.replace(target, aside / target.name)
    try:
        os.replace(source, target)
    except BaseException:
        os.replace(aside / target.name, target)
        aside.rmdir()
        raise
    shutil.rmtree(aside, ignore_errors=True)
