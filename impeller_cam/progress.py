"""Progress bars for long commands: shown on a terminal, silent in CI and pipes."""

from __future__ import annotations

import sys
from typing import Any


def progress_bar(enabled: bool | None = None) -> Any:
    """A transient ``rich.progress.Progress``, or ``None`` when disabled.

    Parameters
    ----------
    enabled : bool, optional
        Force on or off; by default on exactly when stderr is a terminal.
    """
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None
    from rich.progress import Progress

    return Progress(transient=True)
