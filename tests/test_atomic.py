"""Atomic output: ``staged_directory`` publishes all or nothing, also over a rerun."""

from __future__ import annotations

from pathlib import Path

import pytest

from impeller_cam.atomic import replace_path, staged_directory


def test_rerun_replaces_non_empty_sub_folders_and_files(tmp_path: Path) -> None:
    out = tmp_path / "finish"
    with staged_directory(out) as stage:
        (stage / "plots").mkdir()
        (stage / "plots" / "a.png").write_text("old a")
        (stage / "plots" / "b.png").write_text("old b")
        (stage / "finish.json").write_text("old")
    with staged_directory(out) as stage:  # a rerun of the stage
        (stage / "plots").mkdir()
        (stage / "plots" / "a.png").write_text("new a")
        (stage / "finish.json").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == ["finish.json", "plots"]
    assert [p.name for p in (out / "plots").iterdir()] == ["a.png"]  # b.png was the old run's
    assert (out / "plots" / "a.png").read_text() == "new a"
    assert (out / "finish.json").read_text() == "new"


def test_failure_leaves_the_previous_outputs(tmp_path: Path) -> None:
    out = tmp_path / "rough"
    with staged_directory(out) as stage:
        (stage / "rough.json").write_text("first")
    with pytest.raises(RuntimeError), staged_directory(out) as stage:
        (stage / "rough.json").write_text("partial")
        raise RuntimeError("stage failed")
    assert [p.name for p in out.iterdir()] == ["rough.json"]
    assert (out / "rough.json").read_text() == "first"


def test_replace_path_swaps_a_folder_and_creates_a_missing_one(tmp_path: Path) -> None:
    new, target = tmp_path / "new", tmp_path / "target"
    new.mkdir()
    (new / "x").write_text("1")
    replace_path(new, target)  # target did not exist
    assert (target / "x").read_text() == "1" and not new.exists()
    new.mkdir()
    (new / "y").write_text("2")
    replace_path(new, target)
    assert [p.name for p in target.iterdir()] == ["y"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["target"]  # nothing left aside
