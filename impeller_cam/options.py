"""Options dataclasses built from keyword options, refusing unknown names."""

from __future__ import annotations

from dataclasses import fields
from typing import Any, TypeVar

from impeller_cam.errors import InputError

T = TypeVar("T")


def options_from_mapping(cls: type[T], values: dict[str, Any], what: str) -> T:
    """Build the options dataclass ``cls`` from ``values``.

    Raises
    ------
    InputError
        Naming the first unknown option, its value and the accepted names.
    """
    known = {f.name for f in fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(values) - known)
    if unknown:
        raise InputError(f"unknown {what} option", field=unknown[0], value=values[unknown[0]],
                         accepted=", ".join(sorted(known)))
    return cls(**values)
