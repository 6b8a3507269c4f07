"""The spec's ``[machining]`` table and the command-line overrides (fast, no chain)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cam.cli import main
from cam.run.settings import DEFAULT_RESOLUTION, resolve_settings
from geometry.machining import machining_of
from geometry.spec import load_spec
from impeller_cam.errors import InputError

ROOT = Path(__file__).resolve().parents[3]
FIXTURES = ROOT / "fixtures" / "impellers"
MACHINE = ROOT / "fixtures" / "machines" / "trunnion-500.toml"


def spec_with(tmp_path: Path, table: str) -> Path:
    """The small fixture's spec with its [machining] table replaced by ``table``."""
    for name in ("hub_camber.csv", "shroud_camber.csv"):
        (tmp_path / name).write_bytes((FIXTURES / "small" / name).read_bytes())
    text = (FIXTURES / "small" / "spec.toml").read_text()
    text = text.split("[machining]")[0]
    path = tmp_path / "spec.toml"
    path.write_text(text + table)
    return path


@pytest.mark.parametrize("name", ["small", "nine_blade", "splitter"])
def test_every_fixture_names_its_tools(name: str) -> None:
    table = machining_of(FIXTURES / name / "spec.toml")
    assert table.rough_tool and table.finish_tool
    settings = resolve_settings(FIXTURES / name / "spec.toml")
    assert settings.rough_tool == table.rough_tool
    assert settings.finish_tool == table.finish_tool


def test_the_spec_reader_keeps_the_table() -> None:
    spec = load_spec(FIXTURES / "nine_blade" / "spec.toml")
    assert spec.machining == machining_of(FIXTURES / "nine_blade" / "spec.toml")


def test_command_line_overrides_the_table(tmp_path: Path) -> None:
    spec = spec_with(tmp_path, '[machining]\nrough_tool = "ball6"\nfinish_tool = "ball4_taper"\n'
                     'verify_resolution_mm = 0.25\n[machining.rough]\nscallop_mm = 0.7\n'
                     'step_along_mm = 1.5\n')
    plain = resolve_settings(spec)
    assert (plain.rough_tool, plain.finish_tool) == ("ball6", "ball4_taper")
    assert plain.verify_resolution_mm == 0.25 and plain.post is None
    assert plain.rough == {"scallop_mm": 0.7, "step_along_mm": 1.5}
    both = resolve_settings(spec, tool="flat10")
    assert (both.rough_tool, both.finish_tool) == ("flat10", "flat10")
    one = resolve_settings(spec, tool="ball4", finish_tool="ball6_taper", post="fanuc",
                           rough={"scallop_mm": 0.4}, verify_resolution_mm=0.5)
    assert (one.rough_tool, one.finish_tool, one.post) == ("ball4", "ball6_taper", "fanuc")
    assert one.rough == {"scallop_mm": 0.4, "step_along_mm": 1.5}  # key by key
    assert one.verify_resolution_mm == 0.5


def test_no_table_needs_tools_on_the_command_line(tmp_path: Path) -> None:
    spec = spec_with(tmp_path, "")
    with pytest.raises(InputError, match="no roughing tool"):
        resolve_settings(spec)
    settings = resolve_settings(spec, tool="ball4_taper")
    assert settings.verify_resolution_mm == DEFAULT_RESOLUTION


@pytest.mark.parametrize(("table", "field", "value"), [
    ('[machining]\nrough_tol = "ball6"\n', "machining.rough_tol", "ball6"),
    ("[machining]\nrough_tool = 6\n", "machining.rough_tool", "6"),
    ("[machining]\nverify_resolution_mm = 0\n", "machining.verify_resolution_mm", "0"),
    ('[machining]\nverify_resolution_mm = "fine"\n', "machining.verify_resolution_mm",
     "fine"),
    ("[machining]\nrough = 3\n", "machining.rough", "3"),
    ('[machining]\nrough_tool = "ball6"\nfinish_tool = "ball4_taper"\n'
     "[machining.rough]\nscallop = 0.5\n", "machining.rough.scallop", "0.5"),
    ('[machining]\nrough_tool = "ball6"\nfinish_tool = "ball4_taper"\n'
     "[machining.finish]\nscallop_mm = -1.0\n", "machining.finish.scallop_mm", "-1.0"),
])
def test_bad_table_is_exit_2_naming_file_field_and_value(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], table: str, field: str,
        value: str) -> None:
    spec = spec_with(tmp_path, table)
    code = main(["run", str(spec), "-m", str(MACHINE), "-o", str(tmp_path / "out")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert str(spec) in err and field in err and value in err
    assert not (tmp_path / "out").exists()  # nothing written before the first stage


def test_unknown_stage_is_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["run", str(FIXTURES / "small" / "spec.toml"), "-m", str(MACHINE), "-o",
                 str(tmp_path / "out"), "--stage", "polish"])
    assert code == 2
    assert "polish" in capsys.readouterr().err
