"""The input-file commands: design, check, tools, example, --version, unknown commands."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cam.cli import main
from geometry.spec import load_spec
from impeller_cam import __version__

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "fixtures"
Capture = pytest.CaptureFixture[str]


def test_version(capsys: Capture) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"impeller-cam {__version__}"


def test_unknown_command_is_a_usage_error(capsys: Capture) -> None:
    assert main(["frobnicate"]) == 2
    err = capsys.readouterr().err
    assert "No such command 'frobnicate'" in err and "Usage:" in err
    assert "internal error" not in err


def test_design_writes_spec_csvs_and_figures(tmp_path: Path, capsys: Capture) -> None:
    out = tmp_path / "variant"
    assert main(["design", str(FIXTURES / "impellers" / "small" / "design.toml"),
                 "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "figures.json", "hub_camber.csv", "shroud_camber.csv", "spec.toml"]
    for name in ("spec.toml", "hub_camber.csv", "shroud_camber.csv"):  # same as the fixture
        assert (out / name).read_bytes() == (FIXTURES / "impellers" / "small" / name).read_bytes()
    figures = json.loads((out / "figures.json").read_text())
    spec = load_spec(out / "spec.toml")
    assert figures["blades"] == spec.blades == 6
    assert figures["D2_mm"] == pytest.approx(2 * spec.shroud_camber[-1, 0])
    assert 0 < figures["r_max_mm"] < figures["d_min_mm"]
    assert figures["fillet_radius_mm"] <= figures["max_fillet_radius_mm"]
    printed = capsys.readouterr().out
    for words in ("D2", "b2", "wrap", "blade angle", "d_min", "r_max", "largest fillet"):
        assert words in printed


def test_design_refuses_a_fillet_too_large_and_writes_nothing(tmp_path: Path,
                                                             capsys: Capture) -> None:
    design = tmp_path / "design.toml"
    text = (FIXTURES / "impellers" / "small" / "design.toml").read_text()
    design.write_text(text.replace("fillet_radius_mm = 1.0", "fillet_radius_mm = 30.0"))
    out = tmp_path / "out"
    assert main(["design", str(design), "-o", str(out)]) == 2
    assert "blade.fillet_radius_mm" in capsys.readouterr().err
    assert not out.exists()


def test_check_tells_every_fixture_kind(capsys: Capture) -> None:
    files = sorted(FIXTURES.glob("**/*.toml"))
    assert main(["check", *map(str, files)]) == 0
    out = capsys.readouterr().out
    for kind in ("spec", "design", "machine", "tools", "plant", "feed-drive"):
        assert f"ok ({kind})" in out
    assert out.count(": ok (") == len(files)


def test_check_reports_each_bad_file(tmp_path: Path, capsys: Capture) -> None:
    bad = tmp_path / "tools.toml"
    bad.write_text((FIXTURES / "tools" / "library.toml").read_text()
                   .replace("feed_mm_min = 1500", "feed_mm_min = -1500"))
    good = FIXTURES / "machines" / "xyzac-trt.toml"
    assert main(["check", str(bad), str(good)]) == 2
    captured = capsys.readouterr()
    assert "tool 'ball10'.feed_mm_min" in captured.err and "must be positive" in captured.err
    assert f"{good}: ok (machine)" in captured.out
    assert main(["check", "--kind", "plant", str(good)]) == 2
    assert main(["check", "--kind", "gcode", str(good)]) == 2
    unknown = tmp_path / "other.toml"
    unknown.write_text("colour = 1\n")
    assert main(["check", str(unknown)]) == 2
    assert "cannot tell what kind" in capsys.readouterr().err


def test_tools_lists_parts(tmp_path: Path, capsys: Capture) -> None:
    assert main(["tools"]) == 0
    out = capsys.readouterr().out
    assert "T2 ball6_taper: cutter ball D6" in out and "taper 2 deg" in out
    assert "holder 40 x D20-26 + 40 x D50" in out
    assert "bull10r2" in out and "r2" in out
    assert "T8 ball6_flank3: cutter ball D6 tapered 3 deg, flutes 45, shank D12" in out
    assert main(["tools", str(FIXTURES / "nc" / "thirdparty" / "tools.toml")]) == 0
    assert capsys.readouterr().out.startswith("T1 ball4_long")
    bad = tmp_path / "lib.toml"
    bad.write_text("[[tool]]\nname = 'x'\n")
    assert main(["tools", str(bad)]) == 2
    assert main(["tools", str(tmp_path / "absent.toml")]) == 2


def test_example_writes_a_spec_folder(tmp_path: Path, capsys: Capture) -> None:
    out = tmp_path / "start"
    assert main(["example", "nine_blade", "-o", str(out)]) == 0
    assert load_spec(out / "spec.toml").blades == 9
    assert main(["check", str(out / "spec.toml"), str(out / "design.toml")]) == 0
    assert main(["example", "ten_blade", "-o", str(tmp_path / "no")]) == 2
    assert "nine_blade" in capsys.readouterr().err
    assert not (tmp_path / "no").exists()


def test_bundled_data_is_the_fixtures() -> None:
    """One copy of each file: the repository's fixtures/ links to the bundled data."""
    from impeller_cam.data import data_path

    bundled = data_path()
    files = sorted(p.relative_to(bundled) for p in bundled.rglob("*")
                   if p.is_file() and p.suffix != ".py" and "__pycache__" not in p.parts)
    assert len(files) >= 20
    for rel in files:
        assert (FIXTURES / rel).is_symlink(), rel
        assert (FIXTURES / rel).samefile(bundled / rel), rel


def test_json_schemas_are_up_to_date() -> None:
    from cam.inputs import SCHEMA_FOLDER, schema_text, schemas

    generated = schemas()
    assert sorted(generated) == sorted(p.name for p in SCHEMA_FOLDER.glob("*.json"))
    for name, schema in generated.items():
        assert (SCHEMA_FOLDER / name).read_text() == schema_text(schema), (
            f"{name} is stale: run python -m cam.inputs")
    tools = generated["tools.schema.json"]
    holder = tools["$defs"]["ToolTable"]["properties"]["holder"]
    assert tools["$defs"]["ToolTable"]["additionalProperties"] is False and holder
    rough = generated["spec.schema.json"]["$defs"]["MachiningTable"]["properties"]["rough"]
    assert "scallop_mm" in rough["properties"] and rough["additionalProperties"] is False


def test_example_copy_is_independent(tmp_path: Path) -> None:
    out = tmp_path / "ex"
    assert main(["example", "small", "-o", str(out)]) == 0
    shutil.rmtree(out)
    from impeller_cam.data import example_folder

    assert (example_folder("small") / "spec.toml").is_file()


@pytest.mark.parametrize(("old", "new", "extra"), [
    ("fillet_radius_mm", "fillet_radus_mm", []),
    ('rough_tool = "ball6"', 'rough_tool = "ball66"', []),
    ("", "", ["-m", "no-such-machine"]),
    ("", "", ["-t", "ball6_tapr"]),
])
def test_run_checks_every_input_before_writing(tmp_path: Path, old: str, new: str,
                                               extra: list[str], capsys: Capture) -> None:
    source = FIXTURES / "impellers" / "small"
    for item in source.iterdir():
        shutil.copyfile(item, tmp_path / item.name)
    spec = tmp_path / "spec.toml"
    spec.write_text(spec.read_text().replace(old, new, 1) if old else spec.read_text())
    out = tmp_path / "out"
    args = ["run", str(spec), "-m", "trunnion-500", "-o", str(out), *extra]
    if "-m" in extra:
        args = ["run", str(spec), "-o", str(out), *extra]
    assert main(args) == 2
    assert capsys.readouterr().err.startswith("impeller-cam: error: ")
    assert not out.exists()


@pytest.mark.parametrize("kind", ["spec", "design", "machine", "tools", "plant", "feed-drive"])
def test_fixtures_meet_their_json_schema_and_a_typo_does_not(kind: str) -> None:
    import tomllib

    import jsonschema

    from cam.inputs import SCHEMA_FOLDER, check_file

    schema = json.loads((SCHEMA_FOLDER / f"{kind}.schema.json").read_text())
    validator = jsonschema.Draft202012Validator(schema)
    files = [p for p in sorted(FIXTURES.glob("**/*.toml")) if check_file(p)[0] == kind]
    assert files
    for path in files:
        data = tomllib.loads(path.read_text())
        assert not list(validator.iter_errors(data)), path
        data["colour"] = 1  # an unknown key at the top level
        assert list(validator.iter_errors(data)), path


def test_check_reads_a_linuxcnc_tool_table(tmp_path: Path, capsys: Capture) -> None:
    table = tmp_path / "tool.tbl"
    table.write_text("T1 P1 D6.0 Z40.0 ;6 mm ball\n")
    assert main(["check", str(table)]) == 0
    assert "ok (tools)" in capsys.readouterr().out
    table.write_text("T1 P1 Z40.0\n")
    assert main(["check", str(table)]) == 2
