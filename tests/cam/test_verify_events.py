"""Planted faults are found at the right NC line; outputs of ``run_verify``."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh

from cam.verify.command import VerifyOptions, run_verify
from cam.verify.stock import Stock
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
FAST = VerifyOptions(render=False)


def _write(path: Path, lines: list[str]) -> dict[str, int]:
    """Write an NC file; return the 1-based line of every line tagged ``(@name)``."""
    path.write_text("\n".join(lines) + "\n")
    tags = {}
    for number, text in enumerate(lines, 1):
        if "(@" in text:
            tags[text.split("(@")[1].split(")")[0]] = number
    return tags


def _box_stl(path: Path, lower: list[float], upper: list[float]) -> Path:
    lo, hi = np.array(lower), np.array(upper)
    box = trimesh.creation.box(extents=hi - lo)
    box.apply_translation(0.5 * (lo + hi))
    box.export(path)
    return path


def _events(out: Path) -> list[dict]:
    return json.loads((out / "verify.json").read_text())["events"]


@pytest.fixture(scope="module")
def faults(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, int]]:
    folder = tmp_path_factory.mktemp("faults")
    tags = _write(folder / "faults.ngc", [
        "(planted faults: rapid through stock, shank in stock, over-travel)",
        "G21 G90 G94",
        "G0 X-30 Y0 Z20",
        "G0 X-30 Y0 Z-2",
        "G0 X30 Y0 Z-2 (@rapid)",
        "G0 X30 Y0 Z20",
        "G0 X-30 Y-15 Z20",
        "G0 Z-17",
        "G1 X0 F300 (@side)",
        "G1 Z20 (@exit)",
        "G0 Z100",
        "G0 A60 (@tilt)",
        "G0 A0",
        "G0 X250 (@xtravel)",
        "G0 X0",
        "M30",
    ])
    stock = _box_stl(folder / "stock.stl", [-20, -20, -20], [20, 20, 0])
    out = folder / "out"
    run_verify([folder / "faults.ngc"], MACHINE, "ball6", str(stock), None, 0.25, out,
               options=VerifyOptions(render=True), progress=False)
    return out, tags


def test_rapid_through_stock_is_found_at_its_line(faults) -> None:  # type: ignore[no-untyped-def]
    out, tags = faults
    found = [e for e in _events(out) if e["type"] == "rapid_in_stock"]
    assert [e["line"] for e in found] == [tags["rapid"]]
    assert found[0]["removed_volume_mm3"] > 100.0


def test_shank_in_stock_is_a_holder_collision(faults) -> None:  # type: ignore[no-untyped-def]
    out, tags = faults
    found = [e for e in _events(out) if e["type"] == "holder_collision"]
    # the shank stands in uncut stock after the side move, so leaving touches it again
    assert found[0]["line"] == tags["side"]
    assert {e["line"] for e in found} <= {tags["side"], tags["exit"]}
    # ball6: flutes end 14 mm above the tip; tip at -17 leaves 3 mm of shank below the
    # top face, dragged sideways 20 mm into the stock
    assert found[0]["amount"] > 3.0


def test_axes_beyond_limits_are_overtravel(faults) -> None:  # type: ignore[no-untyped-def]
    out, tags = faults
    found = [e for e in _events(out) if e["type"] == "overtravel"]
    assert {(e["line"], e["axis"]) for e in found} == {(tags["tilt"], "A"), (tags["xtravel"], "X")}
    tilt = next(e for e in found if e["axis"] == "A")
    assert tilt["limit"] == pytest.approx(50.0) and tilt["amount"] == pytest.approx(10.0)


def test_outputs_are_complete(faults) -> None:  # type: ignore[no-untyped-def]
    out, _ = faults
    data = json.loads((out / "verify.json").read_text())
    assert data["removed_volume_mm3"] > 0
    assert data["remaining_volume_mm3"] == pytest.approx(
        data["initial_volume_mm3"] - data["removed_volume_mm3"], abs=1e-2)
    assert data["event_counts"]["rapid_in_stock"] == 1
    suite = ET.parse(out / "verify.junit.xml").getroot()
    assert suite.attrib["failures"] == "3"  # rapid, holder, overtravel
    html = (out / "report.html").read_text()
    assert "data:image/png;base64," in html and "rapid_in_stock" in html
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs and all((out / p).stat().st_size > 5000 for p in pngs)
    assert Stock.load(out / "stock.npz").volume() == pytest.approx(
        data["remaining_volume_mm3"], abs=0.01)


def test_gouge_is_tied_to_the_moved_block(tmp_path: Path) -> None:
    # design: a wall whose face is the plane y = 5; the finishing pass runs a 10 mm flat
    # end mill along it at y = 10 (tangent). One block is moved 0.3 mm into the wall.
    tags = _write(tmp_path / "finish.ngc", [
        "G21 G90 G94",
        "G0 X-30 Y10 Z10",
        "G0 Z-6",
        "G1 X-10 F500",
        "G1 Y9.7 (@step_in)",
        "G1 X10 (@moved)",
        "G1 Y10 (@step_out)",
        "G1 X30",
        "G0 Z10",
        "M30",
    ])
    stock = _box_stl(tmp_path / "stock.stl", [-20, -20, -20], [20, 20, 0])
    design = _box_stl(tmp_path / "design.stl", [-20, -20, -20], [20, 5, 0])
    out = tmp_path / "out"
    run_verify([tmp_path / "finish.ngc"], MACHINE, "flat10", str(stock), design, 0.2, out,
               options=FAST, progress=False)
    gouges = [e for e in _events(out) if e["type"] == "gouge"]
    lines = {e["line"] for e in gouges}
    assert tags["moved"] in lines
    assert lines <= {tags["step_in"], tags["moved"], tags["step_out"]}
    deepest = max(gouges, key=lambda e: e["amount"])
    assert deepest["amount"] == pytest.approx(0.3, abs=0.01)
    moved = next(e for e in gouges if e["line"] == tags["moved"])
    assert moved["amount"] == pytest.approx(0.3, abs=0.01)
    assert -10.0 <= moved["position_mm"][0] <= 10.0
    data = json.loads((out / "verify.json").read_text())
    assert data["deviation"]["min_mm"] == pytest.approx(-0.3, abs=0.01)


def test_programs_run_in_sequence_through_the_saved_state(tmp_path: Path) -> None:
    # cylinder stock z = 0..10; the rough pass leaves 1 mm for the finishing pass
    _write(tmp_path / "rough.ngc", ["G0 X-20 Y0 Z15", "G1 Z7 F300", "G1 X20", "G0 Z15"])
    _write(tmp_path / "finish.ngc", ["G0 X-20 Y0 Z15", "G1 Z6 F300", "G1 X20", "G0 Z15"])
    both = tmp_path / "both"
    run_verify([tmp_path / "rough.ngc", tmp_path / "finish.ngc"], MACHINE, "ball6",
               "cylinder:50,10", None, 0.2, both, options=FAST, progress=False)
    first = tmp_path / "first"
    run_verify([tmp_path / "rough.ngc"], MACHINE, "ball6", "cylinder:50,10", None, 0.2, first,
               options=FAST, progress=False)
    second = tmp_path / "second"
    run_verify([tmp_path / "finish.ngc"], MACHINE, "ball6", str(first / "stock.npz"), None, 0.2,
               second, options=FAST, progress=False)
    all_in_one = json.loads((both / "verify.json").read_text())
    chained = json.loads((second / "verify.json").read_text())
    assert chained["remaining_volume_mm3"] == pytest.approx(
        all_in_one["remaining_volume_mm3"], abs=1e-6)
    assert all_in_one["programs"][1]["removed_volume_mm3"] > 0
    owners = Stock.load(second / "stock.npz").owners
    assert owners == [("rough.ngc", n) for n in range(1, 5)] + [("finish.ngc", n)
                                                                 for n in range(1, 5)]


def test_a_stock_handed_over_in_memory_continues_as_the_saved_state(tmp_path: Path) -> None:
    _write(tmp_path / "rough.ngc", ["G0 X-20 Y0 Z15", "G1 Z7 F300", "G1 X20", "G0 Z15"])
    _write(tmp_path / "finish.ngc", ["G0 X-20 Y3 Z15", "G1 Z6 F300", "G1 X20", "G0 Z15"])
    saved = tmp_path / "saved"
    run_verify([tmp_path / "rough.ngc"], MACHINE, "ball6", "cylinder:50,10", None, 0.2,
               tmp_path / "first", options=FAST, progress=False)
    run_verify([tmp_path / "finish.ngc"], MACHINE, "ball6",
               str(tmp_path / "first" / "stock.npz"), None, 0.2, saved, options=FAST,
               progress=False)
    stock = Stock.cylinder(50.0, 10.0, 0.2)
    run_verify([tmp_path / "rough.ngc"], MACHINE, "ball6", "cylinder:50,10", None, 0.2,
               tmp_path / "memory_first", options=FAST, progress=False, initial_stock=stock)
    memory = tmp_path / "memory"
    run_verify([tmp_path / "finish.ngc"], MACHINE, "ball6", "named.npz", None, 0.2, memory,
               options=FAST, progress=False, initial_stock=stock)
    expected = json.loads((saved / "verify.json").read_text())
    got = json.loads((memory / "verify.json").read_text())
    assert got["stock"] == "named.npz"
    for key in ("initial_volume_mm3", "removed_volume_mm3", "remaining_volume_mm3",
                "programs", "event_counts"):
        assert got[key] == expected[key], key
    a, b = Stock.load(saved / "stock.npz"), Stock.load(memory / "stock.npz")
    assert a.owners == b.owners
    for ga, gb in zip(a.grids, b.grids, strict=True):
        assert np.array_equal(ga.count, gb.count)
        sa, sb = ga.slots()[0], gb.slots()[0]
        assert np.array_equal(ga.lo[sa], gb.lo[sb]) and np.array_equal(ga.hi[sa], gb.hi[sb])
        assert np.array_equal(ga.hi_move[sa], gb.hi_move[sb])


@pytest.mark.parametrize(
    ("stock", "tool", "field"),
    [("cylinder:50", "ball6", "--stock"), ("cylinder:50,10", "no_such_tool", "-t"),
     ("missing.stl", "ball6", "--stock")],
)
def test_bad_input_is_an_input_error_and_writes_nothing(
    tmp_path: Path, stock: str, tool: str, field: str
) -> None:
    _write(tmp_path / "p.ngc", ["G0 X0 Y0 Z5"])
    out = tmp_path / "out"
    with pytest.raises(InputError) as info:
        run_verify([tmp_path / "p.ngc"], MACHINE, tool, stock, None, 0.2, out, progress=False)
    assert info.value.field == field
    assert not out.exists()


def test_progress_bar_runs_without_a_terminal(tmp_path: Path) -> None:
    _write(tmp_path / "p.ngc", ["G0 X-20 Y0 Z15", "G1 Z8 F300", "G1 X20", "G0 Z15"])
    run_verify([tmp_path / "p.ngc"], MACHINE, "ball6", "cylinder:50,10", None, 0.25,
               tmp_path / "out", options=FAST, progress=True)
    data = json.loads((tmp_path / "out" / "verify.json").read_text())
    # a 6 mm ball 2 mm deep, 40 mm long inside the 50 mm cylinder: a few hundred mm^3
    assert 200.0 < data["removed_volume_mm3"] < 600.0
