"""The 3+2 roughing programs against the machine model (issue 29, planning side).

Each UMR is cut at one index orientation (A, C); between UMR visits the post moves
the rotary axes (a safe retract, the turn at the retract height, positioning, the
approach). Whether a UMR's orientation and those index moves keep the machine's
components (spindle head and nose, cradle, rotary table, the fixture and the part)
their clearances is a question about the program the post writes, so it is asked
of that program: every APT file is posted in memory as the post stage will, and its
blocks are checked with the verifier's own check (``cam.verify.machine_check.
check_program``) against the scene the verifier builds - the part's solid from the
spec's blank (cast at ``BLANK_PITCH``: a coarser cast gives a larger solid, on the
safe side of the verifier's finer one).

Each block the verifier would reject is described with its UMR visit (the post's
``OPERATION`` section of the offending block), the two components, the distance and
the clearance: with ``refuse`` the plan is refused (``InputError``, exit 2), else
they go into rough.json's ``machine`` entry (``machine_collisions``, ``notes``) next
to the smallest clearance and where it is. The orientations themselves were chosen
with the machine's check of their cutting poses (``machine_pose``,
``umr.partition_passage``); this check adds the links and index moves.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from impeller_cam.errors import InputError

__all__ = ["BLANK_PITCH", "check_machine_fit"]

#: Machine collisions described in rough.json at most.
NOTES = 20
#: Ray spacing of the spec's blank standing for the part, mm.
BLANK_PITCH = 1.0
_OPERATION = re.compile(r"OPERATION \d+: (\S+)")


def _sections(text: str) -> list[str]:
    """The post's OPERATION section (a UMR visit's name) of every line (1-based + 1)."""
    out = [""]
    current = ""
    for line in text.splitlines():
        found = _OPERATION.search(line)
        if found:
            current = found.group(1)
        out.append(current)
    return out


def check_machine_fit(apt_files: list[Path], machine_path: str | Path, machine: Any,
                      kins: Any, tool: Any, spec: str | Path, refuse: bool = False,
                      scene: Any = None) -> dict[str, Any] | None:
    """Post every APT file in memory and check it against the machine model.

    Parameters
    ----------
    apt_files : list of Path
        The roughing APT files (written, not yet published).
    machine_path : str or Path
        The machine TOML (posted with its own dialect).
    machine : Machine
        The loaded machine (``None`` model: nothing to check, returns None).
    kins : TableTiltingRotary
    tool : Tool
        The roughing tool (its holder and gauge line ride on the spindle).
    spec : str or Path
        The impeller spec (its blank stands for the part).
    refuse : bool
        Raise on the first program with a machine collision (else report them).
    scene : MachineScene, optional
        The scene of ``machine``, ``tool`` and the spec's blank when the caller has
        built it already (``machine_pose.orientation_check``'s); default: built here.

    Returns
    -------
    dict or None
        rough.json's ``machine`` entry: ``machine_clearance_mm`` (smallest distance of
        any checked pair over all programs), ``machine_clearance_pair``,
        ``machine_clearance_umr`` (the UMR visit), ``machine_clearance_joints`` (X Y Z
        mm, A C deg), ``programs_checked``, ``machine_collisions`` (blocks closer than
        a pair's clearance) and ``notes`` (the first ``NOTES`` of them described).

    Raises
    ------
    InputError
        With ``refuse``: some block brings two components closer than their clearance.
    """
    if machine.model is None:
        return None
    import numpy as np

    from cam.verify.machine_check import check_program, machine_scene, part_solid
    from cam.verify.sources import load_stock
    from postproc.command import post_text
    from postproc.nc_reader import parse_nc

    if scene is None:
        part = part_solid(load_stock(str(spec), BLANK_PITCH))
        scene = machine_scene(machine.model, tool, None, part=part)
    best: dict[str, Any] = {"machine_clearance_mm": None, "programs_checked": len(apt_files)}
    problems: list[str] = []
    for apt in apt_files:
        text = post_text(apt, machine_path)
        program = parse_nc(text, apt.name, machine=machine)
        check = check_program(scene, kins, program, apt.name)
        sections = _sections(text)
        for event in check.events:
            a, b = event.details["components"]
            section = sections[min(event.line, len(sections) - 1)]
            problems.append(f"{section or apt.stem} (line {event.line}): {a} and {b} "
                            f"{event.details['distance_mm']:.2f} mm apart, clearance "
                            f"{event.details['clearance_mm']:.2f} mm")
        if check.pair[0] and (best["machine_clearance_mm"] is None
                              or check.smallest < best["machine_clearance_mm"]):
            best.update({
                "machine_clearance_mm": round(float(check.smallest), 3),
                "machine_clearance_pair": list(check.pair),
                "machine_clearance_umr": sections[min(check.line, len(sections) - 1)],
                "machine_clearance_joints": [round(float(v), 4) for v in [
                    *check.joints[:3], *np.degrees(check.joints[3:])]],
            })
    best["machine_collisions"] = len(problems)
    best["notes"] = problems[:NOTES]
    if problems and refuse:
        shown = "; ".join(problems[:5]) + (f"; and {len(problems) - 5} more"
                                          if len(problems) > 5 else "")
        raise InputError(f"the machine's components collide at these UMR orientations or "
                         f"index moves: {shown}", file=Path(machine_path), field="model",
                         value=f"{len(problems)} machine collisions",
                         accepted="UMR orientations the machine reaches with every "
                         "component clear (another machine, a riser, a longer tool)")
    return best
