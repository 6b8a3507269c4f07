"""``stock_short``: verification finds where the initial stock cuts into the part.

A blank planted 0.5 mm short at one trailing edge is found there; the spec's own
blank (``geometry.blank.spec_blank_profile``) is short nowhere.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from cam.verify.command import VerifyOptions, run_verify
from cam.verify.shortfall import short_places, stock_short_events
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
ROUND_TE = ROOT / "fixtures" / "impellers" / "round_te" / "spec.toml"
SMALL = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
#: Dexel spacing of these runs, mm (the chain test's is 0.3).
RESOLUTION = 0.2
#: How far the reported place may lie from the planted spot, mm, and the depth error.
WHERE = 1.0
DEPTH = 0.1


def _idle_program(path: Path) -> Path:
    """A program that never comes near the part (the check runs before its blocks)."""
    path.write_text("G21 G90 G94\nG0 X0 Y0 Z100\nM30\n")
    return path


def _events(out: Path, kind: str) -> list[dict]:
    data = json.loads((out / "verify.json").read_text())
    return [e for e in data["events"] if e["type"] == kind]


def test_short_places_group_touching_cubes() -> None:
    a = np.array([[0.1, 0.1, 0.1], [0.9, 0.2, 0.1], [1.5, 0.5, 0.5]])  # cubes 0 and 1
    b = a + [10.0, 0.0, 0.0]
    place = short_places(np.vstack([a, b]))
    assert len(set(place[:3])) == 1 and len(set(place[3:])) == 1 and place[0] != place[3]


def test_only_never_machined_samples_deeper_than_the_tolerance_are_short() -> None:
    points = np.array([[0, 0, 0], [0.5, 0, 0], [20, 0, 0], [40, 0, 0], [60, 0, 0]], float)
    signed = np.array([-0.3, -0.45, -0.2, -0.04, -2.0])
    moves = np.array([-1, -1, -1, -1, 7])  # the last one was cut by a block: a gouge
    events = stock_short_events(points, signed, moves, 0.05, "p.ngc")
    assert [e.amount for e in events] == pytest.approx([0.45, 0.2])
    assert events[0].position == pytest.approx((0.5, 0.0, 0.0))
    assert events[0].details["samples"] == 2 and events[0].line == 0
    assert all(e.type == "stock_short" and e.program == "p.ngc" for e in events)


@pytest.fixture(scope="module")
def planted(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The round-TE fixture's blank with a ball cut 0.5 mm into one trailing edge."""
    from geometry.blank import spec_blank_profile
    from geometry.outline import blade_loop
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    folder = tmp_path_factory.mktemp("planted")
    spec = load_spec(ROUND_TE)
    blade = build_surfaces(spec).blades[0]
    caps = [s for s in blade_loop(blade, spec.leading_edge, spec.trailing_edge)
            if s.role == "trailing_edge"]
    middle = caps[len(caps) // 2]  # the middle third of the half-round cap
    half = np.array([0.5])
    spot = middle.point(half, half)[0]  # its apex at mid-span
    outward = middle.normal(half, half)[0]
    blank = trimesh.creation.revolve(spec_blank_profile(spec), sections=720)
    radius = 1.5
    ball = trimesh.creation.icosphere(subdivisions=5, radius=radius)
    ball.apply_translation(spot + (radius - 0.5) * outward)
    short = trimesh.boolean.difference([blank, ball], engine="manifold")
    assert short.is_volume
    stock = folder / "short_blank.stl"
    short.export(stock)
    return {"folder": folder, "stock": stock, "spot": spot - 0.5 * outward}


@pytest.mark.slow
def test_a_blank_planted_short_at_one_trailing_edge_is_found_there(planted: dict) -> None:
    out = planted["folder"] / "out"
    program = _idle_program(planted["folder"] / "idle.ngc")
    run_verify([program], MACHINE, "ball6", str(planted["stock"]), ROUND_TE, RESOLUTION,
               out, options=VerifyOptions(render=False), progress=False)
    short = _events(out, "stock_short")
    assert len(short) == 1, short
    event = short[0]
    assert np.linalg.norm(np.array(event["position_mm"]) - planted["spot"]) <= WHERE, event
    assert event["amount"] == pytest.approx(0.5, abs=DEPTH)
    assert event["line"] == 0 and event["program"] == "idle.ngc"
    counts = json.loads((out / "verify.json").read_text())["event_counts"]
    assert counts["stock_short"] == 1
    assert "stock_short" in (out / "verify.junit.xml").read_text()


@pytest.mark.slow
def test_a_short_stock_can_be_refused_before_anything_is_written(planted: dict) -> None:
    out = planted["folder"] / "refused"
    program = _idle_program(planted["folder"] / "idle.ngc")
    with pytest.raises(InputError, match="does not contain the design: short at 1 place"):
        run_verify([program], MACHINE, "ball6", str(planted["stock"]), ROUND_TE, RESOLUTION,
                   out, options=VerifyOptions(render=False, refuse_short_stock=True),
                   progress=False)
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize("spec", [ROUND_TE, SMALL], ids=["round_te", "small"])
def test_the_spec_blank_is_short_nowhere(spec: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    program = _idle_program(tmp_path / "idle.ngc")
    run_verify([program], MACHINE, "ball6", str(spec), spec, 0.3, out,
               options=VerifyOptions(render=False, refuse_short_stock=True), progress=False)
    assert _events(out, "stock_short") == []
