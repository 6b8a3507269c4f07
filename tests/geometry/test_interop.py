"""The impeller in build123d: out as a Part, edited, face roles kept; a script's hub
and blank in (issue 24). The cadquery round trip: test_interop_cadquery.py."""

from __future__ import annotations

import dataclasses
from collections import Counter

import numpy as np
import pytest

from geometry import FaceRoles, Impeller, impeller_part, load_spec, solid_mesh
from geometry.brep import volume
from geometry.meridional import hub_contour, meridional_profile, with_hub
from geometry.revolved import RevolvedSurface
from impeller_cam.errors import InputError
from tests.geometry.interop_cases import (
    GROOVE_DEPTH,
    GROOVE_INNER,
    GROOVE_OUTER,
    KEY_REACH,
    KEY_WIDTH,
    SMALL,
    bore_height,
    groove_volume,
    hub_points,
    keyway_volume,
    pappus_volume,
)

bd = pytest.importorskip("build123d")


@pytest.fixture(scope="module")
def small() -> Impeller:
    return Impeller.from_spec(SMALL)


def _edited(part: object) -> object:
    key = bd.Box(KEY_WIDTH, KEY_REACH, 200,
                 align=(bd.Align.CENTER, bd.Align.MIN, bd.Align.CENTER))
    on_back = (bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN)
    groove = (bd.Cylinder(GROOVE_OUTER, GROOVE_DEPTH, align=on_back)
              - bd.Cylinder(GROOVE_INNER, GROOVE_DEPTH, align=on_back))
    return part - key - groove  # type: ignore[operator]


def test_part_out_is_the_solid(small: Impeller) -> None:
    part = impeller_part(small)
    assert isinstance(part, bd.Part)
    assert part.label == "small"
    assert part.volume == pytest.approx(volume(small.solid), rel=1e-12)
    roles = FaceRoles.of(small)
    assert roles.counts(part) == {k: v for k, v in small.role_counts().items() if v}
    labels = Counter(face.label for face in roles.label(part))
    assert labels == Counter({k: v for k, v in small.role_counts().items() if v})
    pressure = roles.select(part, "pressure")
    assert len(pressure) == small.spec.blades and {f.label for f in pressure} == {"pressure"}


def test_keyway_and_groove_keep_roles(small: Impeller) -> None:
    part = impeller_part(small)
    roles = FaceRoles.of(small)
    edited = _edited(part)
    removed = keyway_volume(small.spec.bore_radius, bore_height(small.spec)) + groove_volume()
    # GProp integrates the B-spline solid to ~1e-6 relative
    assert part.volume - edited.volume == pytest.approx(removed, rel=1e-5)
    before, after = roles.counts(part), roles.counts(edited)
    # the blades, fillets and hub are untouched; the bore is cut open by the keyway, the
    # back face split in two by the groove; 3 keyway + 3 groove faces are new
    for role in ("pressure", "suction", "fillet", "leading_edge", "trailing_edge", "hub",
                 "shroud"):
        assert after[role] == before[role]
    assert after["bore"] == 1 and after["back"] == 2 and after[None] == 6
    new = roles.faces(edited, None)
    areas = sorted(bd.Face(f).area for f in new)
    groove_bottom = np.pi * (GROOVE_OUTER**2 - GROOVE_INNER**2)
    assert max(areas) == pytest.approx(groove_bottom, rel=1e-9)
    assert {f.label for f in roles.label(edited)} >= {"bore", "back", ""}


def test_step_export_of_the_edit(small: Impeller, tmp_path) -> None:
    edited = _edited(impeller_part(small))
    path = tmp_path / "edited.step"
    assert bd.export_step(edited, str(path))
    back = bd.import_step(str(path))
    assert back.volume == pytest.approx(edited.volume, rel=1e-6)


def test_unknown_role_and_shape(small: Impeller) -> None:
    roles = FaceRoles.of(small)
    with pytest.raises(InputError, match="unknown face role"):
        roles.faces(small.solid, "blade")
    with pytest.raises(InputError, match="not a shape"):
        roles.counts("impeller.step")


def _script_hub(spec):  # noqa: ANN001, ANN202 - a build123d script's own hub
    spline, closing = hub_points(spec)
    face = bd.make_face([bd.Spline(*spline), bd.Polyline(*closing)])
    return bd.revolve(face, bd.Axis.Z)


def test_meridional_profile_of_a_script_hub() -> None:
    spec = load_spec(SMALL)
    hub = _script_hub(spec)
    profile = meridional_profile(hub)
    signed = 0.5 * np.sum(profile[:, 0] * np.roll(profile[:, 1], -1)
                          - np.roll(profile[:, 0], -1) * profile[:, 1])
    assert signed > 0  # counter-clockwise
    assert profile[:, 0].min() == pytest.approx(spec.bore_radius, abs=1e-9)
    # Pappus on the sampled polygon (chords inside the spline by <= 0.002 mm)
    assert pappus_volume(profile) == pytest.approx(hub.volume, rel=2e-4)
    contour = hub_contour(hub, spec.hub_contour)
    assert np.allclose(contour[0], spec.hub_contour[0], atol=1e-9)
    assert np.allclose(contour[-1], spec.hub_contour[-1], atol=1e-9)
    reference = RevolvedSurface(spec.hub_contour, passage_side=+1)
    foot = reference.meridian(reference.closest_s(contour[:, 0], contour[:, 1]))
    assert np.hypot(*(contour - foot).T).max() < 1e-3


def test_script_hub_builds_the_impeller(small: Impeller) -> None:
    spec = with_hub(small.spec, _script_hub(small.spec), samples=33)
    assert len(spec.hub_contour) == 33 and spec.bore_radius == pytest.approx(4.0)
    impeller = Impeller(spec)
    assert impeller.role_counts() == small.role_counts()
    assert volume(impeller.solid) == pytest.approx(volume(small.solid), rel=2e-4)


def test_script_hub_must_carry_the_blades(small: Impeller) -> None:
    lowered = dataclasses.replace(small.spec, hub_contour=small.spec.hub_contour
                                  - np.array([1.0, 0.0]))
    with pytest.raises(InputError, match="off its meridional contour"):
        with_hub(small.spec, _script_hub(lowered))


def test_script_blank_becomes_the_stock() -> None:
    from cam.verify import Stock

    blank = bd.Cylinder(42.0, 33.0, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN))
    blank -= bd.Cylinder(4.0, 33.0, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN))
    mesh = solid_mesh(blank, tolerance=0.005)
    assert mesh.is_watertight
    exact = np.pi * (42.0**2 - 4.0**2) * 33.0
    assert mesh.volume == pytest.approx(exact, rel=1e-3)
    stock = Stock.from_mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), 0.5)
    assert stock.volume() == pytest.approx(exact, rel=0.02)
    with pytest.raises(InputError, match="no solid"):
        solid_mesh(bd.Circle(3.0))
