"""The rest operation's choice of points (``cam.run.rest``) and its planner offset."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cam.finishing.options import FinishOptions
from cam.run.rest import PAD, RestTrim, rest_samples
from impeller_cam.errors import InputError
from tests.cam.conftest import CHAIN_MACHINE, CHAIN_SETTINGS, SMALL_SPEC


def _path(centres: np.ndarray) -> SimpleNamespace:
    return SimpleNamespace(centre=np.asarray(centres, np.float64))


def test_rest_samples_keep_milled_samples_beyond_the_limit() -> None:
    points = np.arange(15.0).reshape(5, 3)
    signed = np.array([0.5, 2.0, 2.0, 1.5, 3.0])
    milled = np.array([True, True, False, True, True])
    out = rest_samples(points, signed, milled, 1.5)
    np.testing.assert_array_equal(out, points[[1, 4]])


def test_a_point_needs_the_rest_operation_within_reach_of_a_sample() -> None:
    trim = RestTrim(np.array([[10.0, 0.0, 0.0]]), reach=2.0, pitch=math.pi / 2, passages=4)
    centres = np.array([[8.5, 0.0, 0.0], [7.9, 0.0, 0.0], [10.0, 0.0, 1.99],
                        [10.0, 0.0, 2.01]])
    np.testing.assert_array_equal(trim.needed(centres), [True, False, True, False])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 5), st.floats(0.0, 2.0 * math.pi))
def test_a_sample_in_any_passage_marks_the_passage_0_point(k: int, angle: float) -> None:
    """A sample at the passage-0 point turned by k pitches is found (any k < passages)."""
    pitch = 2.0 * math.pi / 6
    centre = np.array([[20.0 * math.cos(angle), 20.0 * math.sin(angle), 5.0]])
    turn = k * pitch
    rot = np.array([[math.cos(turn), -math.sin(turn), 0.0],
                    [math.sin(turn), math.cos(turn), 0.0], [0.0, 0.0, 1.0]])
    sample = centre @ rot.T + [0.0, 0.0, 0.5]
    trim = RestTrim(sample, reach=1.0, pitch=pitch, passages=6)
    assert trim.needed(centre).all()
    assert not RestTrim(sample, reach=1.0, pitch=pitch, passages=k).needed(centre).any()


def test_the_kept_points_are_widened_by_pad_and_all_kept_is_none() -> None:
    x = np.arange(20.0)
    centres = np.column_stack([x, np.zeros(20), np.zeros(20)])
    trim = RestTrim(np.array([[10.0, 3.0, 0.0]]), reach=3.2, pitch=1.0, passages=1)
    mask = trim(_path(centres))  # type: ignore[arg-type]
    assert mask is not None
    need = trim.needed(centres)
    np.testing.assert_array_equal(np.flatnonzero(need), [9, 10, 11])
    np.testing.assert_array_equal(np.flatnonzero(mask), np.arange(9 - PAD, 12 + PAD))
    everywhere = RestTrim(centres, reach=0.1, pitch=1.0, passages=1)
    assert everywhere(_path(centres)) is None  # type: ignore[arg-type]
    nowhere = RestTrim(np.zeros((0, 3)), reach=1.0, pitch=1.0, passages=1)
    assert not nowhere(_path(centres)).any()  # type: ignore[arg-type, union-attr]


def test_the_allowance_and_the_threshold_are_checked() -> None:
    with pytest.raises(InputError, match="allowance_mm"):
        FinishOptions(allowance_mm=-0.1)
    with pytest.raises(InputError, match="rest_threshold_mm"):
        FinishOptions(rest_threshold_mm=0.0)
    assert FinishOptions().allowance_mm == 0.0 and FinishOptions().rest_machining


def _over(out: Path, relative: str, limit: float) -> int:
    """Milled-face samples of a verified stock farther than ``limit`` from the design."""
    from cam.run.regions import LabelledDesign, face_groups
    from cam.verify.stock import Stock

    design = LabelledDesign(SMALL_SPEC)
    points, _, _ = Stock.load(out / relative).surface_samples()
    signed, faces = design.distance.closest(points)
    groups, _ = face_groups(design, points, design.face_roles[faces], np.abs(signed), 0.0,
                            design.face_splitter[faces], skin_gap=0.0)
    milled = np.logical_or.reduce(list(groups.values()))
    return int((milled & (signed > limit)).sum())


@pytest.mark.slow
def test_rough_stock_beyond_the_threshold_gets_the_rest_operation(chain_small: Path,
                                                                  tmp_path: Path) -> None:
    """With a threshold below what roughing leaves, the finish stage plans the rest
    operation there, verifies it, finishes against what it left; the post stage writes
    its programs between roughing and finishing and the verify stage runs them."""
    from cam.run import run_chain

    default = json.loads((chain_small / "rest/rest.json").read_text())
    assert default["enabled"] and default["threshold_mm"] == 1.0
    out = tmp_path / "out"
    shutil.copytree(chain_small, out)
    settings = {**CHAIN_SETTINGS, "finish": {**CHAIN_SETTINGS["finish"],
                                             "rest_threshold_mm": 0.3}}
    try:
        run_chain(SMALL_SPEC, CHAIN_MACHINE, out, start="finish", progress=False, **settings)
    except RuntimeError as error:
        if "cam.report" not in str(error):
            raise
    rest = json.loads((out / "rest/rest.json").read_text())
    assert rest["planned"] and rest["samples_over"] > 0 and rest["operations"]
    document = json.loads((out / "rest/finish.json").read_text())
    assert document["options"]["allowance_mm"] == rest["finishing_allowance_mm"]
    assert document["summary"]["collisions"] == 0
    assert document["summary"]["motion_collisions"] == 0
    assert document["link_collisions"] == 0
    finish = json.loads((out / "finish/finish.json").read_text())
    assert finish["stock"]["source"].endswith("verify/rest/stock.npz")
    counts = json.loads((out / "verify/rest/verify.json").read_text())["event_counts"]
    for kind in ("holder_collision", "gouge", "overtravel", "rapid_in_stock"):
        assert counts[kind] == 0, (kind, counts)
    # the rest operation brings the samples beyond the threshold down where it cuts
    limit = rest["limit_mm"]
    after_rest = _over(out, "verify/rest/stock.npz", limit)
    assert rest["points"] > 0 and after_rest < rest["samples_over"]
    post = json.loads((out / "nc/post.json").read_text())
    ops = [p["operation"] for p in post["programs"]]
    first, last = ops.index("rest"), len(ops) - 1 - ops[::-1].index("rest")
    assert set(ops[:first]) == {"rough"} and set(ops[first:last + 1]) == {"rest"}
    assert set(ops[last + 1:]) == {"finish"}
    motion = json.loads((out / "motion/motion.json").read_text())
    assert any(p["operation"] == "rest" and p["cycle_time_s"] > 0
               for p in motion["programs"])
    counts = json.loads((out / "verify/finish/verify.json").read_text())["event_counts"]
    for kind in ("holder_collision", "gouge", "overtravel", "rapid_in_stock"):
        assert counts[kind] == 0, (kind, counts)
    # finishing reaches what the rest operation brought down, or names what it leaves
    finished = _over(out, "verify/finish/stock.npz", limit)
    assert finished <= after_rest
    assert finished == 0 or finish["cut_short"], finished
