"""Spec loading and validation: each bad input names file, field, value, what is accepted."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from geometry.spec import load_spec
from impeller_cam.errors import InputError
from tests.geometry.synthetic import write_synthetic_spec


def test_good_spec_loads(tmp_path: Path) -> None:
    spec = load_spec(write_synthetic_spec(tmp_path))
    assert spec.blades == 6
    assert spec.pitch == pytest.approx(2 * np.pi / 6)
    assert spec.shroud_camber.shape == (12, 3)
    assert spec.thickness(np.array([0.0, 0.5, 1.0])) == pytest.approx([1.5, 1.5, 1.5])
    assert spec.leading_edge == "round" and spec.trailing_edge == "cut"


def _error(path: Path) -> InputError:
    with pytest.raises(InputError) as info:
        load_spec(path)
    return info.value


def test_missing_spec_file(tmp_path: Path) -> None:
    error = _error(tmp_path / "nope.toml")
    assert "not found" in str(error) and "nope.toml" in str(error)


def test_zero_blades(tmp_path: Path) -> None:
    error = _error(write_synthetic_spec(tmp_path, blades=0))
    assert error.field == "impeller.blades" and error.value == 0
    assert "1..64" in str(error)


def test_nan_in_camber_csv(tmp_path: Path) -> None:
    path = write_synthetic_spec(tmp_path)
    lines = (tmp_path / "hub.csv").read_text().splitlines()
    lines[3] = "nan," + lines[3].split(",", 1)[1]
    (tmp_path / "hub.csv").write_text("\n".join(lines) + "\n")
    error = _error(path)
    assert error.file and error.file.endswith("hub.csv") and error.field == "r"
    assert "line 4" in str(error)


def test_non_numeric_in_camber_csv(tmp_path: Path) -> None:
    path = write_synthetic_spec(tmp_path)
    text = (tmp_path / "shroud.csv").read_text().replace(",", ",abc", 1)
    (tmp_path / "shroud.csv").write_text(text.replace("r,abctheta_deg", "r,theta_deg"))
    lines = (tmp_path / "shroud.csv").read_text().splitlines()
    lines[2] = lines[2].split(",")[0] + ",twelve," + lines[2].split(",")[2]
    (tmp_path / "shroud.csv").write_text("\n".join(lines) + "\n")
    error = _error(path)
    assert error.field == "theta_deg" and error.value == "twelve"


def test_too_few_points(tmp_path: Path) -> None:
    error = _error(write_synthetic_spec(tmp_path, points=3))
    assert "too few points (3)" in str(error) and "at least 4" in str(error)


def test_meridional_coordinate_going_backwards(tmp_path: Path) -> None:
    path = write_synthetic_spec(tmp_path)
    lines = (tmp_path / "hub.csv").read_text().splitlines()
    lines[4], lines[5] = lines[5], lines[4]
    (tmp_path / "hub.csv").write_text("\n".join(lines) + "\n")
    error = _error(path)
    assert "backwards" in str(error) and error.field == "camber.hub"


def test_hub_and_shroud_crossing(tmp_path: Path) -> None:
    # swap the files: the shroud line now lies inside the hub
    path = write_synthetic_spec(tmp_path)
    text = path.read_text()
    text = (
        text.replace('shroud = "shroud.csv"', 'shroud = "X"')
        .replace('hub = "hub.csv"', 'hub = "shroud.csv"')
        .replace('shroud = "X"', 'shroud = "hub.csv"')
    )
    path.write_text(text)
    error = _error(path)
    assert error.field in {"camber.hub", "camber.shroud"}


def test_bad_edge_shape_and_negative_fillet(tmp_path: Path) -> None:
    path = write_synthetic_spec(tmp_path)
    path.write_text(path.read_text().replace('leading_edge = "round"', 'leading_edge = "sharp"'))
    error = _error(path)
    assert error.field == "blade.leading_edge" and "'round' or 'cut'" in str(error)
    path = write_synthetic_spec(tmp_path / "b", fillet=-1.0)
    error = _error(path)
    assert error.field == "blade.fillet_radius_mm" and error.value == -1.0


def test_thickness_law_must_increase(tmp_path: Path) -> None:
    path = write_synthetic_spec(
        tmp_path, thickness="thickness = { u = [0, 0.6, 0.5, 1], mm = [1, 2, 2, 1] }"
    )
    error = _error(path)
    assert error.field == "blade.thickness.u"
