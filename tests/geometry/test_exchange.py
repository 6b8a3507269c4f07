"""Exchange formats (issue 22): the hand-made files, the section split, bad input via the CLI.

The round trips with solids are in ``test_exchange_roundtrip.py`` (slow).
"""

from __future__ import annotations

import json
import math
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from cam.cli import main
from geometry.exchange.bladegen import read_bladegen
from geometry.exchange.cftgeo import read_cftgeo
from geometry.exchange.sections import split_section
from geometry.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]
BLADEGEN = ROOT / "fixtures" / "exchange" / "bladegen_cm" / "impeller.inf"
CFTURBO = ROOT / "fixtures" / "exchange" / "cfturbo_cm" / "impeller.cft-geo"
SPLITTER = load_spec(ROOT / "fixtures" / "impellers" / "splitter" / "spec.toml")


@pytest.mark.parametrize("source", [BLADEGEN, CFTURBO], ids=["bladegen", "cft-geo"])
def test_hand_made_file_imports(source: Path, tmp_path: Path,
                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "spec"
    assert main(["import", str(source), "-o", str(out), "--no-check-solid"]) == 0
    spec = load_spec(out / "spec.toml")
    report = json.loads((out / "import_report.json").read_text())
    assert spec.blades == 7 and spec.splitters == 1
    assert report["units"] == "CM" and report["blades_per_set"] == 2
    assert spec.leading_edge == "round" and spec.trailing_edge == "cut"
    # the files were written from the splitter fixture: same splitter start, same lines (mm)
    assert spec.splitter_start == pytest.approx(SPLITTER.splitter_start, abs=1e-4)
    assert np.abs(spec.hub_camber - SPLITTER.hub_camber).max() < 1e-3
    assert np.abs(spec.shroud_contour - SPLITTER.shroud_contour).max() < 1e-3
    assert len(report["spans"]) == 3 and report["ruled"] is True
    assert "blades: 7 + 7 splitters" in capsys.readouterr().out


def test_hub_points_at_varying_angles_give_the_same_contour() -> None:
    xyz = np.loadtxt(BLADEGEN.parent / "impeller_hub.crv")
    angles = np.unique(np.round(np.degrees(np.arctan2(xyz[:, 1], xyz[:, 0])), 3))
    assert len(angles) > 10
    blading = read_bladegen(BLADEGEN)
    assert np.abs(blading.hub - SPLITTER.hub_contour).max() < 1e-3  # mm, from r and z


def test_both_formats_read_the_same_blade() -> None:
    a, b = read_bladegen(BLADEGEN), read_cftgeo(CFTURBO)
    for blade_a, blade_b in zip(a.blades, b.blades, strict=True):
        for line_a, line_b in zip(blade_a.mean_lines, blade_b.mean_lines, strict=True):
            assert np.abs(line_a[:, [0, 2]] - line_b[:, [0, 2]]).max() < 2e-3


def _circle_loop(n_side: int, cap: int, half: float, cut_te: bool) -> np.ndarray:
    """A flat test blade along +x at z = 10 (r ~ 50): sides y = +-half, round LE."""
    x = np.linspace(0.0, 40.0, n_side)
    upper = np.column_stack([x, np.full(n_side, half), np.zeros(n_side)])
    lower = upper * np.array([1.0, -1.0, 1.0])
    phi = np.linspace(0.0, math.pi, cap + 2)[1:-1]
    nose = np.column_stack([-half * np.sin(phi), -half * np.cos(phi), np.zeros(cap)])
    parts = [upper]
    if not cut_te:
        parts.append(np.column_stack([40 + half * np.sin(phi), half * np.cos(phi),
                                      np.zeros(cap)]))
    parts += [lower[::-1], nose]
    loop = np.vstack(parts)
    return loop + np.array([50.0, 0.0, 10.0])  # r from 50 to 90: inlet at x = 50


@pytest.mark.parametrize("cut_te", [True, False])
def test_split_section_recovers_mean_line_and_thickness(cut_te: bool) -> None:
    loop = _circle_loop(21, 9, 1.25, cut_te)
    hub = np.array([[10.0, 40.0], [10.0, 100.0]])
    split = split_section(loop, hub, "round", "cut" if cut_te else "round")
    assert len(split.mean) == 21
    np.testing.assert_allclose(split.mean[:, 0], np.linspace(50.0, 90.0, 21), atol=1e-12)
    np.testing.assert_allclose(split.mean[:, 1:], [[0.0, 10.0]] * 21, atol=1e-12)
    np.testing.assert_allclose(split.thickness, 2.5, atol=1e-12)
    # the same loop started anywhere, in either direction
    turned = np.roll(loop, 17, axis=0)[::-1]
    again = split_section(turned, hub, "round", "cut" if cut_te else "round")
    np.testing.assert_allclose(again.mean, split.mean, atol=1e-12)


# -- bad input ------------------------------------------------------------------------
def _copy(tmp_path: Path) -> Path:
    folder = tmp_path / "in"
    shutil.copytree(BLADEGEN.parent, folder)
    return folder / BLADEGEN.name


def _edit(path: Path, pattern: str, new: str) -> None:
    text = path.read_text()
    changed = re.sub(pattern, new, text, count=1, flags=re.M)
    assert changed != text, pattern
    path.write_text(changed)


def _drop_profile(inf: Path) -> None:
    (inf.parent / "impeller_profile.crv").unlink()


def _open_block(inf: Path) -> None:
    profile = inf.parent / "impeller_profile.crv"
    lines = profile.read_text().splitlines()
    second = [i for i, line in enumerate(lines) if line.startswith("#")][1]
    del lines[second - 1]  # block 1 loses its closing point
    profile.write_text("\n".join(lines) + "\n")


def _one_span(inf: Path) -> None:
    profile = inf.parent / "impeller_profile.crv"
    lines = profile.read_text().splitlines()
    heads = [i for i, line in enumerate(lines) if line.startswith("#")]
    keep = lines[heads[0]:heads[1]] + lines[heads[3]:heads[4]]  # span 1 of each blade
    profile.write_text("\n".join(keep) + "\n")


def _short_block(inf: Path) -> None:
    profile = inf.parent / "impeller_profile.crv"
    lines = profile.read_text().splitlines()
    second = [i for i, line in enumerate(lines) if line.startswith("#")][1]
    del lines[second + 5]
    profile.write_text("\n".join(lines) + "\n")


CASES: dict[str, tuple[Callable[[Path], None], str]] = {
    "missing data file": (_drop_profile, r"impeller\.inf: field 'Profile Data File': line 9: "
                          r"data file not found"),
    "block not closed": (_open_block, r"impeller_profile\.crv: line \d+: profile block 1 "
                         r"\(opened at line 1\) is not closed"),
    "fewer than two spans": (_one_span, r"impeller_profile\.crv: line 1: only 1 span"),
    "mismatched point counts": (_short_block, r"impeller_profile\.crv: line \d+: profile "
                                r"block 2 has \d+ points, block 1 has \d+"),
    "unknown unit": (lambda inf: _edit(inf, r"^Geometry Units: CM", "Geometry Units: FT"),
                     r"impeller\.inf: field 'units': line 6: unknown length unit "
                     r"\(got 'FT'\); accepted: M, CM, MM or IN"),
    "axis not Z": (lambda inf: _edit(inf, r"^Axis of Rotation: Z", "Axis of Rotation: X"),
                   r"line 3: unsupported axis of rotation"),
    "three blades per set": (lambda inf: _edit(inf, r"^Number of Blades Per Set: 2",
                                               "Number of Blades Per Set: 3"),
                             r"line 5: unsupported value \(got '3'\); accepted: an integer "
                             r"from 1 to 2"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_bladegen_input(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    breaker, expected = CASES[case]
    inf = _copy(tmp_path)
    breaker(inf)
    out = tmp_path / "out"
    assert main(["import", str(inf), "-o", str(out), "--no-check-solid"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert re.search(expected, err), err
    assert not out.exists()


CFT_CASES = {
    "unknown unit": ("<LengthUnit>LengthCm</LengthUnit>", "<LengthUnit>LengthFt</LengthUnit>",
                     r"line 7: unknown length unit \(got 'LengthFt'\)"),
    "fewer than two spans": ("<SpanPositions>0.000000 0.500000 1.000000</SpanPositions>",
                             "<SpanPositions>0.000000</SpanPositions>",
                             r"line \d+: 3 mean lines for span positions '0.000000'"),
    "not a number": ('<Point r="2.200000"', '<Point r="2.2x"',
                     r"line 15: <Point> attribute r is not a number"),
}


@pytest.mark.parametrize("case", list(CFT_CASES))
def test_bad_cftgeo_input(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    old, new, expected = CFT_CASES[case]
    path = tmp_path / "impeller.cft-geo"
    text = CFTURBO.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    out = tmp_path / "out"
    assert main(["import", str(path), "-o", str(out), "--no-check-solid"]) == 2
    err = capsys.readouterr().err.strip()
    assert re.search(expected, err) and "impeller.cft-geo" in err, err
    assert not out.exists()


def test_cftgeo_mean_lines_of_different_lengths(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    text = CFTURBO.read_text()
    start = text.index("<MeanLines>")
    point = text.index("<Point", text.index("<Curve>", start))
    end = text.index("\n", point) + 1
    path = tmp_path / "impeller.cft-geo"
    path.write_text(text[:point] + text[end:])
    assert main(["import", str(path), "-o", str(tmp_path / "out"), "--no-check-solid"]) == 2
    err = capsys.readouterr().err
    assert re.search(r"line \d+: mean line of \d+ points, the first has \d+", err), err
    assert not (tmp_path / "out").exists()


def test_export_refuses_unknown_unit_and_format(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    spec = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
    assert main(["export", str(spec), "--format", "step", "-o", str(tmp_path / "a")]) == 2
    assert main(["export", str(spec), "--format", "bladegen", "--units", "FT",
                 "-o", str(tmp_path / "b")]) == 2
    assert "accepted: bladegen or cft-geo" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


# -- closed-form round trips of design variants (no solid: fast) -----------------------
def _variant(tmp_path: Path, **changes: object) -> Path:
    import dataclasses

    from geometry.design import load_design
    from geometry.design_files import write_design

    params = load_design(ROOT / "fixtures" / "impellers" / "round_te" / "design.toml")
    return write_design(dataclasses.replace(params, **changes), tmp_path / "variant")


VARIANTS: dict[str, dict[str, object]] = {
    "round edges": {},
    "cut edges": {"leading_edge": "cut", "trailing_edge": "cut"},
    "non-ruled": {"midspan_wrap_offset": math.radians(6.0)},
    "splitter": {"splitters": 1, "splitter_start": 0.4},
}


@pytest.mark.parametrize("fmt", ["bladegen", "cft-geo"])
@pytest.mark.parametrize("variant", list(VARIANTS))
def test_variant_round_trip(variant: str, fmt: str, tmp_path: Path) -> None:
    from geometry.surfaces import build_surfaces

    spec_path = _variant(tmp_path, **VARIANTS[variant])
    suffix = "inf" if fmt == "bladegen" else "cft-geo"
    assert main(["export", str(spec_path), "--format", fmt, "--units", "IN",
                 "-o", str(tmp_path / "files")]) == 0
    assert main(["import", str(tmp_path / "files" / f"round_te.{suffix}"),
                 "-o", str(tmp_path / "back"), "--no-check-solid"]) == 0
    before, after = load_spec(spec_path), load_spec(tmp_path / "back" / "spec.toml")
    assert (after.midspan_camber is None) == (before.midspan_camber is None)
    assert (after.leading_edge, after.trailing_edge, after.splitters) == \
        (before.leading_edge, before.trailing_edge, before.splitters)
    a, b = build_surfaces(before), build_surfaces(after)
    u, v = np.meshgrid(np.linspace(0, 1, 101), np.linspace(0, 1, 11), indexing="ij")
    for blade_a, blade_b in zip(a.all_blades(), b.all_blades(), strict=True):
        for side in (1, -1):
            gap = np.linalg.norm(blade_a.side(u, v, side) - blade_b.side(u, v, side), axis=-1)
            assert gap.max() < 0.01
    report = json.loads((tmp_path / "back" / "import_report.json").read_text())
    assert report["ruled"] is (before.midspan_camber is None)
