"""Reading the motion TOML files (plant, feed drives) with errors that name the file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from impeller_cam.schema import load_toml


def read_toml(path: str | Path, kind: str) -> dict[str, Any]:
    """Parse a TOML file.

    Parameters
    ----------
    path : str or Path
    kind : str
        What the file is, for the message (``"plant"``, ``"feed-drive"``).

    Raises
    ------
    InputError
        When the file is missing or is not valid UTF-8 TOML.
    """
    return load_toml(path, kind)
