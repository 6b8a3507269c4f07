"""Verification events: what went wrong, where, and at which NC line.

Events are results, not errors: ``impeller-cam verify`` exits 0 when it ran and
lists them in verify.json, report.html and the JUnit XML.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: The event types, in report order.
EVENT_TYPES: tuple[str, ...] = (
    "stock_short",
    "rapid_in_stock",
    "holder_collision",
    "machine_collision",
    "gouge",
    "overtravel",
    "excess",
)


@dataclass(frozen=True)
class Event:
    """One finding tied to an NC line.

    Attributes
    ----------
    type : str
        One of ``EVENT_TYPES``.
    line : int
        1-based line of the block in its NC file (0: not tied to a block, e.g. excess
        material on a surface no block touched, or stock short of the design before
        the first block).
    program : str
        NC file name.
    position : tuple of float
        Where, mm, workpiece frame (tool tip at the block end, or the deepest point).
    amount : float
        Size of the finding: mm of depth (gouge, excess, rapid cut, holder overlap,
        stock inside the design), how far past the limit (overtravel, mm or deg) or
        how far inside the pair's clearance (machine_collision, mm).
    message : str
        One human-readable sentence.
    details : dict
        Extra numbers (e.g. removed volume of a rapid, axis name and limit).
    """

    type: str
    line: int
    program: str
    position: tuple[float, float, float]
    amount: float
    message: str
    details: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.type not in EVENT_TYPES:
            raise ValueError(f"unknown event type {self.type!r}; accepted: {EVENT_TYPES}")

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (docs/formats.md).

        Returns
        -------
        dict
        """
        return {
            "type": self.type,
            "line": int(self.line),
            "program": self.program,
            "position_mm": [round(float(v), 4) for v in self.position],
            "amount": round(float(self.amount), 5),
            "message": self.message,
            **{key: _plain(value) for key, value in sorted(self.details.items())},
        }


def _plain(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float):
        return round(value, 6)
    return value


def sort_events(events: list[Event]) -> list[Event]:
    """One program's events in a stable order: line, type, largest first."""
    order = {name: i for i, name in enumerate(EVENT_TYPES)}
    return sorted(events, key=lambda e: (e.line, order[e.type], -e.amount))
