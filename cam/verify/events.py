"""Verification events: what went wrong, where, and at which NC line.

Events are results, not errors: ``impeller-cam verify`` exits 0 when it ran and
lists them in verify.json, report.html and the JUnit XML.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from cam.verify.deviation import Deviation

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

#: Events of one type per program kept in the outputs (largest first).
MAX_EVENTS_PER_TYPE = 200


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


def motion_events(
    name: str, program: Any, moves: Any, per_block: NDArray[np.float64], contact: float
) -> list[Event]:
    """Rapids that cut, shank or holder overlap and over-travel of one program's blocks.

    Parameters
    ----------
    name : str
        The NC file name.
    program : MachineProgram
        Its blocks.
    moves : ToolMoves
        Its sub-moves (``cam.verify.motion``): block end poses, over-travel findings.
    per_block : (b, 3) float64
        Per block: removed volume mm^3, longest cut and longest shank/holder overlap
        along one ray, mm.
    contact : float
        A cut or overlap counts when longer than this, mm.

    Returns
    -------
    list of Event
    """
    from postproc.program import Motion

    events: list[Event] = []
    rapid = program.motion == int(Motion.RAPID)
    for b in np.flatnonzero(rapid & (per_block[:, 1] > contact)):
        events.append(Event(
            "rapid_in_stock", int(program.line[b]), name, tuple(moves.end_tip[b]),
            float(per_block[b, 1]),
            f"rapid move cuts stock: {per_block[b, 0]:.3f} mm3 removed, "
            f"{per_block[b, 1]:.3f} mm deep along a dexel",
            {"removed_volume_mm3": float(per_block[b, 0])},
        ))
    for b in np.flatnonzero(per_block[:, 2] > contact):
        events.append(Event(
            "holder_collision", int(program.line[b]), name, tuple(moves.end_tip[b]),
            float(per_block[b, 2]),
            f"shank or holder runs {per_block[b, 2]:.3f} mm into the stock",
        ))
    for found in moves.overtravel:
        b = found["block"]
        past = abs(found["value"] - found["limit"])
        events.append(Event(
            "overtravel", int(program.line[b]), name, tuple(moves.end_tip[b]), past,
            f"axis {found['axis']} reaches {found['value']:.4f} {found['unit']}, "
            f"beyond its limit {found['limit']:.4f} {found['unit']}",
            {"axis": found["axis"], "limit": found["limit"], "value": found["value"]},
        ))
    return events


def deviation_events(
    deviation: Deviation,
    owners: list[tuple[str, int]],
    gouge_tol: float,
    allowance: float,
    last_program: str,
) -> list[Event]:
    """Gouge and excess events of a stock's deviation, grouped per block.

    Parameters
    ----------
    deviation : Deviation
        The stock's surface samples and their signed design distance.
    owners : list of (str, int)
        Program and NC line of each move id.
    gouge_tol : float
        Deeper than this inside the design is a gouge, mm.
    allowance : float
        More than this plus ``gouge_tol`` outside the design is excess, mm.
    last_program : str
        The program named for excess no block touched.

    Returns
    -------
    list of Event
    """
    from cam.verify.deviation import grouped_extremes

    events: list[Event] = []
    key = deviation.moves.astype(np.int64)
    gouge = grouped_extremes(
        (deviation.distance < -gouge_tol) & (key >= 0), key, -deviation.distance
    )
    for move, i, depth in gouge:
        name, line = owners[move]
        events.append(Event(
            "gouge", line, name, tuple(deviation.points[i]), depth,
            f"material removed {depth:.3f} mm inside the design surface",
        ))
    excess = grouped_extremes(
        deviation.distance > allowance + gouge_tol, key, deviation.distance
    )
    for move, i, amount in excess:
        name, line = owners[move] if move >= 0 else (last_program, 0)
        where = "left by this block" if move >= 0 else "never machined"
        events.append(Event(
            "excess", line, name, tuple(deviation.points[i]), amount,
            f"{amount:.3f} mm of material left outside the design ({where}), "
            f"allowance {allowance:.3f} mm",
        ))
    return events


def capped(events: list[Event]) -> tuple[list[Event], dict[str, int]]:
    """Keep the largest MAX_EVENTS_PER_TYPE events per program and type."""
    counts: dict[str, int] = {t: 0 for t in EVENT_TYPES}
    kept: list[Event] = []
    groups: dict[tuple[str, str], list[Event]] = {}
    for event in events:
        counts[event.type] += 1
        groups.setdefault((event.program, event.type), []).append(event)
    for group in groups.values():
        kept.extend(sorted(group, key=lambda e: -e.amount)[:MAX_EVENTS_PER_TYPE])
    return kept, counts
