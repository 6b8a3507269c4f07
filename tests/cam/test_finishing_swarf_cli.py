"""``impeller-cam finish --blade-strategy`` / ``--check-swarf`` and the spec's
``[machining.finish] blade_strategy`` (issue 23)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cam.cli import main

ROOT = Path(__file__).resolve().parents[2]
STRAIGHT = ROOT / "fixtures" / "impellers" / "straight" / "spec.toml"
Capture = pytest.CaptureFixture[str]


def test_a_bad_blade_strategy_option_is_refused(tmp_path: Path, capsys: Capture) -> None:
    out = tmp_path / "out"
    code = main(["finish", str(STRAIGHT), "-m", "trunnion-500", "-t", "ball4_taper",
                 "-o", str(out), "--blade-strategy", "flank"])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("impeller-cam: error: ") and err.count("\n") == 1
    for word in ("--blade-strategy", "'flank'", "point, swarf, swarf_or_point"):
        assert word in err
    assert not out.exists()


def test_a_bad_blade_strategy_in_the_spec_is_refused(tmp_path: Path, capsys: Capture) -> None:
    source = ROOT / "fixtures" / "impellers" / "small"
    for item in source.iterdir():
        shutil.copyfile(item, tmp_path / item.name)
    spec = tmp_path / "spec.toml"
    text = spec.read_text()
    assert "[machining.finish]\n" in text
    spec.write_text(text.replace("[machining.finish]\n",
                                 '[machining.finish]\nblade_strategy = "flank"\n', 1))
    out = tmp_path / "out"
    for args in (["check", str(spec)],
                 ["run", str(spec), "-m", "trunnion-500", "-o", str(out)]):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1
        for word in (str(spec), "machining.finish.blade_strategy", "'flank'", "'point'",
                     "'swarf'", "'swarf_or_point'"):
            assert word in err
    assert not out.exists()


def test_finish_needs_an_output_folder_unless_checking(capsys: Capture) -> None:
    assert main(["finish", str(STRAIGHT), "-m", "trunnion-500", "-t", "ball4_taper"]) == 2
    assert "-o" in capsys.readouterr().err


def test_check_swarf_prints_the_prediction_per_band(tmp_path: Path, capsys: Capture) -> None:
    """On the developable fixture: no rule deviation, every ruling within tolerance,
    75 % of each side in the band; nothing written."""
    out = tmp_path / "out"
    code = main(["finish", str(STRAIGHT), "-m", "trunnion-500", "-t", "ball4_taper",
                 "-o", str(out), "--check-swarf"])
    assert code == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    assert lines[0].startswith("rule deviation of the blades: ")
    assert float(lines[0].split(": ")[1].split()[0]) < 1e-3
    walls = [line for line in lines if line.startswith("  blade")]
    assert len(walls) == 2
    for line in walls:
        rulings = line.split("rulings ")[1].split()[0]
        cut, total = (int(x) for x in rulings.split("/"))
        assert cut == total > 0
        assert "75.0 % of the side" in line
    assert not out.exists()
