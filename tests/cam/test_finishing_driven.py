"""The cutter allowance on the faces a pass drives only (cam/finishing/driven.py).

Planted case of the splitter's outlet gouges: a ball beside a wall it cuts whose
flutes reach a face the pass does not drive (the trailing edge) by a known depth.
With the allowance on every face (the check before) a 0.035 mm cut into that face
passed the 0.05 mm allowance; the pass's scene refuses it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from cam.collision import CollisionScene
from cam.finishing.driven import DrivenScene, design_scene, driven_roles, driven_scene
from cam.finishing.interference import check_path
from cam.finishing.options import FinishOptions
from cam.finishing.paths import CutterPath, Wall
from cam.tools import resolve_tool
from impeller_cam.errors import InputError

TOOL = resolve_tool("ball4_taper")  # R 2, flutes 10
R = TOOL.radius
#: The circumscribing tool mesh is up to ~0.006 mm larger than the tool
#: (tests/cam/test_finishing_interference.py): depths keep that far from the limits.
MESH = 0.006
#: Height of the ball centres, mm.
Z = 5.0
#: Top of the faces: below the shank (from the tip + 10 mm), so only the cutter meets them.
TOP = Z + 4.0


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    box = trimesh.creation.box(extents=np.subtract(hi, lo))
    box.apply_translation(0.5 * np.add(lo, hi))
    return box


def scene(te_face_y: float, wall_top: float = TOP) -> CollisionScene:
    """A wall (role ``pressure``, face x = 0) and a block (role ``trailing_edge``,
    face y = ``te_face_y``, x in [1, 6]) beside the upright tool of ``postures``."""
    return CollisionScene({
        "pressure": _box((-1.0, -50.0, 0.0), (0.0, 50.0, wall_top)),
        "trailing_edge": _box((1.0, te_face_y, 0.0), (6.0, te_face_y + 5.0, TOP)),
    }, grid_spacing=2.0)


def postures(wall_depth: float, y: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """An upright tool whose ball cuts ``wall_depth`` into the wall (x = 0), mm."""
    centre = np.array([[R - wall_depth, y, Z]])
    axis = np.array([[0.0, 0.0, 1.0]])
    return centre - R * axis, axis


def blade_pass(side: int = 1, operation: str = "blade", name: str = "p0.blade.b.x.01"
               ) -> CutterPath:
    """A pass record with what ``driven_roles`` reads (operation, wall side, name)."""
    wall = Wall(blade=None, side=side, label="blade0.pressure")  # type: ignore[arg-type]
    point = np.zeros((1, 3))
    return CutterPath(name=name, operation=operation, passage=0, centre=point,
                      normal=point, reference_axis=point, away=point, opposite_tip=point,
                      curve_u=np.zeros(1), wall=wall)


OPTIONS = FinishOptions()


@pytest.mark.parametrize("depth", [0.03, 0.035, 0.04])
def test_flutes_into_an_undriven_face_are_refused(depth: float) -> None:
    # the flutes (radius R round the axis x = R) reach y = R: a face at R - depth
    world = scene(R - depth)
    tip, axis = postures(0.0)
    assert OPTIONS.undriven_allowance_mm + MESH < depth < OPTIONS.cutter_allowance_mm - MESH
    # the allowance on every face (the check before): accepted, a cut of ``depth``
    assert not check_path(world, TOOL, tip, axis, OPTIONS).collides.any()
    report = check_path(driven_scene(world, blade_pass(), OPTIONS), TOOL, tip, axis, OPTIONS)
    assert report.collides.all()
    assert report.hit_role == ["trailing_edge"]


def test_the_driven_face_keeps_the_cutter_allowance() -> None:
    # the ball 0.035 mm into the wall it cuts (a tessellated concave face), the
    # trailing edge within the undriven allowance
    world = scene(R - 0.01)
    tip, axis = postures(0.035)
    report = check_path(driven_scene(world, blade_pass(), OPTIONS), TOOL, tip, axis, OPTIONS)
    assert not report.collides.any()
    # past the cutter allowance the wall itself stops it
    tip, axis = postures(OPTIONS.cutter_allowance_mm + 0.02)
    report = check_path(driven_scene(world, blade_pass(), OPTIONS), TOOL, tip, axis, OPTIONS)
    assert report.hit_role == ["pressure"]


def test_the_motion_between_clear_postures_is_checked_too() -> None:
    # a narrow block (x in [4, 4.5]) whose face y = R - 0.035 the flutes (a circle of
    # radius R about the axis) reach by 0.035 mm while the axis is within 0.37 mm of it
    world = CollisionScene({
        "pressure": _box((-1.0, -50.0, 0.0), (0.0, 50.0, TOP)),
        "trailing_edge": _box((4.0, R - 0.035, 0.0), (4.5, R + 5.0, TOP)),
    }, grid_spacing=2.0)
    centre = np.array([[R, 0.0, Z], [R + 5.0, 0.0, Z]])
    axis = np.tile([0.0, 0.0, 1.0], (2, 1))
    tip = centre - R * axis
    # both end postures (axis at x = 2 and x = 7) are clear of the block
    before = check_path(world, TOOL, tip, axis, OPTIONS)
    assert not before.collides.any() and not before.motion_collides.any()
    after = check_path(driven_scene(world, blade_pass(), OPTIONS), TOOL, tip, axis, OPTIONS)
    assert not after.collides.any()
    assert after.motion_collides.all()


def test_shank_and_holder_are_checked_as_before() -> None:
    # a wall up to z = 20 one mm off the ball: the neck's clearance as in
    # tests/cam/test_finishing_interference.py, the same through the pass's scene
    world = scene(R + 1.0, wall_top=20.0)
    tip, axis = postures(-1.0)
    plain = check_path(world, TOOL, tip, axis, OPTIONS)
    driven = check_path(driven_scene(world, blade_pass(), OPTIONS), TOOL, tip, axis, OPTIONS)
    expected = 3.0 - (2.0 + (20.0 - (Z - R) - TOOL.flute_length) * math.tan(math.radians(1.5)))
    assert plain.clearance[0] == pytest.approx(expected, abs=0.01)
    np.testing.assert_array_equal(driven.clearance, plain.clearance)
    assert not driven.collides.any() and not plain.collides.any()


def test_driven_roles_by_operation() -> None:
    assert driven_roles(blade_pass(+1)) == ("pressure", "fillet")
    assert driven_roles(blade_pass(-1)) == ("suction", "fillet")
    assert driven_roles(blade_pass(+1, "junction")) == ("pressure", "hub", "fillet")
    assert driven_roles(blade_pass(-1, "fillet")) == (
        "fillet", "hub", "pressure", "suction", "leading_edge", "trailing_edge", "edges")
    assert driven_roles(blade_pass(+1, "hub")) == ("hub", "fillet")
    edge = blade_pass(+1, "edge", "p0.edge.blade0.leading_edge.02")
    assert driven_roles(edge) == ("leading_edge", "pressure", "suction", "fillet")
    assert driven_roles(blade_pass(+1, "swarf")) is None


def test_driven_scene_wraps_once_and_only_when_it_matters() -> None:
    world = scene(R + 1.0)
    wrapped = driven_scene(world, blade_pass(), OPTIONS)
    assert isinstance(wrapped, DrivenScene)
    assert wrapped.driven == ("pressure",) and wrapped.others == ("trailing_edge",)
    assert driven_scene(wrapped, blade_pass(), OPTIONS) is wrapped
    assert design_scene(wrapped) is world
    # another pass's roles: a new wrapper of the same scene
    other = driven_scene(wrapped, blade_pass(-1), OPTIONS)
    assert isinstance(other, DrivenScene) and other.inner is world
    # no smaller allowance: the scene itself
    same = FinishOptions(undriven_allowance_mm=OPTIONS.cutter_allowance_mm)
    assert driven_scene(world, blade_pass(), same) is world
    assert driven_scene(world, blade_pass(+1, "swarf"), OPTIONS) is world


def test_undriven_allowance_must_be_a_number_at_least_zero() -> None:
    with pytest.raises(InputError, match="undriven_allowance_mm"):
        FinishOptions(undriven_allowance_mm=-0.01)


#: The last posture of a pressure-side blade pass of the splitter chain (298206b,
#: finish_blade.apt line 10725): tip (mm) and axis. The verifier found 0.052 mm gouges
#: at such postures' trailing-edge tip corners.
SPLITTER_TIP = (-76.891791, -28.865307, 11.229108)
SPLITTER_AXIS = (0.031721, 0.006963, 0.999472)


@pytest.mark.slow
def test_the_splitter_outlet_posture_is_refused() -> None:
    from cam.finishing.scene import solid_meshes
    from cam.verify.deviation import DesignDistance
    from geometry.impeller import Impeller
    from tests.cam.conftest import ROOT

    impeller = Impeller.from_spec(ROOT / "fixtures" / "impellers" / "splitter" / "spec.toml")
    tip = np.array([SPLITTER_TIP])
    axis = np.array([SPLITTER_AXIS]) / np.linalg.norm(SPLITTER_AXIS)
    # independently: the flutes reach 0.048 mm into the trailing edge (the design mesh)
    mesh = impeller.mesh()
    design = DesignDistance(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    heights = np.arange(0.0, TOOL.flute_length - R, 0.05)
    depth, face = design.closest(tip + (R + heights)[:, None] * axis)
    deepest = int(np.argmin(depth))
    assert R - depth[deepest] == pytest.approx(0.048, abs=0.002)
    assert impeller.triangle_roles()[face[deepest]] == "trailing_edge"
    world = CollisionScene(solid_meshes(impeller, OPTIONS.tessellation_mm))
    assert not world.check_postures(TOOL, tip, axis, cutter_allowance=0.05,
                                    clearance=False).collides.any()
    report = driven_scene(world, blade_pass(+1), OPTIONS).check_postures(
        TOOL, tip, axis, cutter_allowance=OPTIONS.cutter_allowance_mm, clearance=False)
    assert report.collides.all() and report.hit_role == ["trailing_edge"]
