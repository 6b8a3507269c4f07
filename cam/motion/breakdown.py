"""Where a program's time goes: cutting, air (rapids, approaches, departures, links),
rotary links; under look-ahead blending (the cycle time) and exact stop (a bound).

The NC program alone does not say which feed blocks cut: the APT file it was posted
from does. ``block_kinds`` posts the APT again with the chain's post options
(``post_toolpaths`` is deterministic) and maps every block to the ``MoveKind`` of the
APT pose it moves to (safety blocks: rapids); if the re-posted program does not have
the NC program's block count, the feed blocks all count as cutting and the result
says so (``"air_feed_source": "none"``).

Classes of blocks:

* **rapid**: ``G0`` (links, retracts, positioning);
* **rotary link**: a ``G0`` that turns A or C (counted in rapid too);
* **approach / departure**: feed blocks moving to a pose of an ``air_kinds`` kind
  (finishing: ``PLUNGE`` = approach, ``RETRACT`` = departure; roughing: ``RETRACT``,
  its plunges cut);
* **cutting**: every other feed block.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.motion.blending import DEFAULT_TOLERANCE_MM, blended_program_time
from cam.motion.cycle_time import program_cycle_time
from postproc.program import MachineProgram, Motion
from postproc.toolpath import MoveKind

if TYPE_CHECKING:
    from postproc.machine import Machine

__all__ = ["AIR_KINDS", "block_kinds", "time_breakdown"]

#: Feed move kinds that do not cut, per operation of the chain.
AIR_KINDS = {"finish": (MoveKind.PLUNGE, MoveKind.RETRACT), "rough": (MoveKind.RETRACT,)}
_ROTARY_STILL = 1e-9


def block_kinds(apt: str | Path, machine: Machine, blocks: int) -> NDArray[np.int8] | None:
    """``MoveKind`` of the APT pose each block of the posted program moves to.

    Returns None when re-posting with the default options does not give ``blocks``
    motion blocks (the program was posted otherwise).
    """
    from postproc.apt import read_apt
    from postproc.posting import post_toolpaths
    from postproc.posts import PostOptions

    toolpaths = read_apt(apt)
    posted = post_toolpaths(toolpaths, machine, PostOptions(), source=Path(apt).name)
    if len(posted) != blocks:
        return None
    lines = np.concatenate([tp.source_records for tp in toolpaths]).astype(np.int64)
    kinds = np.concatenate([tp.kind for tp in toolpaths]).astype(np.int8)
    order = np.argsort(lines)
    found = np.searchsorted(lines[order], posted.record)
    found = np.clip(found, 0, len(lines) - 1)
    known = (posted.record >= 0) & (lines[order][found] == posted.record)
    out = np.full(len(posted), int(MoveKind.RAPID), np.int8)
    out[known] = kinds[order][found[known]]
    return out


def time_breakdown(program: MachineProgram, machine: Machine,
                   joints: NDArray[np.float64] | None = None,
                   kinds: NDArray[np.int8] | None = None,
                   air_kinds: tuple[MoveKind, ...] = AIR_KINDS["finish"],
                   tolerance: float = DEFAULT_TOLERANCE_MM,
                   smoothing: float = 0.0) -> dict[str, Any]:
    """Times of a program by class of block, s.

    Parameters
    ----------
    program : MachineProgram
    machine : Machine
    joints : (n, 5) float64, optional
        Joint targets (TCP blocks mapped to joints).
    kinds : (n,) int8, optional
        ``MoveKind`` per block (``block_kinds``); None: every feed block cuts.
    air_kinds : tuple of MoveKind
        Feed kinds that are approaches or departures.
    tolerance : float
        Path tolerance of the blending (``G64 P``), mm.
    smoothing : float
        Post-interpolation smoothing the corner speeds allow for, s
        (``program_servo.machine_corner_smoothing``; 0: none).

    Returns
    -------
    dict
        ``cycle_time_s`` (blended), ``exact_stop_s``, ``nominal_s``, ``cutting_s``,
        ``air_s`` (= ``rapid_s`` + ``approach_departure_s``), ``rotary_link_s``,
        ``air_share``, block counts, ``blend_tolerance_mm`` and
        ``corner_smoothing_s``.
    """
    blended = blended_program_time(program, machine, joints, tolerance, smoothing)
    exact = program_cycle_time(program, machine, joints)
    targets = program.joints if joints is None else joints
    path = np.vstack([program.start[None, :], targets])
    step = np.diff(path, axis=0)
    step = np.where(np.isfinite(step), step, 0.0)
    rapid = program.motion == Motion.RAPID
    rotary = np.array([s.rotary for s in machine.axes.values()], dtype=bool)
    turns = np.abs(step[:, rotary]).max(axis=1) > _ROTARY_STILL if rotary.any() \
        else np.zeros(len(step), bool)
    link = rapid & turns
    feed_air = np.zeros(len(rapid), bool) if kinds is None else \
        ~rapid & np.isin(kinds, [int(k) for k in air_kinds])
    air = rapid | feed_air
    t = blended.time
    total = float(t.sum())
    return {
        "cycle_time_s": total,
        "exact_stop_s": exact.limited_total,
        "nominal_s": exact.nominal_total,
        "cutting_s": float(t[~air].sum()),
        "air_s": float(t[air].sum()),
        "rapid_s": float(t[rapid].sum()),
        "approach_departure_s": float(t[feed_air].sum()),
        "rotary_link_s": float(t[link].sum()),
        "air_share": float(t[air].sum()) / total if total > 0 else 0.0,
        "rapid_blocks": int(rapid.sum()),
        "rotary_link_blocks": int(link.sum()),
        "air_feed_source": "none" if kinds is None else "apt",
        "blend_tolerance_mm": tolerance,
        "corner_smoothing_s": smoothing,
    }


def program_file_times(nc: str | Path, apt: str | Path | None, machine: Machine,
                       operation: str = "finish",
                       tolerance: float = DEFAULT_TOLERANCE_MM) -> dict[str, Any]:
    """``time_breakdown`` of an NC file, its feed blocks classed from its APT file.

    Parameters
    ----------
    nc : path
        The program (read with ``postproc.nc_reader.read_nc``).
    apt : path or None
        The APT file it was posted from (default post options), if known.
    operation : str
        ``"finish"`` or ``"rough"`` (``AIR_KINDS``).

    The corners allow for the drives' smoothing when the machine has servo data
    (``program_servo.machine_corner_smoothing``), as the contour-error prediction does.
    """
    from cam.motion.program_servo import machine_corner_smoothing, program_joints
    from postproc.nc_reader import read_nc

    program = read_nc(nc, machine=machine)
    kinds = None if apt is None or not Path(apt).is_file() else \
        block_kinds(apt, machine, len(program))
    out = time_breakdown(program, machine, program_joints(program, machine), kinds,
                         AIR_KINDS.get(operation, AIR_KINDS["finish"]), tolerance,
                         machine_corner_smoothing(machine))
    out["blocks"] = len(program)
    return out
