"""Round trips (issue 22): spec -> BladeGen / CFturbo files -> spec -> solid, per fixture.

Each fixture's original solid and the two imported ones are built once per module.
Acceptance: solid volume within 0.1 %, blade surfaces within 0.01 mm, d_min and
r_max within 0.01 mm.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cam.cli import main
from geometry.brep import volume
from geometry.figures import compute_figures
from geometry.impeller import Impeller

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
FORMATS = {"bladegen": "inf", "cft-geo": "cft-geo"}


@pytest.fixture(scope="module", params=["nine_blade", "splitter", "small"])
def trip(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
         ) -> dict[str, Any]:
    name = request.param
    spec = ROOT / "fixtures" / "impellers" / name / "spec.toml"
    out: dict[str, Any] = {"original": Impeller.from_spec(spec)}
    for fmt, suffix in FORMATS.items():
        folder = tmp_path_factory.mktemp(f"{name}-{fmt}")
        unit = "IN" if fmt == "bladegen" else "M"
        assert main(["export", str(spec), "--format", fmt, "--units", unit,
                     "-o", str(folder / "files")]) == 0
        assert main(["import", str(folder / "files" / f"{name}.{suffix}"),
                     "-o", str(folder / "spec"), "--no-check-solid"]) == 0
        out[fmt] = Impeller.from_spec(folder / "spec" / "spec.toml")
    return out


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_volume_within_a_thousandth(trip: dict[str, Any], fmt: str) -> None:
    before, after = volume(trip["original"].solid), volume(trip[fmt].solid)
    assert abs(after - before) <= 1e-3 * before


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_blade_surfaces_within_a_hundredth(trip: dict[str, Any], fmt: str) -> None:
    a, b = trip["original"].surfaces, trip[fmt].surfaces
    u, v = np.meshgrid(np.linspace(0, 1, 201), np.linspace(0, 1, 21), indexing="ij")
    assert len(a.all_blades()) == len(b.all_blades())
    for blade_a, blade_b in zip(a.all_blades(), b.all_blades(), strict=True):
        for side in (1, -1):
            gap = np.linalg.norm(blade_a.side(u, v, side) - blade_b.side(u, v, side), axis=-1)
            assert gap.max() < 0.01


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_d_min_and_r_max_kept(trip: dict[str, Any], fmt: str) -> None:
    a = compute_figures(trip["original"].surfaces)
    b = compute_figures(trip[fmt].surfaces)
    assert abs(a.d_min - b.d_min) < 0.01 and abs(a.r_max - b.r_max) < 0.01


def test_report_measures_section_points_on_the_solid(tmp_path: Path) -> None:
    spec = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
    assert main(["export", str(spec), "--format", "bladegen", "-o", str(tmp_path / "f")]) == 0
    assert main(["import", str(tmp_path / "f" / "small.inf"), "-o", str(tmp_path / "s")]) == 0
    report = json.loads((tmp_path / "s" / "import_report.json").read_text())
    surface = report["surface_distance"]
    assert surface["points"] > 100
    # the written points are the nominal sections: on the solid but at the cut trailing
    # edge's broken corners (radius 0.15 x half thickness, sqrt(2) - 1 of it off) and at
    # the hub span, whose side points sit off the hub surface by up to half the thickness
    # times the tilt of the camber normal to it
    assert surface["mean_mm"] < 0.01
    corner = 0.15 * 0.75 * (2 ** 0.5 - 1)
    for span in surface["per_span"]:
        assert span["max_mm"] < (0.75 if span["span"] == 0.0 else corner + 0.005)
