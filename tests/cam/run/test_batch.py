"""Batch on a local Dask cluster: two design variants, one of them failing.

To stay quick the batch reruns the post stage (``--stage post``) of two variants
whose earlier stages are copies of the session chain; variant ``b`` has no finishing
output, so its post stage fails with bad input while ``a`` is done.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from cam.cli import main
from tests.cam.conftest import CHAIN_MACHINE, SMALL_SPEC


def variant(folder: Path, name: str) -> Path:
    """A copy of the small spec under another impeller name."""
    folder.mkdir(parents=True)
    for csv in ("hub_camber.csv", "shroud_camber.csv"):
        shutil.copy(SMALL_SPEC.parent / csv, folder / csv)
    text = SMALL_SPEC.read_text().replace('name = "small"', f'name = "{name}"')
    (folder / "spec.toml").write_text(text)
    return folder / "spec.toml"


def test_batch_of_two_variants_reports_the_failed_one(chain_small: Path, tmp_path: Path
                                                      ) -> None:
    specs = [variant(tmp_path / "specs" / n, f"small_{n}") for n in ("a", "b")]
    out = tmp_path / "batch"
    for n in ("a", "b"):
        shutil.copytree(chain_small, out / f"small_{n}")
        shutil.rmtree(out / f"small_{n}" / "nc")
    shutil.rmtree(out / "small_b" / "finish")
    code = main(["run", *map(str, specs), "-m", str(CHAIN_MACHINE), "-o", str(out),
                 "-t", "ball4_taper", "--stage", "post", "--workers", "2"])
    assert code == 2  # the only failure is bad input
    batch = json.loads((out / "batch.json").read_text())
    assert batch["done"] == 1 and batch["failed"] == 1
    assert batch["scheduler"] == "local (2 processes)"
    a, b = batch["specs"]
    assert (a["name"], a["status"]) == ("small_a", "done")
    assert (b["name"], b["status"], b["stage"], b["kind"]) == ("small_b", "failed", "post",
                                                               "input")
    assert "finish" in b["error"]
    assert json.loads((out / "small_a" / "nc" / "post.json").read_text())["programs"]
    assert not (out / "small_b" / "nc").exists()
    record = json.loads((out / "small_b" / "run.json").read_text())
    assert {s["name"]: s["status"] for s in record["stages"]}["post"] == "failed"


def test_duplicate_names_are_refused(tmp_path: Path) -> None:
    code = main(["run", str(SMALL_SPEC), str(SMALL_SPEC), "-m", str(CHAIN_MACHINE), "-o",
                 str(tmp_path / "out"), "-t", "ball4_taper"])
    assert code == 2
