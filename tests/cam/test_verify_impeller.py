"""Gouge planted in a real impeller blade: one finishing block moved 0.3 mm into it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam.verify.command import VerifyOptions, run_verify
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
R = 2.0
TOOLS = """
[[tool]]
name = "ball4_short"     # the ball is the whole cutter: the neck only probes
type = "ball"
diameter_mm = 4.0
flute_length_mm = 2.0
shank_diameter_mm = 1.5
stickout_mm = 25.0
[[tool.holder]]
length_mm = 20.0
diameter_mm = 12.0
"""


def _finishing_program(moved: int, depth: float) -> tuple[list[str], int]:
    """A TCP pass along mid-span of a blade's side, ball tangent to it; block ``moved``
    pushed ``depth`` into the blade. Returns the lines and the moved block's line."""
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    blade = build_surfaces(load_spec(SPEC)).blades[0]
    u = np.linspace(0.25, 0.75, 21)
    v = np.full_like(u, 0.5)
    surface, normal = blade.side(u, v, 1), blade.side_normal(u, v, 1)
    axis = np.array([0.0, 0.0, 1.0]) + 0.7 * normal  # tilted away from the blade
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    offset = np.full(len(u), R)
    offset[moved] -= depth
    tips = surface + offset[:, None] * normal - R * axis
    tips = np.vstack([tips[:1] + 15 * axis[:1], tips, tips[-1:] + 15 * axis[-1:]])
    axes = np.vstack([axis[:1], axis, axis[-1:]])
    machine = load_machine(MACHINE)
    joints = kinematics_for(machine).inverse(tips, axes)
    lines = ["(finishing pass along a blade, TCP)", "G21 G90 G94", "M428"]
    for i, (tip, joint) in enumerate(zip(tips, joints, strict=True)):
        word = "G0" if i == 0 else "G1"
        feed = " F500" if i == 1 else ""
        a, c = np.degrees(joint[3:])
        lines.append(f"{word} X{tip[0]:.4f} Y{tip[1]:.4f} Z{tip[2]:.4f} A{a:.4f} C{c:.4f}{feed}")
    lines += ["M429", "M30"]
    return lines, 3 + 1 + moved + 1  # 3 header lines, the approach, then block 0


@pytest.mark.slow
def test_gouge_in_a_blade_is_found_at_the_moved_block(tmp_path: Path) -> None:
    pytest.importorskip("geometry.impeller")
    lines, moved_line = _finishing_program(moved=10, depth=0.3)
    (tmp_path / "finish.ngc").write_text("\n".join(lines) + "\n")
    (tmp_path / "tools.toml").write_text(TOOLS)
    out = tmp_path / "out"
    run_verify([tmp_path / "finish.ngc"], MACHINE, f"{tmp_path / 'tools.toml'}:ball4_short",
               str(SPEC), SPEC, 0.2, out, options=VerifyOptions(render=False), progress=False)
    data = json.loads((out / "verify.json").read_text())
    gouges = [e for e in data["events"] if e["type"] == "gouge"]
    assert gouges, "the planted gouge was not found"
    deepest = max(gouges, key=lambda e: e["amount"])
    assert deepest["amount"] == pytest.approx(0.3, abs=0.05)
    # the moved block and the block leaving it are the only ones that cut the blade
    assert {e["line"] for e in gouges} <= {moved_line, moved_line + 1}
    assert deepest["line"] in (moved_line, moved_line + 1)
    assert data["event_counts"]["overtravel"] == 0
