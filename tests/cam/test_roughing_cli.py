"""``impeller-cam rough`` options through the CLI: bad values exit 2 with one line that
names the field, the value and what is accepted, and write nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from cam.cli import main

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "fixtures/impellers/nine_blade/spec.toml"
MACHINE = ROOT / "fixtures/machines/trunnion-500.toml"


@pytest.mark.parametrize(("option", "value", "expect"), [
    ("--baseline-layering", "planar", ("baseline_layering", "'planar'", "ruling, depth")),
    ("--max-depth", "-1", ("max_depth_mm", "-1", "0 (tool radius)")),
    ("--step-along", "0", ("step_along_mm", "0", "> 0")),
])
def test_bad_rough_option_exits_2_and_writes_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, value: str,
        expect: tuple[str, ...]) -> None:
    out = tmp_path / "out"
    code = main(["rough", str(SPEC), "-m", str(MACHINE), "-t", "ball10", "-o", str(out),
                 option, value])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and err.startswith("impeller-cam: error:")
    for text in expect:
        assert text in err
    assert not out.exists()
