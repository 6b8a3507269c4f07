"""The schema layer: one strict declaration per input file, one message per problem."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cam.motion.feeddrive import load_feed_drives
from cam.motion.plant import load_plant
from cam.tools import DEFAULT_LIBRARY, load_tool_library
from geometry.design import load_design
from geometry.spec import load_spec
from impeller_cam.errors import InputError
from postproc.machine import load_machine

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "fixtures"
LIBRARY = FIXTURES / "tools" / "library.toml"


def _edited(tmp_path: Path, source: Path, old: str, new: str, name: str | None = None) -> Path:
    """A copy of ``source`` (with its folder's CSVs) with ``old`` replaced by ``new`` once."""
    for csv in source.parent.glob("*.csv"):
        shutil.copyfile(csv, tmp_path / csv.name)
    text = source.read_text()
    assert old in text, old
    path = tmp_path / (name or source.name)
    path.write_text(text.replace(old, new, 1))
    return path


def test_holder_typo_is_refused_with_the_nearest_key(tmp_path: Path) -> None:
    text = LIBRARY.read_text()
    start = text.index('name = "ball6_taper"')
    at = text.index("[[tool.holder]]", start)
    path = tmp_path / "tools.toml"
    path.write_text(text[:at] + "[[tool.holdr]]" + text[at + len("[[tool.holder]]"):])
    with pytest.raises(InputError) as caught:
        load_tool_library(path)
    error = caught.value
    assert error.message == "unknown key 'holdr' in [[tool]] 'ball6_taper': did you mean 'holder'?"
    assert error.file == str(path) and error.field == "tool 'ball6_taper'.holdr"
    assert "holder" in (error.accepted or "") and "length_mm" in str(error)


def test_fillet_typo_is_refused_with_the_nearest_key(tmp_path: Path) -> None:
    path = _edited(tmp_path, FIXTURES / "impellers" / "small" / "spec.toml",
                   "fillet_radius_mm = 1.0", "fillet_radus_mm = 1.0")
    with pytest.raises(InputError) as caught:
        load_spec(path)
    error = caught.value
    assert error.message == ("unknown key 'fillet_radus_mm' in [blade]: "
                             "did you mean 'fillet_radius_mm'?")
    assert error.field == "blade.fillet_radus_mm" and error.value == 1.0
    assert str(path) in str(error)


@pytest.mark.parametrize(("source", "old", "new", "field", "words"), [
    ("impellers/small/spec.toml", "stock_mm = 1.0", "stock_mm = nan",
     "allowances.stock_mm", "finite"),
    ("impellers/small/spec.toml", "stock_mm = 1.0", "stock_mm = -1.0",
     "allowances.stock_mm", "must not be negative"),
    ("impellers/small/spec.toml", "blades = 6", 'blades = "6"', "impeller.blades",
     "must be an integer"),
    ("impellers/small/spec.toml", "[splitters]\ncount = 0\nstart_fraction = 0.35",
     "[splitters]", "splitters", "empty table"),
    ("impellers/small/spec.toml", "scallop_mm = 0.5", "scallop_m = 0.5",
     "machining.rough.scallop_m", "did you mean"),
    ("impellers/small/design.toml", "bore_radius_mm = 4.0", "bore_radius = 4.0",
     "hub.bore_radius", "did you mean 'bore_radius_mm'"),
    ("impellers/small/design.toml", "theta_deg = [0.0, -22.0, -40.0]",
     "theta_deg = [0.0, inf, -40.0]", "camber.shroud.theta_deg", "finite"),
    ("machines/trunnion-500.toml", "[axes.X]", "[axes.X]\nvelocty = 1.0",
     "axes.X.velocty", "did you mean 'velocity'"),
    ("machines/trunnion-500.toml", "[axes.C]", "[axes.c]", "axes.c", "did you mean 'C'"),
    ("tools/library.toml", "diameter_mm = 10.0", "diameter_mm = -10.0",
     "tool 'ball10'.diameter_mm", "must be positive"),
    ("tools/library.toml", "flute_length_mm = 22.0", 'flute_length_mm = "22"',
     "tool 'ball10'.flute_length_mm", "must be a number"),
    ("motion/indexing_table.toml", "stiffness = 730000.0", "stifness = 730000.0",
     "plant.stifness", "did you mean 'stiffness'"),
    ("motion/indexing_table.toml", "band = 840.0", "band = -840.0",
     "settling.band", "must be positive"),
    ("motion/suzuki_table1.toml", "Kvi = 0.198", "Kvii = 0.198", "axes.X.Kvii",
     "did you mean 'Kvi'"),
])
def test_every_kind_names_file_field_and_value(
    tmp_path: Path, source: str, old: str, new: str, field: str, words: str
) -> None:
    from cam.inputs import check_file

    path = _edited(tmp_path, FIXTURES / source, old, new)
    with pytest.raises(InputError) as caught:
        check_file(path)
    error = caught.value
    assert error.field == field, str(error)
    assert words in str(error) and str(path) in str(error)
    assert "\n" not in str(error)


def test_loaders_read_the_fixtures_and_bundled_data() -> None:
    assert list(load_tool_library(DEFAULT_LIBRARY)) == list(load_tool_library(LIBRARY))
    load_machine(FIXTURES / "machines" / "trunnion-500.toml")
    load_plant(FIXTURES / "motion" / "indexing_table.toml")
    assert set(load_feed_drives(FIXTURES / "motion" / "suzuki_table1.toml")) == {"X", "Y", "C"}
    assert load_design(FIXTURES / "impellers" / "nine_blade" / "design.toml").blades == 9


def test_holder_segment_is_a_cylinder_or_a_cone(tmp_path: Path) -> None:
    path = _edited(tmp_path, LIBRARY, "length_mm = 40.0\ndiameter_mm = 50.0",
                   "length_mm = 40.0\ndiameter_mm = 50.0\ntop_diameter_mm = 52.0")
    with pytest.raises(InputError, match="not both"):
        load_tool_library(path)


def test_corner_radius_only_for_bullnose(tmp_path: Path) -> None:
    path = _edited(tmp_path, LIBRARY, "diameter_mm = 10.0", "diameter_mm = 10.0\n"
                   "corner_radius_mm = 1.0")
    with pytest.raises(InputError, match="only for type"):
        load_tool_library(path)
