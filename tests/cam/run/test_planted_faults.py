"""Faults planted in the project's own finishing program are found at their NC lines.

The small chain's ``finish_hub.ngc`` (joint mode on trunnion-500: the tool stays
along machine Z, so a change of Z moves the tool along its own axis) is verified at
0.1 mm on a stock that is the design itself (the chain's exported STL, also the
design): the program as posted finishes to the design, so every event comes from a
planted fault. Three faults, each in its own block:

* a cutting block moved 0.5 mm down Z (along the tool axis, into the hub): a gouge;
* a rapid inserted 1 mm down Z from a cutting point: a rapid through stock;
* a feed block inserted 14 mm down Z (the ball's 10 mm flutes and the neck above them
  into the part): shank/holder in stock.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from cam.finishing.lead_blend import LEAD_POINTS
from cam.verify.command import VerifyOptions, run_verify
from tests.cam.conftest import CHAIN_MACHINE, CHAIN_SETTINGS

RESOLUTION = 0.1
Z_WORD = re.compile(r"Z(-?\d+(?:\.\d*)?)")


def cutting_lines(lines: list[str]) -> list[int]:
    """Indices of inverse-time cutting blocks with all five coordinates, inside a pass.

    The tangent leads (``lead_blend``, ``LEAD_POINTS`` blocks) turn the tool axis at
    the pass's rate, so they too are five-coordinate inverse-time blocks, contiguous
    with their pass but in the air: the first and last ``LEAD_POINTS + 1`` blocks of
    every run of such blocks are left out.
    """
    five = [i for i, line in enumerate(lines)
            if line.startswith("X") and all(f" {w}" in line for w in "ZACF")]
    runs: list[list[int]] = []
    for i in five:
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    edge = LEAD_POINTS + 1
    return [i for run in runs for i in run[edge:len(run) - edge]]


def z_of(line: str) -> float:
    match = Z_WORD.search(line)
    assert match is not None, line
    return float(match.group(1))


def with_z(line: str, z: float) -> str:
    return Z_WORD.sub(f"Z{z:.4f}", line, count=1)


def plant(lines: list[str]) -> tuple[list[str], dict[str, int]]:
    """The program with the three faults; their 1-based NC lines."""
    cuts = cutting_lines(lines)
    a, b, c = (cuts[len(cuts) * k // 4] for k in (1, 2, 3))
    out = list(lines)
    # from the last line backwards so that earlier indices stay valid
    zc = z_of(out[c])
    out[c + 1] = "G93 G1 " + out[c + 1]
    out.insert(c + 1, f"G94 G1 Z{zc - 14.0:.4f} F450")
    zb = z_of(out[b])
    out[b + 1] = "G1 " + out[b + 1]
    out.insert(b + 1, f"G0 Z{zb - 1.0:.4f}")
    out[a] = with_z(out[a], z_of(out[a]) - 0.5)
    return out, {"gouge": a + 1, "rapid_in_stock": b + 2, "holder_collision": c + 3}


def test_planted_faults_are_reported_at_their_lines(chain_small: Path, tmp_path: Path) -> None:
    source = (chain_small / "nc" / "finish_hub.ngc").read_text().splitlines()
    faulty, where = plant(source)
    program = tmp_path / "finish_hub_faulty.ngc"
    program.write_text("\n".join(faulty) + "\n")
    design = chain_small / "geometry" / "impeller.stl"
    out = tmp_path / "verify"
    run_verify([program], CHAIN_MACHINE, CHAIN_SETTINGS["finish_tool"], str(design), design,
               RESOLUTION, out, options=VerifyOptions(allowance=0.0, render=False),
               progress=False)
    data = json.loads((out / "verify.json").read_text())
    assert data["resolution_mm"] == pytest.approx(RESOLUTION)
    events = data["events"]

    def lines_of(kind: str, deeper: float = 0.0) -> set[int]:
        return {e["line"] for e in events if e["type"] == kind and e["amount"] > deeper}

    # the moved block, or the block leaving the moved point, cuts 0.3+ mm into the hub
    gouge = where["gouge"]
    near_a = [e for e in events if e["type"] == "gouge" and e["line"] in (gouge, gouge + 1)]
    assert near_a and max(e["amount"] for e in near_a) > 0.3, near_a
    assert lines_of("rapid_in_stock") == {where["rapid_in_stock"]}
    # the plunge and the block climbing back out of it
    holder = where["holder_collision"]
    assert holder in lines_of("holder_collision") <= {holder, holder + 1}
    # gouges of more than the tolerance belong to the three faults (and the blocks
    # leaving them), none elsewhere in the program
    faults = {gouge, gouge + 1, where["rapid_in_stock"], where["rapid_in_stock"] + 1,
              where["holder_collision"], where["holder_collision"] + 1}
    assert lines_of("gouge", data["gouge_tolerance_mm"]) <= faults
    assert data["event_counts"]["overtravel"] == 0
