"""Hand-computed cases for M4's formulas and the drop-cutter (closed form)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cam.roughing.dropcutter import DropCutter, frame_to_z
from cam.roughing.layers import (
    depth_layer_points,
    layer_axes,
    layer_count,
    layer_fractions,
    layer_points,
    repeats_layer_above,
)
from cam.roughing.options import RoughOptions
from cam.roughing.passes import (
    interpolated_pass,
    linear_passes,
    offset_curve,
    pass_count,
    rotate_z,
    stepover,
    zigzag_order,
)
from cam.roughing.tool_size import check_tool_size
from cam.tools import resolve_tool
from impeller_cam.errors import InputError


def test_eq1_tool_size_refuses_large_ball_with_numbers() -> None:
    tool = resolve_tool("ball10")
    # r_max = (13 - 2 * 0.5) / (2 * 1.2) = 5.0: a 5 mm radius ball just fits
    assert check_tool_size(tool, 13.0, 0.5, 1.2) == pytest.approx(5.0, abs=1e-12)
    with pytest.raises(InputError) as err:
        check_tool_size(tool, 12.0, 0.5, 1.2)  # r_max = 11 / 2.4 = 4.583 mm
    assert "4.583" in str(err.value) and "12.000" in str(err.value)


def test_a_run_is_cut_from_the_end_with_the_shorter_entry() -> None:
    from cam.roughing.plan import oriented_run

    run = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [20.0, 0.0, 0.0]])

    def entry(_index: int, r: np.ndarray) -> float:  # the end at x = 20 enters shorter
        return 5.0 if r[0, 0] == 0.0 else 1.0

    def never(_r: np.ndarray) -> bool:
        return False

    assert oriented_run(run, 1, True, never, entry)[0, 0] == 20.0
    assert oriented_run(run, 1, True, never, entry)[-1, 0] == 0.0
    # a direct link onto the planned start keeps the plan (a layer's step-down)...
    assert oriented_run(run, 1, True, lambda r: bool(r[0, 0] == 0.0), entry)[0, 0] == 0.0
    # ... one onto the far end turns the run whatever the entries
    assert oriented_run(run, 1, True, lambda r: bool(r[0, 0] == 20.0),
                     lambda _i, _r: 0.0)[0, 0] == 20.0
    # equal entries keep the plan; the first run has no link to reach
    assert oriented_run(run, 1, True, never, lambda _i, _r: 1.0)[0, 0] == 0.0
    assert oriented_run(run, 0, False, lambda _r: True, entry)[0, 0] == 20.0
    single = run[:1]
    assert oriented_run(single, 0, False, never, entry) is single


def test_layer_visits_cut_every_regions_upper_layers_first() -> None:
    from cam.roughing.plan import layer_visits

    # regions with layers 0..2 and 0..1, one layer per visit: layer-major
    assert layer_visits([2, 1], 1) == [((0, 0), 0), ((0, 0), 1), ((1, 1), 0), ((1, 1), 1),
                                       ((2, 2), 0)]
    # two layers per visit; the last visit of a region stops at its hub layer
    assert layer_visits([2, 1], 2) == [((0, 1), 0), ((0, 1), 1), ((2, 2), 0)]
    # 0: every region's layers in one visit (UMR-major)
    assert layer_visits([2, 1], 0) == [((0, 2), 0), ((0, 1), 1)]
    # a region's consecutive visits merge: the last layers of the deeper region, and
    # a single region (one UMR) is cut in one visit as before
    assert layer_visits([3, 1], 1) == [((0, 0), 0), ((0, 0), 1), ((1, 1), 0), ((1, 1), 1),
                                       ((2, 3), 0)]
    assert layer_visits([4], 1) == [((0, 4), 0)]
    assert layer_visits([], 1) == []
    with pytest.raises(InputError):
        RoughOptions(layers_per_visit=-1)


def test_stepover_and_pass_count() -> None:
    # d = 10, h = 0.5: w = 2 sqrt(0.5 * 9.5) = 4.358899
    assert stepover(10.0, 0.5) == pytest.approx(4.358898944, abs=1e-9)
    assert pass_count(40.0, 4.358898944) == 10  # 40 / 4.36 = 9.18 -> 10
    with pytest.raises(InputError):
        stepover(10.0, 10.0)


def test_eq2_eq3_layers() -> None:
    assert layer_count(38.0, 5.0) == 8
    assert layer_fractions(4).tolist() == [1.0, 0.75, 0.5, 0.25, 0.0]
    hub = np.array([1.0, 2.0, 3.0])
    ruling = np.array([0.0, 0.0, 8.0])  # P_s - P_x
    pts = layer_points(hub, ruling, 4)
    assert np.allclose(pts[:, 2], [11.0, 9.0, 7.0, 5.0, 3.0])
    axes = layer_axes(hub + ruling, pts[1:])
    assert np.allclose(axes, [0.0, 0.0, 1.0])


def test_depth_layers_by_hand() -> None:
    """Rulings of 8 and 3 mm up +Z, n1 = 4: steps of 8 / 4 = 2 mm below the shroud
    on both; the short ruling reaches its hub after two steps (3 -> 1 -> 0) and
    repeats it below (eq. 2 would step it by 0.75 mm)."""
    hub = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 1.0]])
    ruling = np.array([[0.0, 0.0, 8.0], [0.0, 0.0, 3.0]])
    pts = depth_layer_points(hub, ruling, 4)
    assert pts.shape == (5, 2, 3)
    assert np.allclose(pts[:, 0, 2], [8.0, 6.0, 4.0, 2.0, 0.0])  # = eq. 2 on the longest
    assert np.allclose(pts[:, 0], layer_points(hub, ruling, 4)[:, 0])
    assert np.allclose(pts[:, 1, 2], [4.0, 2.0, 1.0, 1.0, 1.0])
    assert np.allclose(pts[:, :, :2], hub[None, :, :2])
    assert repeats_layer_above(pts).tolist() == [[False, False], [False, False],
                                                 [False, False], [False, True],
                                                 [False, True]]
    assert not repeats_layer_above(layer_points(hub, ruling, 4)).any()
    with pytest.raises(InputError, match="umr_layering"):
        RoughOptions(umr_layering="planar")


def test_eq5_to_eq9_passes() -> None:
    first = np.array([[0.0, 0.0, 0.0]])
    last = np.array([[4.0, 0.0, 0.0]])
    assert np.allclose(linear_passes(first, last, 4)[:, 0, 0], [0, 1, 2, 3, 4])
    assert np.allclose(offset_curve(np.zeros(3), np.array([1.0, 0, 0]), 2.0,
                                    np.array([0, 0, 1.0]), 0.5), [2.0, 0.0, 0.5])
    assert np.allclose(rotate_z(np.array([1.0, 0.0, 5.0]), math.pi / 2), [0.0, 1.0, 5.0])
    # OC_P at angle 0, OC_S at 40 deg, same radius 10: the mid path lies at 20 deg
    th = math.radians(40.0)
    oc_p = np.array([10.0, 0.0, 1.0])
    oc_s = np.array([10 * math.cos(th), 10 * math.sin(th), 3.0])
    mid = interpolated_pass(oc_p, oc_s, th, 0.5)
    assert np.allclose(mid, [10 * math.cos(th / 2), 10 * math.sin(th / 2), 2.0])
    assert np.allclose(interpolated_pass(oc_p, oc_s, th, 0.0), oc_p)
    assert np.allclose(interpolated_pass(oc_p, oc_s, th, 1.0), oc_s)
    assert zigzag_order(2, 3).tolist() == [0, 1, 2, 5, 4, 3]


def test_frame_to_z_maps_axis() -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        a = rng.normal(size=3)
        a /= np.linalg.norm(a)
        m, _, _ = frame_to_z(a)
        assert np.allclose(m @ a, [0, 0, 1], atol=1e-12)
        assert np.allclose(m @ m.T, np.eye(3), atol=1e-12)


def test_dropcutter_closed_form_cases() -> None:
    rho = 2.0
    plane = np.array([[[-50, -50, 1.0], [50, -50, 1.0], [0, 50, 1.0]]])
    # facet: ball centre rho above a horizontal plane
    assert DropCutter(plane, rho).drop(np.array([[0.0, 0.0]]))[0] == pytest.approx(3.0)
    # inclined plane z = 0.5 x: centre at z = 0.5 x + rho sqrt(1 + 0.25)
    slope = np.array([[[-50, -50, -25.0], [50, -50, 25.0], [0, 50, 0.0]]])
    z = DropCutter(slope, rho).drop(np.array([[1.0, 0.0]]))[0]
    assert z == pytest.approx(0.5 + rho * math.sqrt(1.25), abs=1e-12)
    # vertex: a tiny triangle around the origin seen from (1, 0): sqrt(4 - 1)
    tiny = np.array([[[0, 0, 0.0], [-1e-3, -5e-4, -1.0], [-1e-3, 5e-4, -1.0]]])
    assert DropCutter(tiny, rho).drop(np.array([[1.0, 0.0]]))[0] == pytest.approx(
        math.sqrt(3.0), abs=1e-9)
    # edge: a horizontal edge along x at z = 0 seen from y = 1: sqrt(4 - 1)
    edge = np.array([[[-10, 0, 0.0], [10, 0, 0.0], [0, -1e-3, -5.0]]])
    assert DropCutter(edge, rho).drop(np.array([[0.0, 1.0]]))[0] == pytest.approx(
        math.sqrt(3.0), abs=1e-9)
    # nothing within reach
    assert DropCutter(plane, rho).drop(np.array([[500.0, 0.0]]))[0] == -np.inf


def test_dropcutter_matches_brute_force_on_random_triangles() -> None:
    rng = np.random.default_rng(7)
    tri = rng.uniform(-10, 10, (60, 3, 3))
    pts = rng.uniform(-12, 12, (400, 2))
    fast = DropCutter(tri, 1.5).drop(pts)
    # brute force: every triangle alone (one grid cell), the highest centre of all
    slow = np.max([DropCutter(t[None], 1.5, cell=100.0).drop(pts) for t in tri], axis=0)
    assert np.array_equal(np.isfinite(fast), np.isfinite(slow))
    ok = np.isfinite(fast)
    assert np.max(np.abs(fast[ok] - slow[ok])) < 1e-12
    # and no triangle vertex comes closer than rho to the dropped centres
    centres = np.column_stack([pts[ok], fast[ok]])
    d = np.linalg.norm(centres[:, None, None, :] - tri[None], axis=-1).min(axis=(1, 2))
    assert d.min() >= 1.5 - 1e-9


def test_dropcutter_cells_hold_their_triangles_highest_first() -> None:
    rng = np.random.default_rng(11)
    tri = rng.uniform(-10, 10, (80, 3, 3))
    tri[40:, :, 2] = np.round(tri[40:, :, 2])  # many equal tops: ties in the order
    rho = 1.5
    cutter = DropCutter(tri, rho)
    lo = np.floor((tri[:, :, :2].min(axis=1) - rho - cutter.origin) / cutter.cell)
    hi = np.minimum(np.floor((tri[:, :, :2].max(axis=1) + rho - cutter.origin) / cutter.cell),
                    cutter.shape - 1)
    top = tri[:, :, 2].max(axis=1)
    for i in range(int(cutter.shape[0])):
        for j in range(int(cutter.shape[1])):
            c = i * int(cutter.shape[1]) + j
            items = cutter.cell_items[cutter.cell_start[c]:cutter.cell_start[c + 1]]
            want = np.flatnonzero((lo[:, 0] <= i) & (i <= hi[:, 0])
                                  & (lo[:, 1] <= j) & (j <= hi[:, 1]))
            assert sorted(items.tolist()) == want.tolist()
            assert np.all(np.diff(top[items]) <= 0.0)
    pts = rng.uniform(-12, 12, (300, 2))
    # brute force: every triangle alone (one grid cell), the highest centre of all
    slow = np.max([DropCutter(t[None], rho, cell=100.0).drop(pts) for t in tri], axis=0)
    assert np.array_equal(cutter.drop(pts), slow)


def test_refine_moves_lifts_a_cutting_move_over_a_ridge() -> None:
    from cam.roughing.linking import refine_moves
    from postproc.toolpath import MoveKind

    # roof ridge along y at z = 0, flanks down to z = -5 at x = +-5
    roof = np.array([[[-5, -20, -5.0], [0, -20, 0.0], [0, 20, 0.0]],
                     [[-5, -20, -5.0], [0, 20, 0.0], [-5, 20, -5.0]],
                     [[5, -20, -5.0], [0, 20, 0.0], [0, -20, 0.0]],
                     [[5, -20, -5.0], [5, 20, -5.0], [0, 20, 0.0]]])
    cutter = DropCutter(roof, 1.0)
    # a straight feed move at z = 0.5 across the ridge: the ball centre must rise to
    # rho = 1 over the edge (edge contact, closed form sqrt(rho^2 - x^2) near x = 0)
    path = np.array([[-3.0, 0.0, 0.5], [3.0, 0.0, 0.5]])
    kind = np.array([MoveKind.RAPID, MoveKind.FEED], np.int8)
    # the end points themselves are below the flanks' drop surface: lift them first
    path[:, 2] = np.maximum(path[:, 2], cutter.drop(path))
    out, k, added = refine_moves(path, kind, cutter, step=0.25)
    assert added >= 1 and len(out) == 2 + added
    assert np.all(k[1:] == MoveKind.FEED)
    top = out[np.argmin(np.abs(out[:, 0]))]
    assert abs(top[0]) < 0.25 and top[2] == pytest.approx(math.sqrt(1.0 - top[0] ** 2),
                                                           abs=1e-9)
    # resampled finely, the refined path dips at most a chord's sag below the surface
    fine = np.concatenate([np.linspace(a, b, 50)
                           for a, b in zip(out[:-1], out[1:], strict=True)])
    assert np.max(cutter.drop(fine) - fine[:, 2]) < 0.02


def test_layer_order_alternates_and_push_clear_keeps_rho() -> None:
    from cam.roughing.baseline import push_clear
    from cam.roughing.plan import layer_order

    order = layer_order(3, 2, 3)
    assert order[0].tolist() == [0, 1, 2, 5, 4, 3]
    assert order[1].tolist() == [3, 4, 5, 2, 1, 0]  # starts where layer 0 ended
    assert order[2].tolist() == order[0].tolist()
    # a plane z = 0 (two triangles): a centre 1 mm above moves to rho = 2.5 above it
    plane = np.array([[[-10, -10, 0.0], [10, -10, 0.0], [10, 10, 0.0]],
                      [[-10, -10, 0.0], [10, 10, 0.0], [-10, 10, 0.0]]])
    moved, count = push_clear(np.array([[1.0, 2.0, 1.0], [0.0, 0.0, 4.0]]), plane, 2.5)
    assert count == 1
    assert np.allclose(moved, [[1.0, 2.0, 2.5 + 1e-6], [0.0, 0.0, 4.0]])


def test_splitter_passage_has_three_lanes() -> None:
    from pathlib import Path

    from cam.roughing.passage import passage_lanes
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    root = Path(__file__).resolve().parents[2]
    surfaces = build_surfaces(load_spec(root / "fixtures/impellers/splitter/spec.toml"))
    lanes = passage_lanes(surfaces)
    start = surfaces.splitters[0].u_start
    assert [lane.name for lane in lanes] == ["inlet", "pressure-splitter", "splitter-suction"]
    assert (lanes[0].u0, lanes[0].u1) == (0.0, start)
    assert lanes[1].suction is surfaces.splitters[0] and lanes[2].pressure is surfaces.splitters[0]
    nine = build_surfaces(load_spec(root / "fixtures/impellers/nine_blade/spec.toml"))
    assert [lane.name for lane in passage_lanes(nine)] == ["passage"]



def test_depth_layers_of_the_nine_blade_passage() -> None:
    """On nine_blade (rulings 15.7-37.6 mm, ball10, a_p = 5 mm: n1 = 8) the depth
    layering steps every ruling by the longest one's 4.70 mm, never more than a_p,
    keeps eq. 2's shroud and hub layers, and needs 27 % fewer layer points."""
    from pathlib import Path

    from cam.roughing.passage import passage_grid
    from geometry.spec import load_spec
    from geometry.surfaces import build_surfaces

    root = Path(__file__).resolve().parents[2]
    nine = build_surfaces(load_spec(root / "fixtures/impellers/nine_blade/spec.toml"))
    grids = {lay: passage_grid(nine, 5.0, 0.5, scallop=1.0, max_depth=5.0, step_along=2.0,
                               layering=lay) for lay in ("ruling", "depth")}
    ruling, depth = grids["ruling"], grids["depth"]
    assert ruling.n1 == depth.n1 == 8
    assert depth.depth == pytest.approx(ruling.depth) and depth.depth <= 5.0
    assert np.allclose(depth.centres[0], ruling.centres[0])  # shroud
    assert np.array_equal(depth.centres[-1], ruling.centres[-1])  # hub, exactly
    # re-layering keeps the passes: the same grid as built in the other layering
    assert np.array_equal(ruling.with_layering("depth").centres, depth.centres)
    assert np.array_equal(depth.with_layering("ruling").centres, ruling.centres)
    assert depth.with_layering("depth") is depth
    steps = np.linalg.norm(np.diff(depth.centres, axis=0), axis=-1)
    assert steps.max() <= depth.depth + 1e-9
    length = np.linalg.norm(depth.ruling, axis=-1)
    # a ruling of length L is cut in ceil(L / d) steps (then repeats the hub point)
    cut = (~repeats_layer_above(depth.centres)).sum(axis=0) - 1
    assert np.array_equal(cut, np.ceil(length / depth.depth - 1e-9).astype(int))
    saved = 1.0 - (cut + 1).sum() / ruling.centres[..., 0].size
    assert 0.25 < saved < 0.30

# --- linking, stock models and the five-axis re-tilt (hand-computed cases) ---------

def _flat(z: float, size: float = 60.0) -> np.ndarray:
    """Two triangles of the plane at height z over [-size, size]^2."""
    return np.array([[[-size, -size, z], [size, -size, z], [size, size, z]],
                     [[-size, -size, z], [size, size, z], [-size, size, z]]])


def test_zmap_air_height_blank_and_swept_column() -> None:
    from cam.roughing.stockmap import ZMap

    zmap = ZMap(np.array([-20.0, -20.0]), np.array([20.0, 20.0]), _flat(10.0), 2.0)

    def air(x: float, y: float, conservative: bool = False) -> float:
        return float(zmap.air_height(np.array([[x, y]]), conservative)[0])

    # over the uncut blank (top z = 10) a ball is in air from centre height 10 + R
    assert air(0.0, 0.0) == pytest.approx(12.0, abs=1e-9)
    assert air(0.0, 0.0, True) == pytest.approx(12.0, abs=1e-9)
    # a ball swept along x at centre height 6: its own column is air down to 6 ...
    zmap.sweep(np.column_stack([np.linspace(-5, 5, 41), np.zeros(41), np.full(41, 6.0)]))
    assert air(0.0, 0.0) == pytest.approx(6.0, abs=1e-9)
    # ... and 1 mm to the side the uncut rim beyond y = 2 (ground 10, the blank top)
    # decides: its nearest nodes, at y = 2.5 (d = 1.5), give 10 + sqrt(4 - 1.5^2)
    assert air(0.0, 1.0) == pytest.approx(10.0 + math.sqrt(4.0 - 1.5 ** 2), abs=1e-9)
    # the planner's conservative view: the groove's wall may stand anywhere within
    # cell / sqrt(2) of the first uncut node, one cell nearer (3 x 3 dilation): the
    # wall at |y| = 2 now counts from |y| = 2.5 - 0.5 - 0.354 = 1.646 on
    e = 2.5 - 0.5 - 0.5 / math.sqrt(2.0)
    assert air(0.0, 0.0, True) == pytest.approx(10.0 + math.sqrt(4.0 - e * e), abs=1e-9)
    assert air(0.0, 1.0, True) >= air(0.0, 1.0)
    # off the map: unknown, so never air
    assert air(19.5, 0.0) == np.inf


def test_rapids_in_stock_replay() -> None:
    from cam.roughing.stockmap import ZMap, rapids_in_stock
    from postproc.toolpath import MoveKind

    def fresh() -> ZMap:
        return ZMap(np.array([-30.0, -30.0]), np.array([30.0, 30.0]), _flat(10.0), 2.0)

    # plunge from air (z 13) to 6 at x = -10, cut to x = 10, lift 1 mm, rapid up to 12.5
    # (above the blank top + R), across and down again over the cut groove to 7
    c = np.array([[-10, 0, 13.0], [-10, 0, 6.0], [10, 0, 6.0], [10, 0, 7.0],
                  [10, 0, 12.5], [-5, 0, 12.5], [-5, 0, 7.0]])
    k = np.array([MoveKind.RAPID, MoveKind.PLUNGE, MoveKind.FEED, MoveKind.RETRACT,
                  MoveKind.RAPID, MoveKind.RAPID, MoveKind.RAPID], np.int8)
    bad, rapids, depth = rapids_in_stock(fresh(), c, k)
    assert (bad, rapids) == (0, 3) and depth <= 0.0
    # the same rapid down at y = 3 (beside the groove) goes through uncut stock
    c2 = c.copy()
    c2[5:, 1] = 3.0
    bad, _, depth = rapids_in_stock(fresh(), c2, k)
    assert bad == 1 and depth == pytest.approx(12.0 - 7.0, abs=0.05)


def test_link_lifts_rapids_over_the_stock_and_plunges_from_above_it() -> None:
    from cam.roughing.linking import LinkSettings, link_runs
    from cam.roughing.stockmap import ZMap
    from postproc.toolpath import MoveKind

    design = DropCutter(_flat(-100.0), 2.5)  # far below: the stock alone decides
    stock = ZMap(np.array([-30.0, -30.0]), np.array([30.0, 30.0]), _flat(10.0), 2.0)
    run = np.column_stack([np.linspace(0, 20, 21), np.zeros(21), np.full(21, 8.0)])
    stock.sweep(run)
    settings = LinkSettings(clearance=2.0, entry_height=1.0, entry_angle_deg=90.0, lift=0.5)
    start = np.array([0.0, 6.0, 8.0])  # beside the groove: uncut, blank top 10
    c, k, ramped = link_runs(run[-1], start, None, design, stock, settings)
    assert not ramped
    assert k.tolist() == [MoveKind.RETRACT, MoveKind.RAPID, MoveKind.RAPID, MoveKind.RAPID,
                          MoveKind.PLUNGE]
    assert np.allclose(c[0], run[-1] + [0, 0, 0.5])  # feed lift of 0.5 mm
    # plunge top: the blank top + R (air) + entry height = 10 + 2 + 1
    assert np.allclose(c[3], [0.0, 6.0, 13.0]) and np.allclose(c[4], start)
    # link height: the highest of air along the line (12), lift and entry top (13),
    # plus the clearance
    assert c[1, 2] == pytest.approx(15.0) and c[2, 2] == pytest.approx(15.0)
    # entering inside a cleared pocket instead: two passes at y = -1.5 and 1.5 leave a
    # cusp at y = 0, 6 - sqrt(2^2 - 1.5^2) high: the plunge starts 1 mm above the
    # lowest ball centre that clears it, not above the blank
    pocket = ZMap(np.array([-30.0, -30.0]), np.array([30.0, 30.0]), _flat(10.0), 2.0)
    zigzag = np.array([[0, -1.5, 6.0], [20, -1.5, 6.0], [20, 1.5, 6.0], [0, 1.5, 6.0]])
    pocket.sweep(zigzag)
    start = np.array([5.0, 0.0, 6.0])
    cusp = 6.0 - math.sqrt(4.0 - 1.5 ** 2)
    c, k, _ = link_runs(zigzag[-1], start, None, design, pocket, settings)
    assert np.allclose(c[-2], [5.0, 0.0, cusp + 2.0 + 1.0])
    assert cusp + 3.0 + 2.0 <= c[1, 2] <= 12.0 + 2.0  # never above the blank's air


class _BoxBlank:
    """A stand-in blank: the box |x|, |y| <= 50, z <= 10."""

    def touches(self, centres: np.ndarray, radius: float) -> np.ndarray:
        c = np.asarray(centres).reshape(-1, 3)
        out = (np.abs(c[:, 0]) - radius < 50) & (np.abs(c[:, 1]) - radius < 50) & (
            c[:, 2] - radius < 10)
        return out.reshape(np.shape(centres)[:-1])


def test_swept_stock_air_in_the_tool_tube_only_after_the_cut() -> None:
    """Three runs along x at y = -1, 0, 1 (z = 0, axis +Z, R = 2) cut the slab
    |y| <= 3 up through the box's top z = 10; the ball tested is R + 0.25 (the
    clearance), each tested point with the margin m = 2.25 * SPHERE_COVER."""
    from cam.roughing.sweptstock import RAPID_CLEARANCE, SPHERE_COVER, SweptStock

    axes = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    runs = [np.array([[0.0, y, 0.0], [10.0, y, 0.0]]) for y in (-1.0, 0.0, 1.0)]
    swept = SweptStock(_BoxBlank(), 2.0, 30.0, runs, [axes] * 3)  # type: ignore[arg-type]
    assert RAPID_CLEARANCE == 0.25 and swept.margin == pytest.approx(2.25 * SPHERE_COVER)
    above = np.array([[5.0, 0.0, 4.0]])  # in the slab over the runs
    beside = np.array([[5.0, 2.0, 4.0]])  # its ball reaches y = 4.25: uncut stock
    assert swept.air(above, before=3)[0] and not swept.air(above, before=0)[0]
    assert not swept.air(beside, before=3)[0]
    assert swept.air(np.array([[5.0, 1.0, 12.5]]), before=0)[0]  # above the blank
    # coming down the axis over (5, 0): in air down to where the tested ball's bottom
    # (t - 2.25) is within R - m of the run's samples at z = 0, t >= 0.25 + m
    lowest = RAPID_CLEARANCE + swept.margin
    t = swept.approach(np.array([5.0, 0.0, 0.0]), axes[0], 14.0, 3)
    assert lowest <= t <= lowest + 0.25
    # over a point beside the runs: only above the blank by the clearance and the
    # margin (t - 2.25 - m >= 10), tested every 0.25 mm from 14 down
    t = swept.approach(np.array([20.0, 0.0, 0.0]), axes[0], 14.0, 3)
    assert 12.0 + lowest <= t <= 12.0 + lowest + 0.25


def test_swept_stock_a_ball_grazing_the_wall_of_its_groove_is_not_in_air() -> None:
    """The small fixture's defect: a rapid coming down the axis beside the wall of a cut
    at 0.03 mm less than R from it. One run along x at y = 0 cuts the groove |y| <= 2
    (R = 2); a ball at y = 0.03 meets its wall by 0.03 mm: in stock (the former test, a
    ball shrunk by 0.09 mm and 48 points on it, said air)."""
    from cam.roughing.sweptstock import SweptStock

    run = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    axes = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    swept = SweptStock(_BoxBlank(), 2.0, 30.0, [run], [axes])  # type: ignore[arg-type]
    assert not swept.air(np.array([[5.0, 0.03, 4.0]]), before=1)[0]
    # straight up the axis of the run's last pose (10, 0, 0): inside the space its tool
    # took, in air after the run (a retract, no clearance to keep), not before it
    assert swept.air(np.array([[10.0, 0.0, 6.0]]), before=1)[0]
    assert not swept.air(np.array([[10.0, 0.0, 6.0]]), before=0)[0]
    assert not swept.air(np.array([[10.0, 0.03, 6.0]]), before=1)[0]


def test_swept_stock_removed_is_an_earlier_sample_within_reach() -> None:
    """``_removed`` (a grid of cubes, each read in run order up to ``before``)
    answers exactly whether a sample of a run labelled below ``before`` lies within
    reach: brute force over every sample, on twelve runs packed 0.2 mm apart so that
    a point near the later runs has more than 64 samples within reach, all of them
    later than ``before`` (where a k-d tree's nearest samples decide nothing), and at
    reaches below and above the grid's cube (R / 2)."""
    from cam.roughing.sweptstock import SweptStock

    rng = np.random.default_rng(5)
    axes = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    runs = [np.array([[0.0, 0.2 * k, 0.0], [10.0, 0.2 * k, 0.0]]) for k in range(12)]
    swept = SweptStock(_BoxBlank(), 2.0, 6.0, runs, [axes] * 12)  # type: ignore[arg-type]
    points = rng.uniform([-1.0, -2.0, -2.0], [11.0, 4.5, 8.0], (3000, 3))
    gap = np.linalg.norm(points[:, None] - swept.points[None], axis=-1)
    crowded = 0
    for before in (0, 1, 4, 11, 12):
        for within in (0.7, 1.9):
            prefix = swept.labels < before
            want = (gap[:, prefix] < within).any(axis=1)
            assert np.array_equal(swept._removed(points, before, within), want)
            crowded += int(((gap[:, ~prefix] < within).sum(axis=1) > 64).sum())
    assert crowded > 100


def test_swept_stock_sphere_points_cover_the_sphere() -> None:
    """Every unit vector lies within SPHERE_COVER of a SPHERE point (2e5 random ones)."""
    from scipy.spatial import cKDTree

    from cam.roughing.sweptstock import SPHERE, SPHERE_COVER

    rng = np.random.default_rng(3)
    v = rng.normal(size=(200_000, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    gap, _ = cKDTree(SPHERE).query(v)
    assert gap.max() < SPHERE_COVER
    assert gap.max() > 0.9 * SPHERE_COVER  # the bound is not loose


def test_retilt_turns_the_flutes_off_a_wall() -> None:
    from cam.collision.triangle_bvh import TriangleBVH
    from cam.roughing.retilt import clearance_of, retilt

    tool = resolve_tool("ball10")
    # a wall x = 0 from z = -10 to 20 (the ball centre 6 mm from it)
    wall = np.array([[[0, -40, -10.0], [0, 40, -10.0], [0, 40, 20.0]],
                     [[0, -40, -10.0], [0, 40, 20.0], [0, -40, 20.0]]])
    centre = np.array([[6.0, 0.0, 0.0]])
    lean = math.radians(5.0)
    axis = np.array([[-math.sin(lean), 0.0, math.cos(lean)]])  # leaning into the wall
    bvh = TriangleBVH(wall)
    _, before = clearance_of(bvh, centre, axis, tool, 2.0)
    # the tool's cylinder (radius 5) at the wall's top (z = 20) leans 20 tan 5 deg
    # towards it (outline sampled every 1 mm)
    assert before[0] == pytest.approx(6.0 - 5.0 - 20.0 * math.tan(lean), abs=0.1)
    new, tilted, unresolved = retilt(centre, axis, tool, wall, 0.5, margin=0.15)
    assert tilted[0] and not unresolved[0]
    assert np.linalg.norm(new[0]) == pytest.approx(1.0)
    _, after = clearance_of(bvh, centre, new, tool, 2.0)
    assert after[0] >= 0.5 + 0.15 - 1e-6
    assert new[0, 0] > axis[0, 0]  # turned away from the wall
