"""The roughing blank is the verification's lathe-turned blank (hand-computed cases)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam.roughing.stock import Blank

ROOT = Path(__file__).resolve().parents[2]


def _rectangle_blank() -> Blank:
    """A ring blank: r in [4, 10], z in [0, 5] (a bore of radius 4)."""
    blank = Blank.of_profile(np.array([[4.0, 0.0], [10.0, 0.0], [10.0, 5.0], [4.0, 5.0]]))
    assert (blank.z_top, blank.r_out) == (5.0, 10.0)
    return blank


def test_distance_and_touches_in_the_meridian_plane() -> None:
    blank = _rectangle_blank()
    c45 = math.cos(math.radians(45.0))
    pts = np.array([
        [7.0, 0.0, 2.0],                 # inside
        [0.0, -12.0, 2.0],               # 2 outside the rim, another meridian
        [13.0 * c45, 13.0 * c45, 9.0],   # off the corner (10, 5): hypot(3, 4) = 5
        [1.0, 1.0, 2.5],                 # in the bore: 4 - sqrt(2) from its wall
        [6.0, 0.0, -0.5],                # 0.5 below the back face
    ])
    d = blank.distance(pts)
    assert d == pytest.approx([0.0, 2.0, 5.0, 4.0 - math.sqrt(2.0), 0.5], abs=1e-12)
    assert blank.touches(pts, 2.01).tolist() == [True, True, False, False, True]
    assert blank.touches(pts, 0.0).tolist() == [True, False, False, False, False]
    # shapes follow the centres
    assert blank.touches(pts.reshape(5, 1, 3), 1.0).shape == (5, 1)


def test_same_solid_as_the_verification_stock() -> None:
    """The spec's blank for roughing and for ``verify --stock SPEC`` is one profile,
    and the revolved mesh's first hit from above is its top."""
    from cam.roughing.dropcutter import DropCutter
    from geometry.blank import spec_blank_profile
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    spec = load_spec(ROOT / "fixtures/impellers/small/spec.toml")
    blank = Blank(build_surfaces(spec))
    profile = spec_blank_profile(spec)
    assert np.array_equal(blank.profile, profile)  # closed: it ends where it starts
    assert np.array_equal(profile[-1], profile[0])
    # straight down at radius r on the mesh's first meridian: the top of the blank
    # there, the highest z of the profile's edges over r
    tri = np.asarray(blank.closed_mesh().triangles)
    probe = 1e-3
    r = np.linspace(blank.profile[:, 0].min() + 0.5, blank.r_out - 0.5, 12)
    top = DropCutter(tri, probe, cell=1.0).drop(np.column_stack([r, np.zeros_like(r)])) - probe
    a, b = blank.profile[:-1], blank.profile[1:]

    def profile_top(radius: float) -> float:
        over = (np.minimum(a[:, 0], b[:, 0]) <= radius) & (
            radius <= np.maximum(a[:, 0], b[:, 0])) & (a[:, 0] != b[:, 0])
        t = (radius - a[over, 0]) / (b[over, 0] - a[over, 0])
        return float((a[over, 1] + t * (b[over, 1] - a[over, 1])).max())

    # the probe (a ball) rests on the top at r or, on a steep stretch, on the
    # profile within its radius of r
    low = np.array([profile_top(ri) for ri in r])
    high = np.array([max(profile_top(ri + d) for d in (-probe, 0.0, probe)) for ri in r])
    assert np.all(top >= low - 2e-3) and np.all(top <= high + 2e-3), (top, low, high)


def test_touches_is_the_distance_compared_with_the_radius_on_a_real_blank() -> None:
    """``touches`` (early exits: bounding box, the cell screen, first edge within the
    radius) answers exactly ``distance < radius`` (``<= 0`` for radius 0), and
    ``distance`` is the brute-force closest-edge distance outside and 0 inside (seeded
    points around the nine_blade blank, on its vertices and within a cell or two of
    its boundary too, where the screen must not decide)."""
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    blank = Blank(build_surfaces(load_spec(ROOT / "fixtures/impellers/nine_blade/spec.toml")))
    rng = np.random.default_rng(28)
    lo = np.array([-blank.r_out - 8.0, -blank.r_out - 8.0, blank.profile[:, 1].min() - 8.0])
    hi = np.array([blank.r_out + 8.0, blank.r_out + 8.0, blank.z_top + 8.0])
    ang = rng.uniform(0.0, 2.0 * math.pi, len(blank.profile))
    on = np.column_stack([blank.profile[:, 0] * np.cos(ang), blank.profile[:, 0] * np.sin(ang),
                          blank.profile[:, 1]])
    # along the edges, up to two screen cells off them either way
    k = rng.integers(0, len(blank.profile) - 1, 4000)
    along = blank.profile[k] + rng.uniform(0, 1, (4000, 1)) * (blank.profile[k + 1]
                                                                - blank.profile[k])
    along += rng.uniform(-2.0, 2.0, (4000, 2)) * blank._cell
    ang = rng.uniform(0.0, 2.0 * math.pi, 4000)
    near = np.column_stack([along[:, 0] * np.cos(ang), along[:, 0] * np.sin(ang), along[:, 1]])
    pts = np.vstack([rng.uniform(lo, hi, (4000, 3)), on, near])
    d = blank.distance(pts)
    rz = np.column_stack([np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2]])
    a, b = blank.profile[:-1], blank.profile[1:]
    t = np.clip(np.einsum("nkj,kj->nk", rz[:, None] - a[None], b - a)
                / np.einsum("kj,kj->k", b - a, b - a), 0.0, 1.0)
    gap = np.linalg.norm(rz[:, None] - a[None] - t[..., None] * (b - a)[None], axis=-1).min(axis=1)
    outside = d > 0.0
    assert outside.any() and (~outside).any()
    assert np.allclose(d[outside], gap[outside], rtol=0.0, atol=1e-9)
    for radius in (0.0, 0.05, 0.5, 3.0, 5.0):
        want = d < radius if radius > 0.0 else d <= 0.0
        assert np.array_equal(blank.touches(pts, radius), want)
    # the screen decides most cells: those a cell's half diagonal clear of the boundary
    assert (blank._cell_clear > 0.5).mean() > 0.5
