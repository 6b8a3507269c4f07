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


def _edge_np(ax, ay, bx, by, px, py):  # type: ignore[no-untyped-def]
    if ax < bx or (ax == bx and ay < by):
        return (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    return -((ax - bx) * (py - by) - (ay - by) * (px - bx))


def _cast_reference(vertices, faces, k, origin, shape, h):  # type: ignore[no-untyped-def]
    """Every ray of each triangle's bounding box through the edge functions (the cast
    before the row spans), as sorted (ray, hit) pairs."""
    a, b = (k + 1) % 3, (k + 2) % 3
    out = []
    for f in faces:
        (x0, y0), (x1, y1), (x2, y2) = vertices[f][:, [a, b]]
        z = vertices[f][:, k]
        area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
        if area == 0.0:
            continue
        if area < 0.0:
            x1, y1, x2, y2 = x2, y2, x1, y1
            z = z[[0, 2, 1]]
        i0 = max(0, int(np.ceil((min(x0, x1, x2) - origin[0]) / h - 0.5)))
        i1 = min(shape[0] - 1, int(np.floor((max(x0, x1, x2) - origin[0]) / h - 0.5)))
        j0 = max(0, int(np.ceil((min(y0, y1, y2) - origin[1]) / h - 0.5)))
        j1 = min(shape[1] - 1, int(np.floor((max(y0, y1, y2) - origin[1]) / h - 0.5)))
        if i0 > i1 or j0 > j1:
            continue
        ii, jj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="ij")
        px = origin[0] + (ii + 0.5) * h
        py = origin[1] + (jj + 0.5) * h
        ok = np.ones(px.shape, bool)
        ws = []
        for (ax, ay, bx, by) in ((x1, y1, x2, y2), (x2, y2, x0, y0), (x0, y0, x1, y1)):
            w = _edge_np(ax, ay, bx, by, px, py)
            top_left = (by - ay) > 0.0 or ((by - ay) == 0.0 and (bx - ax) < 0.0)
            ok &= (w > 0.0) | ((w == 0.0) & top_left)
            ws.append(w)
        s = ws[0] + ws[1] + ws[2]
        t = (ws[0] * z[0] + ws[1] * z[1] + ws[2] * z[2]) / s
        out += list(zip((ii * shape[1] + jj)[ok].tolist(), t[ok].tolist(), strict=True))
    return sorted(out)


@pytest.mark.parametrize("kind", ["sphere", "revolved", "box"])
def test_cast_mesh_row_spans_keep_every_hit(kind: str) -> None:
    """The row spans skip only rays the edge functions reject: the same hits as every
    ray of each triangle's bounding box (slivers, vertices and edges on ray lines)."""
    import trimesh

    from cam.verify.raycast import cast_mesh

    rng = np.random.default_rng(3)
    if kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.3)
        mesh.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
        h = 0.05
    elif kind == "revolved":
        profile = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.4], [1.2, 1.0], [0.0, 1.0]])
        mesh = trimesh.creation.revolve(profile, sections=360)
        h = 0.05
    else:
        mesh = trimesh.creation.box(extents=[1.0, 0.6, 0.4])  # corners on ray lines
        h = 0.1
    vertices = np.asarray(mesh.vertices, float)
    faces = np.asarray(mesh.faces, np.int64)
    for k in range(3):
        a, b = (k + 1) % 3, (k + 2) % 3
        origin = np.array([vertices[:, a].min() - 0.15, vertices[:, b].min() - 0.15])
        extent = np.ptp(vertices, axis=0)
        shape = (int((extent[a] + 0.3) / h) + 1, int((extent[b] + 0.3) / h) + 1)
        rays, lo, hi = cast_mesh(vertices, faces, k, origin, shape, h)
        hits = _cast_reference(vertices, faces, k, origin, shape, h)
        pairs: dict[int, list[float]] = {}
        for r, t in hits:
            pairs.setdefault(r, []).append(t)
        want = [(r, ts[m], ts[m + 1]) for r, ts in sorted(pairs.items())
                for m in range(0, len(ts) - 1, 2) if ts[m + 1] > ts[m]]
        assert len(want) > 20
        assert list(zip(rays.tolist(), lo.tolist(), hi.tolist(), strict=True)) == want
