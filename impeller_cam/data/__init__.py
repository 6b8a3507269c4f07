"""Data the defaults need, shipped inside the package (``importlib.resources``).

* ``tools/library.toml``: the default tool library (``-t NAME``),
* ``machines/*.toml``: the example machine files (``-m NAME``),
* ``impellers/<name>/``: the example impellers (``impeller-cam example NAME``),
* ``motion/*.toml``: the indexing-table plant of the chain's motion stage and the
  feed-drive parameters of Suzuki et al.

They are the one copy of these files: the repository's ``fixtures/`` holds symbolic
links to them (a test checks it), and an installed wheel carries them, so it works
outside the repository.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from impeller_cam.errors import InputError

__all__ = ["bundled", "data_path", "example_names", "machine_names"]


def data_path(*parts: str) -> Path:
    """Path of a bundled data file, e.g. ``data_path("tools", "library.toml")``."""
    return Path(str(files("impeller_cam.data").joinpath(*parts)))


def example_names() -> list[str]:
    """Names of the bundled example impellers."""
    return sorted(p.name for p in data_path("impellers").iterdir() if p.is_dir())


def machine_names() -> list[str]:
    """Names (file stems) of the bundled machine files."""
    return sorted(p.stem for p in data_path("machines").glob("*.toml"))


def bundled(path: str | Path, kind: str) -> Path:
    """``path`` when it exists, else the bundled ``kind`` file of that name.

    ``kind`` is ``"machines"`` (``-m trunnion-500``) or ``"tools"``. A name that is
    neither an existing file nor a bundled one is returned unchanged (the reader
    then reports it as not found).
    """
    path = Path(path)
    if path.exists() or path.parent != Path("."):
        return path
    candidate = data_path(kind, path.name if path.suffix == ".toml" else f"{path.name}.toml")
    return candidate if candidate.is_file() else path


def example_folder(name: str) -> Path:
    """The bundled example impeller folder ``name``.

    Raises
    ------
    InputError
        When there is no such example.
    """
    folder = data_path("impellers", name)
    if not folder.is_dir():
        raise InputError("no such example", field="NAME", value=name,
                         accepted=", ".join(example_names()))
    return folder
