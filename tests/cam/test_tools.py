"""Tool library: TOML and LinuxCNC tables, outlines, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cam.tools import DEFAULT_LIBRARY, load_tool_library, resolve_tool
from impeller_cam.errors import InputError


def test_bundled_library_loads() -> None:
    tools = load_tool_library(DEFAULT_LIBRARY)
    assert {"ball10", "ball6_taper", "flat10", "bull10r2"} <= set(tools)
    ball = tools["ball10"]
    assert ball.radius == 5.0 and ball.corner_radius == 5.0 and ball.number == 1
    assert ball.holder[0].z0 == ball.stickout
    assert ball.length == pytest.approx(55 + 35 + 40)


def test_ball_outline_is_a_hemisphere() -> None:
    ball = resolve_tool("ball10")
    h = np.linspace(0, 5, 11)
    assert ball.radius_at(h) == pytest.approx(np.sqrt(25 - (5 - h) ** 2))
    flat = resolve_tool("flat10")
    assert flat.radius_at(np.array([0.0, 3.0])) == pytest.approx([5.0, 5.0])
    bull = resolve_tool("bull10r2")
    # corner circle centred at (r=3, h=2): at h = 0 radius 3, at h = 1 3 + sqrt(3)
    assert bull.radius_at(np.array([0.0, 1.0, 2.0])) == pytest.approx([3.0, 3 + np.sqrt(3), 5.0])


def test_tapered_neck_grows_at_its_angle() -> None:
    tool = resolve_tool("ball6_taper")
    neck = tool.shank_segments()[0]
    assert neck.r0 == 3.0
    assert (neck.r1 - neck.r0) / (neck.z1 - neck.z0) == pytest.approx(np.tan(np.radians(2.0)))
    outline = tool.outline()
    assert np.all(np.diff(outline[:, 1]) >= -1e-12)  # heights never go down


def test_resolve_forms(tmp_path: Path) -> None:
    assert resolve_tool(f"{DEFAULT_LIBRARY}:flat10").shape == "flat"
    with pytest.raises(InputError) as info:
        resolve_tool("ball99")
    assert "no such tool" in str(info.value) and "ball10" in str(info.value)
    with pytest.raises(InputError):
        resolve_tool(str(DEFAULT_LIBRARY))  # several tools: must name one


def test_linuxcnc_tool_table(tmp_path: Path) -> None:
    table = tmp_path / "tool.tbl"
    table.write_text("T1 P1 D6.0 Z40.0 ;6 mm ball\nT2 P2 D10 Z0 ;flat end mill\n")
    tools = load_tool_library(table)
    assert tools["T1"].shape == "ball" and tools["T1"].stickout == 40.0
    assert tools["T2"].shape == "flat" and tools["T2"].stickout == 40.0
    table.write_text("T1 P1 Z40\n")
    with pytest.raises(InputError) as info:
        load_tool_library(table)
    assert "line 1" in str(info.value)


def test_bad_tool_values(tmp_path: Path) -> None:
    lib = tmp_path / "lib.toml"
    lib.write_text('[[tool]]\nname = "x"\ntype = "drill"\ndiameter_mm = 6\n')
    with pytest.raises(InputError) as info:
        load_tool_library(lib)
    assert info.value.field == "tool 'x'.type" and info.value.value == "drill"
    lib.write_text(
        '[[tool]]\nname = "x"\ntype = "bullnose"\ndiameter_mm = 6\ncorner_radius_mm = 4\n'
        "flute_length_mm = 10\nstickout_mm = 30\n"
    )
    with pytest.raises(InputError) as info:
        load_tool_library(lib)
    assert "corner radius" in str(info.value)
