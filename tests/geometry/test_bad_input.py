"""Bad impeller specs through the CLI: exit code 2, one clear line, nothing in OUT/.

Each case copies the `small` fixture, breaks one thing, and runs
``impeller-cam geometry SPEC -o OUT/``. The spec is rejected before any solid is built.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from cam.cli import main

SMALL = Path(__file__).resolve().parents[2] / "fixtures" / "impellers" / "small"


def _edit_line(path: Path, index: int, column: int, value: str) -> None:
    lines = path.read_text().splitlines()
    cells = lines[index].split(",")
    cells[column] = value
    lines[index] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def _swap_lines(path: Path, a: int, b: int) -> None:
    lines = path.read_text().splitlines()
    lines[a], lines[b] = lines[b], lines[a]
    path.write_text("\n".join(lines) + "\n")


def _replace(path: Path, pattern: str, new: str) -> None:
    text = path.read_text()
    changed = re.sub(pattern, new, text, count=1, flags=re.M)
    assert changed != text, pattern
    path.write_text(changed)


def _keep_rows(path: Path, rows: int) -> None:
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[: rows + 1]) + "\n")


CASES: dict[str, tuple[Callable[[Path], None], tuple[str, ...]]] = {
    "missing camber file": (
        lambda d: (d / "hub_camber.csv").unlink(),
        ("hub_camber.csv", "camber.hub", "not found"),
    ),
    "non-numeric value": (
        lambda d: _edit_line(d / "shroud_camber.csv", 3, 1, "abc"),
        ("shroud_camber.csv", "theta_deg", "'abc'", "line 4"),
    ),
    "NaN value": (
        lambda d: _edit_line(d / "hub_camber.csv", 2, 0, "nan"),
        ("hub_camber.csv", "field 'r'", "line 3", "finite"),
    ),
    "too few points": (
        lambda d: _keep_rows(d / "hub_camber.csv", 3),
        ("hub_camber.csv", "too few points (3)", "at least 4"),
    ),
    "meridional coordinate backwards": (
        lambda d: _swap_lines(d / "hub_camber.csv", 4, 5),
        ("spec.toml", "camber.hub", "backwards"),
    ),
    "hub and shroud crossing": (
        lambda d: (
            shutil.copy(d / "hub_camber.csv", d / "tmp.csv"),
            shutil.copy(d / "shroud_camber.csv", d / "hub_camber.csv"),
            shutil.copy(d / "tmp.csv", d / "shroud_camber.csv"),
        ),
        ("spec.toml", "camber."),
    ),
    "blades touching": (
        lambda d: _replace(d / "spec.toml", r"^thickness_mm = .*$", "thickness_mm = 14.0"),
        ("spec.toml", "blade.thickness_mm", "14.0", "touch"),
    ),
    "fillet larger than the passage": (
        lambda d: _replace(d / "spec.toml", r"^fillet_radius_mm = .*$", "fillet_radius_mm = 9.0"),
        ("spec.toml", "blade.fillet_radius_mm", "9.0"),
    ),
    "zero blades": (
        lambda d: _replace(d / "spec.toml", r"^blades = .*$", "blades = 0"),
        ("spec.toml", "impeller.blades", "0", "1..64"),
    ),
    "missing spec": (
        lambda d: (d / "spec.toml").unlink(),
        ("spec.toml", "not found"),
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_spec_exits_2_with_one_clear_line_and_no_output(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "spec"
    shutil.copytree(SMALL, folder)
    breaker, expected = CASES[case]
    breaker(folder)
    out = tmp_path / "out"
    code = main(["geometry", str(folder / "spec.toml"), "-o", str(out)])
    message = capsys.readouterr().err.strip()
    assert code == 2, message
    assert message.count("\n") == 0 and message.startswith("impeller-cam: error: ")
    for fragment in expected:
        assert fragment in message, (fragment, message)
    assert not out.exists() or not any(out.iterdir())


def test_existing_output_is_left_alone_on_bad_input(tmp_path: Path) -> None:
    folder = tmp_path / "spec"
    shutil.copytree(SMALL, folder)
    _replace(folder / "spec.toml", r"^blades = .*$", "blades = 0")
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("earlier result\n")
    assert main(["geometry", str(folder / "spec.toml"), "-o", str(out)]) == 2
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]
