"""The machine model: poses on the chain, the per-block check, events, bad input."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w

from cam.cli import main
from cam.tools import resolve_tool
from cam.verify.command import VerifyOptions, run_verify
from cam.verify.machine_check import check_program, machine_scene_for, pose_distance
from cam.verify.motion import block_poser
from cam.verify.sources import load_stock
from impeller_cam.errors import InputError
from postproc.kinematics import kinematics_for
from postproc.machine import load_machine, machine_from_dict
from postproc.machine_model import group_poses
from postproc.nc_reader import read_nc

ROOT = Path(__file__).resolve().parents[2]
MACHINES = ROOT / "fixtures" / "machines"
XYZAC = MACHINES / "xyzac-trt.toml"
STOCK = "cylinder:40,20"

#: The spindle parked beyond the platter (Y80), the table tilted up to A = +50 under
#: it: the platter's rim comes 0.17 mm from the tool's shank during line 3.
TILT_INTO_HEAD = """G21 G90 G94
G0 X0 Y80 Z{z} A0 C0
G1 A50 F1800
G0 Z120
M30
"""
#: Tip heights of the crash and of the same program 10 mm higher, mm.
LOW, HIGH = -8.0, 2.0


def _program(tmp_path: Path, z: float) -> Path:
    path = tmp_path / f"tilt_{z:g}.ngc"
    path.write_text(TILT_INTO_HEAD.format(z=z))
    return path


def _verify(tmp_path: Path, program: Path) -> dict[str, Any]:
    out = tmp_path / f"out_{program.stem}"
    run_verify([program], XYZAC, "ball6", STOCK, None, 1.0, out,
               options=VerifyOptions(render=False), progress=False)
    return json.loads((out / "verify.json").read_text())


def test_table_tilted_into_the_head_is_a_machine_collision(tmp_path: Path) -> None:
    data = _verify(tmp_path, _program(tmp_path, LOW))
    found = [e for e in data["events"] if e["type"] == "machine_collision"]
    assert found, "the tilt into the head must be found"
    assert {e["line"] for e in found} == {3}
    assert {tuple(e["components"]) for e in found} == {("rotary_table", "tool")}
    assert 0.0 <= found[0]["distance_mm"] < found[0]["clearance_mm"] == 2.0
    summary = data["programs"][0]
    assert summary["machine_clearance_pair"] == ["rotary_table", "tool"]
    assert summary["machine_clearance_line"] == 3
    assert summary["machine_clearance_mm"] == pytest.approx(found[0]["distance_mm"], abs=1e-3)
    assert data["event_counts"]["machine_collision"] == 1


def test_the_same_program_with_the_head_raised_10_mm_is_clean(tmp_path: Path) -> None:
    data = _verify(tmp_path, _program(tmp_path, HIGH))
    assert data["event_counts"]["machine_collision"] == 0
    summary = data["programs"][0]
    # the platter's rim now passes more than the 2 mm clearance below the shank
    assert summary["machine_clearance_mm"] > 2.0
    left_out = {tuple(p[:2]) for p in data["machine_model"]["pairs_left_out"]}
    assert ("rotary_table", "rotary_base") in left_out


@pytest.fixture(scope="module")
def scene_xyzac() -> tuple[Any, Any]:
    machine = load_machine(XYZAC)
    kins = kinematics_for(machine)
    scene = machine_scene_for(machine, resolve_tool("ball6"), load_stock(STOCK, 1.0))
    assert scene is not None
    return scene, kins


def test_a_point_on_the_table_follows_the_kinematics(scene_xyzac: tuple[Any, Any]) -> None:
    """The tool tip (X, Y, Z with no tool length) sits on the W point the forward
    kinematics names, placed on the C group's frame by ``group_poses``."""
    _, kins = scene_xyzac
    rng = np.random.default_rng(3)
    joints = np.column_stack([rng.uniform(-100, 100, (50, 3)),
                              rng.uniform(-1.7, 0.8, 50), rng.uniform(-7, 7, 50)])
    tip_w, _ = kins.forward(joints, 0.0)
    rot, trans = group_poses(kins, joints, 0.0, "A")["C"]
    placed = np.einsum("nij,nj->ni", rot, tip_w) + trans
    np.testing.assert_allclose(placed, joints[:, :3], atol=1e-9)


def test_advancement_finds_the_sampled_minimum(tmp_path: Path,
                                               scene_xyzac: tuple[Any, Any]) -> None:
    """The reported smallest clearance matches a brute-force scan of the whole path
    (every pair at 600 poses per block), within the sampling step."""
    scene, kins = scene_xyzac
    program = read_nc(_program(tmp_path, 45.0))
    check = check_program(scene, kins, program, "tilt")
    poser = block_poser(program, kins)
    frac = np.linspace(0.0, 1.0, 601)
    brute = np.inf
    for b in range(len(program)):
        for joints in poser.machine_joints(np.full(len(frac), b), frac):
            for i, j, _ in scene.pairs:
                brute = min(brute, pose_distance(scene, kins, i, j, joints))
    assert brute - 0.05 <= check.smallest <= brute + scene.step
    assert check.exact < check.samples * len(scene.pairs) / 4  # most poses skipped


# ----------------------------------------------------------------------------- bad input
def _machine_doc() -> dict[str, Any]:
    return tomllib.loads(XYZAC.read_text())


def _write_machine(tmp_path: Path, doc: dict[str, Any]) -> Path:
    path = tmp_path / "machine.toml"
    path.write_text(tomli_w.dumps(doc))
    return path


def _run_verify_cli(tmp_path: Path, machine: Path, capsys: pytest.CaptureFixture[str]) -> str:
    program = _program(tmp_path, HIGH)
    out = tmp_path / "out"
    code = main(["verify", str(program), "-m", str(machine), "-t", "ball6",
                 "--stock", STOCK, "-o", str(out), "--resolution", "1.0"])
    assert code == 2
    assert not out.exists()
    return capsys.readouterr().err


def test_a_component_on_a_missing_axis_exits_2(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    doc = _machine_doc()
    doc["model"]["component"][0]["axis"] = "B"
    err = _run_verify_cli(tmp_path, _write_machine(tmp_path, doc), capsys)
    assert "model.component[0] 'spindle_nose'.axis" in err
    assert "no axis 'B'" in err and "base, X, Y, Z, A, C" in err


def test_a_negative_size_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _machine_doc()
    doc["model"]["component"][2]["size"] = [60.0, -270.0, 75.0]
    err = _run_verify_cli(tmp_path, _write_machine(tmp_path, doc), capsys)
    assert "machine.toml" in err and "spindle_head" in err
    assert "every box size must be > 0 mm" in err


def test_an_unreadable_stl_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _machine_doc()
    (tmp_path / "head.stl").write_bytes(b"solid broken\n facet normal what\n")
    doc["model"]["component"][2] = {"name": "spindle_head", "axis": "Z", "shape": "stl",
                                    "file": "head.stl"}
    err = _run_verify_cli(tmp_path, _write_machine(tmp_path, doc), capsys)
    assert "model.component[2] 'spindle_head'.file" in err and "head.stl" in err


def test_a_pair_naming_an_unknown_component_is_refused() -> None:
    doc = _machine_doc()
    doc["model"]["pair"][0]["b"] = "rotary_tabel"
    with pytest.raises(InputError, match="did you mean 'rotary_table'"):
        machine_from_dict(doc, "machine.toml")


def test_a_pair_left_out_needs_a_reason() -> None:
    doc = _machine_doc()
    doc["model"]["pair"][0]["reason"] = " "
    with pytest.raises(InputError, match="needs a reason"):
        machine_from_dict(doc, "machine.toml")


def test_an_stl_component_is_checked(tmp_path: Path) -> None:
    """An STL platter behaves like the cylinder it replaces (same solid, as a mesh)."""
    import trimesh

    platter = trimesh.creation.cylinder(radius=50.0, height=18.0, sections=64)
    platter.export(tmp_path / "platter.stl")
    doc = _machine_doc()
    index = [c["name"] for c in doc["model"]["component"]].index("rotary_table")
    doc["model"]["component"][index] = {"name": "rotary_table", "axis": "C", "shape": "stl",
                                        "file": "platter.stl", "at": [0.0, 0.0, -59.0]}
    machine = load_machine(_write_machine(tmp_path, doc))
    kins = kinematics_for(machine)
    scene = machine_scene_for(machine, resolve_tool("ball6"), load_stock(STOCK, 1.0))
    assert scene is not None
    check = check_program(scene, kins, read_nc(_program(tmp_path, LOW)), "tilt")
    assert {tuple(e.details["components"]) for e in check.events} == {
        ("rotary_table", "tool")}


# ----------------------------------------------------------------------------- report
def test_the_chain_report_shows_the_clearance_and_the_worst_pose(tmp_path: Path) -> None:
    """verify/*/verify.json's machine keys reach the report: a summary card and a table
    with the picture of the worst pose (numbers copied, not recomputed)."""
    from cam.report.inputs import RunFolder
    from cam.report.machine import machine_check, machine_clearance_part
    from tests.cam.report_sample import png_bytes

    folder = tmp_path / "run"
    finish = folder / "verify" / "finish"
    finish.mkdir(parents=True)
    document = {
        "programs": [{"name": "finish_hub.ngc", "machine_clearance_mm": 6.4,
                      "machine_clearance_pair": ["spindle_head", "rotary_table"],
                      "machine_clearance_line": 16,
                      "machine_clearance_joints": [2.7, -24.4, 78.2, -94.8, -76.0]}],
        "event_counts": {"machine_collision": 0},
        "machine_model": {"components": [], "pairs_checked": [], "pairs_left_out": []},
    }
    (finish / "verify.json").write_text(json.dumps(document))
    (finish / "machine_1_finish_hub.png").write_bytes(png_bytes())
    run = RunFolder(folder)
    card = machine_check(run)
    assert card is not None and card[1] is True
    assert "finish 6.4 mm (finish_hub.ngc)" in card[2]
    part = machine_clearance_part(run)
    assert "spindle_head - rotary_table" in part and "-94.8" in part
    assert part.count("data:image/png;base64,") == 1
