"""Fillet finishing (issue 28): pencil passes across the blade-to-hub fillets.

* Geometry: the cusp of the angular step is the scallop; every arc pass's ball lies
  inside the rolling ball of the fillet (it cannot gouge), a ball of the fillet's
  radius runs on the spine; the passes beyond the fillet touch the hub.
* Tool choice: the library's largest ball no larger than the fillet; a larger one,
  a non-ball or a design without fillet is refused (exit 2, nothing written).
* Whole runs (small fixture, a generated design with round trailing edges): the
  fillet operation has its own tool and APT file, its postures are collision-free
  (and in an independent fcl check), reversal-free, post for LinuxCNC and Fanuc, and
  the swept balls leave at most the scallop height on the fillet samples.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cam.cli import main
from cam.finishing.command import run_finish
from cam.finishing.fillet_cover import edge_samples, fillet_samples, material_left
from cam.finishing.fillet_paths import arc_step, fillet_passes, fillet_section
from cam.finishing.fillet_plan import check_fillet_tool, choose_fillet_tool
from cam.finishing.paths import passage_walls
from cam.finishing.posture import rotate_about_z
from cam.tools import resolve_tool
from geometry.design import load_design
from geometry.design_files import write_design
from geometry.spec import load_spec
from geometry.surfaces import build_surfaces
from impeller_cam.errors import InputError
from postproc.apt import read_apt
from postproc.command import post_text
from tests.cam.test_finishing_run import independent_check, passes_of

ROOT = Path(__file__).resolve().parents[2]
IMPELLERS = ROOT / "fixtures" / "impellers"
MACHINE = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
#: Small tapered balls for the small fixture's 1 mm fillet (the bundled library has
#: none that small).
SMALL_BALLS = """
[[tool]]
name = "ball2_taper"
number = 4
type = "ball"
diameter_mm = 2.0
flute_length_mm = 6.0
shank_diameter_mm = 6.0
taper_deg = 3.0
stickout_mm = 45.0
spindle_rpm = 24000
feed_mm_min = 600
[[tool.holder]]
length_mm = 35.0
bottom_diameter_mm = 14.0
top_diameter_mm = 19.0

[[tool]]
name = "ball1.6_taper"
number = 5
type = "ball"
diameter_mm = 1.6
flute_length_mm = 5.0
shank_diameter_mm = 6.0
taper_deg = 3.0
stickout_mm = 45.0
spindle_rpm = 24000
feed_mm_min = 500
[[tool.holder]]
length_mm = 35.0
bottom_diameter_mm = 14.0
top_diameter_mm = 19.0
"""


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("tools") / "small_balls.toml"
    path.write_text(SMALL_BALLS)
    return path


@pytest.fixture(scope="module")
def round_te(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small design with round trailing edges (the generator's output)."""
    params = replace(load_design(IMPELLERS / "small" / "design.toml"), name="small_round_te",
                     trailing_edge="round")
    return write_design(params, tmp_path_factory.mktemp("round_te") / "small_round_te")


@pytest.mark.parametrize(("fillet", "ball", "scallop"),
                         [(2.5, 2.0, 0.5), (2.5, 2.0, 0.02), (1.0, 0.8, 0.1), (3.0, 1.0, 0.05)])
def test_the_angular_step_leaves_the_scallop_height(fillet: float, ball: float,
                                                   scallop: float) -> None:
    step = arc_step(fillet, ball, scallop)
    rho, a = fillet - ball, 0.5 * step
    cusp = fillet - rho * math.cos(a) - math.sqrt(ball**2 - (rho * math.sin(a)) ** 2)
    assert 0 < step < math.pi
    assert cusp == pytest.approx(scallop, abs=1e-9)


#: Rolling-ball centres sampled along a wall's fillet spine for ``spine_distance``
#: (segments under 0.25 mm on the small designs: the distances within 3e-4 mm of those
#: to a polyline of 20,000 samples; the nearest of 6,000 samples, used before, was up
#: to 0.013 mm too far, half its spacing, against the test's 0.03 mm).
SPINE_SAMPLES = 750


def spine_distance(points: np.ndarray, spine: np.ndarray) -> np.ndarray:
    """Distance of ``points`` (n, 3) to the polyline through the spine samples (k, 3),
    mm (n,): to the two segments at each point's nearest sample."""
    from scipy.spatial import cKDTree

    _, nearest = cKDTree(spine).query(points)
    best = np.full(len(points), np.inf)
    for first in (np.clip(nearest - 1, 0, len(spine) - 2), np.minimum(nearest, len(spine) - 2)):
        a, e = spine[first], spine[first + 1] - spine[first]
        t = np.clip(np.einsum("ij,ij->i", points - a, e) / np.einsum("ij,ij->i", e, e), 0, 1)
        best = np.minimum(best, np.linalg.norm(points - a - t[:, None] * e, axis=1))
    return best


@pytest.mark.parametrize("name", ["small", "round_te"])
@pytest.mark.parametrize("ball", [0.6, 1.0])
def test_pencil_balls_stay_inside_the_rolling_ball(name: str, ball: float,
                                                   round_te: Path) -> None:
    """Arc passes: the ball lies inside the fillet's rolling ball (|q - c| <= r_f - r,
    ``spine_distance``); ``r = r_f``: one pass on the spine. Passes beyond the fillet
    touch the hub at r; no ball goes below the hub."""
    from cam.finishing.fillet_paths import wall_interval

    spec = IMPELLERS / "small" / "spec.toml" if name == "small" else round_te
    surfaces = build_surfaces(load_spec(spec))
    fillet = surfaces.spec.fillet_radius
    paths = fillet_passes(surfaces, ball, 2.0, 0.1, 0.5)
    walls = [w for pair in passage_walls(surfaces) for w in pair]
    assert {p.wall.label for p in paths if p.wall} == {w.label for w in walls}
    for wall in walls:
        mine = [p for p in paths if p.wall is not None and p.wall.label == wall.label]
        spine = fillet_section(surfaces, wall, np.linspace(*wall_interval(wall.side, 8),
                                                           SPINE_SAMPLES)).centre
        gap = [float(spine_distance(p.centre, spine).max()) for p in mine]
        arc = [p for p, g in zip(mine, gap, strict=True) if g <= fillet - ball + 0.03]
        assert arc, wall.label
        if ball == fillet:  # the paper's case: one pass (in its three parts) on the spine
            assert len({p.name.rsplit(".", 1)[0] for p in arc}) == 1
            assert max(gap[mine.index(p)] for p in arc) < 0.03
        hub = [p for p in mine if np.allclose(surfaces.hub.signed_distance(p.centre), ball,
                                              atol=1e-6)]
        assert hub, "passes beyond the fillet on the hub"
        for p in mine:
            assert np.linalg.norm(np.diff(p.centre, axis=0), axis=1).max() <= 0.5 + 1e-9
            assert surfaces.hub.signed_distance(p.centre).min() >= ball - 1e-6


@pytest.mark.parametrize("name", ["small", "round_te"])
def test_edge_passes_wrap_the_edges_at_the_ball_radius(name: str, round_te: Path) -> None:
    """Every edge pass's ball touches the blade outline and stays outside the blade
    (``body_distance``, exact for round edges) and clear of the hub; the passes run from
    the suction to the pressure side of the edge."""
    from cam.finishing.edge_paths import HUB_CLEARANCE_MM, edge_passes
    from cam.finishing.paths import body_distance

    spec = IMPELLERS / "small" / "spec.toml" if name == "small" else round_te
    surfaces = build_surfaces(load_spec(spec))
    radius = 2.0
    paths = edge_passes(surfaces, radius, 0.8, 0.5)
    edges = {p.name.split(".")[3] for p in paths}
    assert edges == {"leading_edge", "trailing_edge"}  # cut trailing edges too
    blade = surfaces.blades[0]
    for which in edges:
        mine = [p for p in paths if f".{which}." in p.name]
        assert len(mine) >= 2
        for p in mine:
            assert (surfaces.hub.signed_distance(p.centre) - radius).min() >= \
                HUB_CLEARANCE_MM - 1e-9
            assert np.linalg.norm(np.diff(p.centre, axis=0), axis=1).max() <= 0.5 + 1e-9
            # contact normals turn from the suction side round to the pressure side
            assert float(p.normal[0] @ p.normal[-1]) < -0.5
            if which == "leading_edge" or surfaces.spec.trailing_edge == "round":
                gap = body_distance(blade, p.centre) - radius
                assert gap.min() > -2e-2 and np.median(np.abs(gap)) < 2e-2


def test_the_fillet_tool_is_the_largest_ball_that_fits() -> None:
    chosen = choose_fillet_tool(2.5)
    assert chosen is not None and chosen.name == "ball4_taper"
    assert choose_fillet_tool(3.0) is not None and choose_fillet_tool(3.0).radius == 3.0
    small = choose_fillet_tool(1.0)  # the small fixtures' 1 mm fillets
    assert small is not None and small.name == "ball2_taper" and small.radius == 1.0
    assert choose_fillet_tool(0.8) is None  # no ball of 1.6 mm or less
    assert choose_fillet_tool(0.0) is None
    with pytest.raises(InputError, match="larger than the fillet"):
        check_fillet_tool(resolve_tool("ball6_taper"), 2.5)
    with pytest.raises(InputError, match="ball-end"):
        check_fillet_tool(resolve_tool("flat10"), 6.0)
    with pytest.raises(InputError, match="no blade-to-hub fillet"):
        check_fillet_tool(resolve_tool("ball4_taper"), 0.0)


def test_a_fillet_tool_larger_than_the_fillet_exits_2_writing_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code = main(["finish", str(IMPELLERS / "nine_blade" / "spec.toml"), "-m", str(MACHINE),
                 "-t", "ball6_taper", "-o", str(out), "--fillet-tool", "ball6_taper"])
    assert code == 2
    assert "larger than the fillet" in capsys.readouterr().err
    assert not out.exists()


def test_the_spec_names_the_fillet_tool_and_a_bad_one_is_refused(tmp_path: Path) -> None:
    from cam.inputs import check_run_inputs
    from cam.run.settings import resolve_settings

    text = (IMPELLERS / "nine_blade" / "spec.toml").read_text()
    spec = IMPELLERS / "nine_blade" / "spec.toml"
    good = tmp_path / "good.toml"
    good.write_text(text.replace('finish_tool = "ball6_taper"',
                                 'finish_tool = "ball6_taper"\nfillet_tool = "ball4_taper"'))
    _copy_camber(spec.parent, tmp_path)
    assert resolve_settings(good).fillet_tool == "ball4_taper"
    check_run_inputs(good, MACHINE)
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('finish_tool = "ball6_taper"',
                                'finish_tool = "ball6_taper"\nfillet_tool = "ball6_taper"'))
    with pytest.raises(InputError) as error:
        check_run_inputs(bad, MACHINE)
    assert error.value.field == "machining.fillet_tool"
    typo = tmp_path / "typo.toml"
    typo.write_text(text.replace('finish_tool = "ball6_taper"',
                                 'finish_tool = "ball6_taper"\nfilet_tool = "ball4_taper"'))
    with pytest.raises(InputError):
        resolve_settings(typo)


def _copy_camber(source: Path, target: Path) -> None:
    for csv in source.glob("*.csv"):
        (target / csv.name).write_text(csv.read_text())


@pytest.mark.slow
@pytest.mark.parametrize(("name", "ball"), [("small", "ball1.6_taper"),
                                            ("round_te", "ball2_taper")])
def test_fillet_finishing_is_clean_and_covers_the_fillet(name: str, ball: str, library: Path,
                                                         round_te: Path,
                                                         tmp_path: Path) -> None:
    spec = IMPELLERS / "small" / "spec.toml" if name == "small" else round_te
    scallop = 0.1
    document = run_finish(spec, MACHINE, "ball4_taper", tmp_path / "out",
                          fillet_tool=f"{library}:{ball}", progress=False, plots=False,
                          passages=1, scallop_mm=scallop, point_spacing_mm=1.0,
                          blade_passes=False, hub_passes=False)
    fillet, edge = document["operations"]["fillet"], document["operations"]["edge"]
    assert fillet["tool"]["name"] == ball and fillet["apt"] == "finish_fillet.apt"
    assert edge["tool"]["name"] == "ball4_taper" and edge["apt"] == "finish_edge.apt"
    assert fillet["link_collisions"] == edge["link_collisions"] == 0
    entries = [e for e in document["paths"] if e["operation"] in ("fillet", "edge")]
    assert len(entries) == fillet["paths"] + edge["paths"] and fillet["paths"] > 0
    for entry in entries:
        assert entry["reversals_after"] == {"A": 0, "C": 0}, entry["name"]
        assert entry["collisions"] == 0 and entry["motion_collisions"] == 0, entry["name"]
        assert entry["min_clearance_mm"] >= document["options"]["clearance_mm"]
        assert entry["rule_violation_points"] == [] and not entry["smaller_tool_needed"]
    tool = resolve_tool(f"{library}:{ball}")
    out = tmp_path / "out"
    toolpaths = read_apt(out / "finish_fillet.apt")
    hits, clearance, count = independent_check(
        out / "scene.stl", toolpaths, tool, document["options"]["cutter_allowance_mm"])
    assert count == fillet["poses"] and hits == 0
    assert clearance >= document["options"]["clearance_mm"] - 0.02
    for post in ("linuxcnc", "fanuc"):
        assert f"T{tool.number}" in post_text(out / "finish_fillet.apt", MACHINE, post=post)
    # coverage: the swept balls of the fillet passes alone (feed moves read back from
    # the APT file) leave at most the scallop height on the fillet
    surfaces = build_surfaces(load_spec(spec))
    passes = [tip + tool.radius * axis for tp in toolpaths for tip, axis in passes_of(tp)]
    for wall in [w for pair in passage_walls(surfaces) for w in pair]:
        left = material_left(fillet_samples(surfaces, wall, 400, 15), passes, tool.radius)
        assert left.max() <= scallop + 0.01, (wall.label, float(left.max()))
    # the edge passes (main ball) and the fillet passes (which wrap half of each edge
    # from either side: blade 0's suction side is the last passage's, the rotation of
    # passage 0's blade 1 suction side) leave at most the scallop on blade 0's leading
    # edge and a round trailing edge, above the ball-and-hub contact
    main = resolve_tool("ball4_taper")
    edge_paths = read_apt(out / "finish_edge.apt")
    hits, clearance, count = independent_check(
        out / "scene.stl", edge_paths, main, document["options"]["cutter_allowance_mm"])
    assert count == edge["poses"] and hits == 0
    edge_passes = [tip + main.radius * axis for tp in edge_paths
                   for tip, axis in passes_of(tp)]
    edges = ["leading_edge"] + (["trailing_edge"] if name == "round_te" else [])
    assert edge["paths"] == sum(1 for e in entries if e["operation"] == "edge")
    for which in edges:
        assert any(f".{which}." in e["name"] for e in entries), which
        samples = edge_samples(surfaces, surfaces.blades[0], which, main.radius, 60, 12)
        back = [rotate_about_z(c, -surfaces.spec.pitch) for c in passes]
        left = np.minimum(material_left(samples, edge_passes, main.radius),
                          material_left(samples, passes + back, tool.radius))
        assert left.max() <= scallop + 0.01, (which, float(left.max()))


def test_each_pass_is_cut_round_the_edges_with_overlaps() -> None:
    """Every pass of a wall comes in parts round the leading edge, along the side and
    round the trailing edge; consecutive parts share ``PART_OVERLAP`` ball centres and
    together they are the whole pass (the side part runs over the side alone)."""
    from cam.finishing.fillet_paths import PART_OVERLAP, PARTS

    surfaces = build_surfaces(load_spec(IMPELLERS / "small" / "spec.toml"))
    paths = fillet_passes(surfaces, 0.8, 2.0, 0.1, 0.5)
    whole: dict[str, list] = {}
    for p in paths:
        stem, part = p.name.rsplit(".", 1)
        assert part in PARTS
        whole.setdefault(stem, []).append(p)
    assert len(whole) * 3 == len(paths)
    for stem, parts in whole.items():
        assert [p.name.rsplit(".", 1)[1] for p in parts] == list(PARTS), stem
        for a, b in zip(parts[:-1], parts[1:], strict=True):
            np.testing.assert_allclose(a.centre[-2 * PART_OVERLAP:], b.centre[:2 * PART_OVERLAP])
        total = sum(len(p) for p in parts) - 2 * 2 * PART_OVERLAP
        centres = np.concatenate([parts[0].centre] + [p.centre[2 * PART_OVERLAP:]
                                                      for p in parts[1:]])
        assert len(centres) == total
        # one continuous pass: no step longer than the spacing
        assert np.linalg.norm(np.diff(centres, axis=0), axis=1).max() <= 0.5 + 1e-9


def test_the_neck_lean_clears_the_blade_by_the_clearance() -> None:
    """``sin(lean) (flute_length - r) = clearance + NECK_MARGIN``, between LEAN_DEG and
    MAX_LEAN_DEG."""
    from cam.finishing.fillet_paths import LEAN_DEG
    from cam.finishing.fillet_plan import MAX_LEAN_DEG, NECK_MARGIN, neck_lean

    tool = resolve_tool("ball4_taper")
    lean = neck_lean(tool, 2.5)
    assert math.sin(lean) * (tool.flute_length - tool.radius) == pytest.approx(
        2.5 + NECK_MARGIN)
    assert neck_lean(tool, 0.0) == pytest.approx(math.radians(LEAN_DEG))
    assert neck_lean(tool, 20.0) == pytest.approx(math.radians(MAX_LEAN_DEG))


def test_the_passage_hints_leave_the_fillet_passes_unchanged(
        library: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each pass hands its eq. 7 remedy step to its rotation in the next passage
    (``fillet_plan._finish_all``); a hint is proven before it is taken, so the
    passes are those planned without hints, posture for posture."""
    from cam.collision import CollisionScene
    from cam.finishing import fillet_plan
    from cam.finishing.options import FinishOptions
    from cam.finishing.scene import surface_meshes
    from postproc.kinematics import kinematics_for
    from postproc.machine import load_machine

    surfaces = build_surfaces(load_spec(IMPELLERS / "small" / "spec.toml"))
    scene = CollisionScene(surface_meshes(surfaces, 1.0))
    kins = kinematics_for(load_machine(MACHINE))
    tool = resolve_tool(f"{library}:ball1.6_taper")
    options = FinishOptions(passages=2, scallop_mm=0.2, point_spacing_mm=1.0)
    original = fillet_plan.finish_runs
    given: list[object] = []

    def recorded(*args: object, hint: object = None, **kwargs: object) -> object:
        given.append(hint)
        return original(*args, hint=hint, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(fillet_plan, "finish_runs", recorded)
    hinted = fillet_plan.plan_fillet(surfaces, tool, 2.0, kins, scene, options,
                                     scene_source="surfaces")
    monkeypatch.setattr(fillet_plan, "finish_runs",
                        lambda *a, hint=None, **k: original(*a, **k))
    plain = fillet_plan.plan_fillet(surfaces, tool, 2.0, kins, scene, options,
                                    scene_source="surfaces")
    # the second passage's passes were handed their first passage's step
    assert sum(h is not None for h in given) >= len(given) // 4
    assert [p.path.name for p in hinted.paths] == [p.path.name for p in plain.paths]
    for a, b in zip(hinted.paths, plain.paths, strict=True):
        np.testing.assert_array_equal(a.tip, b.tip)
        np.testing.assert_array_equal(a.axis, b.axis)
        assert a.interference.steps == b.interference.steps
    assert hinted.extra["cut_short"] == plain.extra["cut_short"]
