"""A second ``run_finish`` with the first run's memo (``plan_memo``, ``run_memo``): the
chain's rest operation runs finishing again against less stock, planning anew only a
few passes. What it takes over from the first run must be what it would have made."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cam.finishing.command import run_finish
from cam.finishing.plan_memo import PlanMemo
from cam.finishing.run_memo import RunMemo, same_solid
from postproc.machine_model import Solid

ROOT = Path(__file__).resolve().parents[2]
SMALL = ROOT / "fixtures" / "impellers" / "small" / "spec.toml"
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
OPTIONS = dict(passages=1, scallop_mm=1.6, point_spacing_mm=3.0)


def _run(out: Path, memo: PlanMemo) -> dict[str, Any]:
    return run_finish(SMALL, MACHINE, "ball4_taper", out, scene="surfaces", progress=False,
                      memo=memo, **OPTIONS)  # type: ignore[arg-type]


def _same_but_counts(a: dict[str, Any], b: dict[str, Any]) -> None:
    """finish.json of two runs alike but for the machine queries' counts (a rerun asks
    fewer)."""
    a, b = json.loads(json.dumps(a)), json.loads(json.dumps(b))
    for doc in (a, b):
        if doc["machine_model"] is not None:
            for key in ("poses_checked", "distance_queries"):
                doc["machine_model"].pop(key)
    assert a == b


def _apt(folder: Path, document: dict[str, Any]) -> dict[str, bytes]:
    return {op: (folder / entry["apt"]).read_bytes()
            for op, entry in document["operations"].items()}


@pytest.mark.slow  # two finishing runs of the small part: about 25 s of a core
def test_a_rerun_takes_over_what_its_kept_plans_made(tmp_path: Path) -> None:
    """Kept plans: the same files from the first run's links, plots and scene; a pass
    planned anew (new objects, however alike): its operation linked again."""
    memo = PlanMemo()
    first = _run(tmp_path / "first", memo)
    again = memo.again(set())
    second = _run(tmp_path / "second", again)
    reused = dict(memo.run.reused)
    assert reused["design_scene"] == 1 and again.recalled > 0
    assert reused["operations"] == len(first["operations"]) >= 2
    assert reused["plots"] > 0
    assert _apt(tmp_path / "first", first) == _apt(tmp_path / "second", second)
    for name in ("scene.stl", *(f"plots/{p.name}" for p in (tmp_path / "first/plots").iterdir())):
        assert (tmp_path / "first" / name).read_bytes() == \
            (tmp_path / "second" / name).read_bytes(), name
    # the machine model is asked less the second time, all else is alike
    _same_but_counts(first, second)
    hub = next(e["name"] for e in first["paths"] if e["operation"] == "hub")
    third = _run(tmp_path / "third", memo.again({hub}))
    assert memo.run.reused["operations"] == len(first["operations"]) - 1
    # planned anew against the same scene: the same postures, links and programs
    assert _apt(tmp_path / "first", first) == _apt(tmp_path / "third", third)
    _same_but_counts(first, third)
    assert json.loads((tmp_path / "third" / "finish.json").read_text()) == third


def test_same_solid_compares_mesh_and_pieces() -> None:
    box = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
    faces = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]], np.int64)
    a = Solid("part", "C", "stl", box, faces, pieces=(box,))
    b = Solid("part", "C", "stl", box.copy(), faces.copy(), pieces=(box.copy(),))
    c = Solid("part", "C", "stl", box * 2.0, faces, pieces=(box * 2.0,))
    assert same_solid(a, b) and not same_solid(a, c)
    assert same_solid(None, None) and not same_solid(a, None)
    assert RunMemo().plot("p0.hub.00", []) is None
