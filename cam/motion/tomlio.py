"""Reading the motion TOML files (plant, feed drives) with errors that name the file."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from impeller_cam.errors import InputError


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
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{kind} file not found", file=path) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise InputError(f"not a valid TOML file: {error}", file=path) from None
