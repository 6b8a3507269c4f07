"""Errors that reach the user.

``InputError`` is the one exception type for bad input. The CLI turns it into
exit code 2 and a single message that names the file, the field, the value and
what would be accepted.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


class InputError(ValueError):
    """Bad user input: a file, a field in it, the offending value, what is accepted.

    Parameters
    ----------
    message : str
        What is wrong, in the user's words.
    file : str or Path, optional
        The file the value came from.
    field : str, optional
        The field (TOML key, CSV column, APT record, CLI option).
    value : Any, optional
        The offending value, shown with ``repr``.
    accepted : str, optional
        What would be accepted instead.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | Path | None = None,
        field: str | None = None,
        value: Any = None,
        accepted: str | None = None,
    ) -> None:
        self.message = message
        self.file = None if file is None else str(file)
        self.field = field
        self.value = value
        self.accepted = accepted
        super().__init__(self.__str__())

    def __str__(self) -> str:
        parts = []
        if self.file is not None:
            parts.append(self.file)
        if self.field is not None:
            parts.append(f"field '{self.field}'")
        head = ": ".join(parts)
        text = f"{head}: {self.message}" if head else self.message
        if self.value is not None:
            text += f" (got {self.value!r})"
        if self.accepted is not None:
            text += f"; accepted: {self.accepted}"
        return text
