"""``impeller-cam motion`` sub-commands: JSON outputs and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from cam.motion.cli import motion_app
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
PLANT = ROOT / "fixtures" / "motion" / "indexing_table.toml"
MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"
runner = CliRunner()


def _json(args: list[str]) -> dict:  # type: ignore[type-arg]
    result = runner.invoke(motion_app, args + ["--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_scurve_json() -> None:
    data = _json(["scurve", "--stroke", "20", "--vmax", "500", "--amax-up", "30000",
                  "--amax-down", "20000", "--s-factor", "22"])
    assert data["peak_velocity"] == 500.0 and data["peak_deceleration"] == 20000.0
    assert data["duration_s"] == pytest.approx(sum(data["segment_durations_s"]))
    assert {"duration_s", "peak_velocity", "peak_acceleration",
            "peak_deceleration"} <= set(data)


def test_scurve_bad_input_raises_input_error() -> None:
    result = runner.invoke(motion_app, ["scurve", "--stroke", "20", "--vmax", "-1",
                                        "--amax-up", "1", "--amax-down", "1",
                                        "--s-factor", "1"])
    assert isinstance(result.exception, InputError)
    assert result.exception.field == "vmax"


def test_optimize_json_and_plots(tmp_path: Path) -> None:
    data = _json(["optimize", "--plant", str(PLANT), "--stroke", "20", "--s-step", "23",
                  "--a-step", "10000", "--v-step", "150", "--workers", "0",
                  "--plots", str(tmp_path)])
    times = data["positioning_time_s"]
    assert set(times) == {"best", "best_symmetric", "case_max"}
    assert times["best"] <= times["best_symmetric"]
    assert data["case_max"]["s_factor"] == 22.0
    assert data["grid"]["profiles"] == 6 * 3 * 3 * 3
    assert all(Path(p).is_file() for p in data["plots"])


def test_servo_json() -> None:
    data = _json(["servo", "--machine", str(MACHINE), "--axis", "C", "--omega", "3.14159"])
    assert data["saturation_omega_rad_s"] > 0
    assert data["smallest_radius_mm"] == pytest.approx(
        200.0 / 60.0 / data["saturation_omega_rad_s"])
    row = data["best_kffp"][0]
    assert row["best_kffp_X_percent"] is not None and row["best_kffp_Y_percent"] is not None


def test_servo_unknown_axis() -> None:
    result = runner.invoke(motion_app, ["servo", "--machine", str(MACHINE), "--axis", "A"])
    assert isinstance(result.exception, InputError)


def test_time_json(tmp_path: Path) -> None:
    nc = tmp_path / "p.ngc"
    nc.write_text("G21 G90 G94\nG1 X100 F600\nG0 X0\nM2\n")
    data = _json(["time", str(nc), "-m", str(MACHINE)])
    assert data["blocks"] == 2
    assert data["nominal_time_s"] == pytest.approx(10.0 + 100.0 / 600.0)
    assert data["cycle_time_s"] > data["nominal_time_s"]
    # a reversal (G1 out, G0 back) stops in between: blending gains nothing, so the
    # blended time is the exact-stop time within the corner speed's share
    assert data["nominal_time_s"] < data["blended_time_s"] <= data["cycle_time_s"] + 1e-9
    assert data["blend_tolerance_mm"] == 0.01


def test_servo_on_a_program(tmp_path: Path) -> None:
    # C turns a quarter while X/Y follow a circle of 8 mm (degrees in the NC file)
    lines = ["G21 G90 G94", "G0 X8 Y0 Z10 A0 C0", "F3000"]
    for k in range(1, 37):
        angle = k * 2.5
        rad = math.radians(angle)
        lines.append(f"G1 X{8 * math.cos(rad):.4f} Y{8 * math.sin(rad):.4f} C{angle:.3f}")
    lines.append("M2")
    nc = tmp_path / "circle.ngc"
    nc.write_text("\n".join(lines) + "\n")
    data = _json(["servo", "--machine", str(MACHINE), "--omega", "3.14159",
                  "--program", str(nc)])
    program = data["program"]
    assert program["max_contour_error_mm"] <= program["max_tracking_error_mm"] + 1e-12
    assert program["reference_axis"] == "C"
    assert program["axis_models"]["Z"] == "default: matched to Y"
    assert set(program["recommended_kffp_percent"]) == {"X", "Y", "Z", "A", "C"}


def test_identify_json() -> None:
    response = ROOT / "fixtures" / "motion" / "indexing_response.csv"
    data = _json(["identify", "--plant", str(PLANT), "--response", str(response),
                  "--free", "stiffness", "--free", "damping"])
    assert data["plant"]["stiffness"] == pytest.approx(7.3e5, rel=0.02)
    assert data["relative_rms"] < 0.1


def test_identify_feed_drive_json() -> None:
    response = ROOT / "fixtures" / "motion" / "feed_drive_response.csv"
    data = _json(["identify", "--machine", str(MACHINE), "--axis", "C", "--response",
                  str(response)])
    assert data["free"] == ["J", "C", "Ta", "Tp"] and data["start"] == "identified"
    assert data["servo"]["Tp"] == pytest.approx(0.005, rel=0.02)
    assert data["servo"]["torque_limit"] == 725.0
    # an axis without servo data starts from its stated default
    default = _json(["identify", "--machine", str(MACHINE), "--axis", "A", "--response",
                     str(response), "--free", "Ta"])
    assert default["start"] == "default: matched to C"


def test_identify_needs_a_target() -> None:
    response = ROOT / "fixtures" / "motion" / "feed_drive_response.csv"
    result = runner.invoke(motion_app, ["identify", "--response", str(response)])
    assert isinstance(result.exception, InputError)
    result = runner.invoke(motion_app, ["identify", "--machine", str(MACHINE), "--axis", "W",
                                        "--response", str(response)])
    assert isinstance(result.exception, InputError)


def test_circle_json(tmp_path: Path) -> None:
    drives = ROOT / "fixtures" / "motion" / "suzuki_table1.toml"
    data = _json(["circle", "--drives", str(drives), "--plot", str(tmp_path / "c.png")])
    assert len(data["points"]) == 18 and (tmp_path / "c.png").is_file()
    assert all(p["best_amplitude_um"] < p["machine_amplitude_um"] for p in data["points"])
    assert data["saturation"][0]["limit_acceleration"] == pytest.approx(725 / 5.9)
    result = runner.invoke(motion_app, ["circle", "--drives", str(PLANT)])
    assert isinstance(result.exception, InputError)
