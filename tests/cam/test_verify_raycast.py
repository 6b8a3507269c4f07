"""The pairing of a ray cast's hits into intervals (``raycast._pair_hits``) against a
stable sort of all hits by (ray, position), the numpy form it replaced."""

from __future__ import annotations

import numpy as np
import pytest

from cam.verify.raycast import _pair_hits


def _reference(hits: np.ndarray, counts: np.ndarray):  # type: ignore[no-untyped-def]
    offsets = np.r_[0, np.cumsum(counts)]
    ray_of_hit = np.repeat(np.arange(len(counts), dtype=np.int64), counts)
    order = np.lexsort((hits, ray_of_hit))
    hits = hits[order]
    rank = np.arange(len(hits)) - offsets[ray_of_hit]
    idx = np.flatnonzero((rank % 2 == 0) & (rank + 1 < counts[ray_of_hit]))
    lo, hi = hits[idx], hits[idx + 1]
    keep = hi > lo
    return ray_of_hit[idx][keep], lo[keep], hi[keep]


@pytest.mark.parametrize("seed", range(6))
def test_pair_hits_matches_the_sorted_pairing(seed: int) -> None:
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, 9, 400)  # odd counts too (an open mesh)
    hits = np.round(rng.uniform(-5.0, 5.0, int(counts.sum())), 1)  # ties: empty pairs
    hits[rng.random(hits.shape[0]) < 0.05] = -0.0
    offsets = np.r_[0, np.cumsum(counts)].astype(np.int64)
    want = _reference(hits.copy(), counts)
    got = _pair_hits(hits.copy(), offsets)
    for a, b in zip(got, want, strict=True):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
        assert a.tobytes() == b.tobytes()  # bit for bit (signed zeros)
    assert np.all(got[2] > got[1])
