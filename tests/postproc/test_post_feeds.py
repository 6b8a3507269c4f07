"""Feed words: G94 mm/min, G93 inverse time from the tip path, joint-velocity floor."""

from __future__ import annotations

from math import radians

import numpy as np
import pytest

from impeller_cam.errors import InputError
from postproc.feeds import block_feeds
from postproc.program import FeedMode, Motion

VELOCITY = np.array([20.0, 20.0, 20.0, radians(30.0), radians(30.0)])  # mm/s, rad/s


def test_feed_modes_and_words() -> None:
    motion = np.array([Motion.RAPID, Motion.LINEAR, Motion.LINEAR, Motion.RAPID,
                       Motion.LINEAR], dtype=np.int8)
    feed = np.array([np.nan, 600.0, 1000.0, np.nan, 800.0])
    length = np.array([50.0, 10.0, 2.0, 30.0, 0.0])
    step = np.zeros((5, 5))
    step[1, 0] = 10.0
    step[2, [0, 4]] = [2.0, radians(1.0)]  # simultaneous: tip path 2 mm at 1000 mm/min
    step[4, 4] = radians(90.0)  # C turns 90 deg under a resting tip
    mode, f = block_feeds(motion, feed, length, step, VELOCITY)
    assert mode.tolist() == [94, 94, 93, 93, 93]  # the rapid keeps the mode in force
    assert np.isnan(f[0]) and np.isnan(f[3])
    assert f[1] == 600.0  # G94: mm/min as programmed
    # G93: F = feed / length = 1000 / 2 = 500 1/min (0.12 s); the C axis needs only
    # 1 deg / 30 deg/s = 0.033 s, so the tip path decides.
    assert f[2] == pytest.approx(500.0)
    # 90 deg at 30 deg/s = 3 s = 0.05 min -> F = 20 1/min
    assert f[4] == pytest.approx(20.0)
    assert mode[4] == FeedMode.INVERSE_TIME


def test_feed_move_without_feed_names_the_record() -> None:
    with pytest.raises(InputError, match="record 42"):
        block_feeds(np.array([Motion.LINEAR], np.int8), np.array([np.nan]), np.array([1.0]),
                    np.zeros((1, 5)), VELOCITY, np.array([42]))
