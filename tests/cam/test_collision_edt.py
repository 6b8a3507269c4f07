"""The numba distance transform of the distance grids against scipy's."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from cam.collision.edt import distance_transform


@pytest.mark.parametrize(("shape", "share"), [
    ((7, 9, 5), 0.05), ((30, 20, 25), 0.002), ((1, 1, 1), 1.0), ((40, 1, 3), 0.1),
    ((1, 33, 2), 0.03), ((48, 40, 36), 0.0005)])
def test_unit_spacing_is_scipys_value_bit_for_bit(shape: tuple[int, int, int],
                                                   share: float) -> None:
    rng = np.random.default_rng(sum(shape))
    marked = rng.random(shape) >= share
    marked.flat[rng.integers(marked.size)] = False  # at least one feature node
    np.testing.assert_array_equal(distance_transform(marked, 1.0),
                                  distance_transform_edt(marked, sampling=1.0))


def test_other_spacing_within_rounding() -> None:
    rng = np.random.default_rng(3)
    marked = rng.random((25, 31, 17)) >= 0.004
    marked[3, 4, 5] = False
    ours = distance_transform(marked, 0.7)
    np.testing.assert_allclose(ours, distance_transform_edt(marked, sampling=0.7),
                               rtol=1e-15, atol=1e-14)


def test_single_feature_is_the_exact_distance() -> None:
    marked = np.ones((11, 6, 9), dtype=bool)
    marked[10, 0, 4] = False
    i, j, k = np.indices(marked.shape)
    expected = np.sqrt((i - 10) ** 2 + j ** 2 + (k - 4) ** 2) * 0.5
    np.testing.assert_allclose(distance_transform(marked, 0.5), expected, rtol=1e-15)


def test_needs_a_feature_node() -> None:
    with pytest.raises(ValueError, match="unmarked"):
        distance_transform(np.ones((2, 2, 2), dtype=bool), 1.0)
    with pytest.raises(ValueError, match="3-D"):
        distance_transform(np.zeros((2, 2), dtype=bool), 1.0)
