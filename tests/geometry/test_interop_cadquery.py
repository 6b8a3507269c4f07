"""The impeller in cadquery: out as a tagged Workplane, edited, face roles kept; a
script's hub and blank in (issue 24).

cadquery is an optional extra that cannot share the project's venv (its OCP release
differs from build123d's: docs/dependencies.md); scripts/test runs this module in a
second venv, ``.venv-cadquery``. Without cadquery the module is skipped.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from geometry import FaceRoles, Impeller, impeller_workplane, load_spec, solid_mesh, with_hub
from geometry.brep import volume
from geometry.meridional import meridional_profile
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

if os.environ.get("IMPELLER_CAM_REQUIRE_CADQUERY") == "1":  # scripts/test's cadquery venv
    import cadquery as cq
else:
    cq = pytest.importorskip(
        "cadquery", reason="cadquery is the optional extra [cadquery], tested in "
        ".venv-cadquery (scripts/test): its OCP release cannot share a venv with build123d's")


@pytest.fixture(scope="module")
def small() -> Impeller:
    return Impeller.from_spec(SMALL)


def _edited(workplane):  # noqa: ANN001, ANN202 - a cadquery script's edit
    key = cq.Workplane("XY").box(KEY_WIDTH, KEY_REACH, 1000.0, centered=(True, False, True))
    groove = (cq.Workplane("XY").circle(GROOVE_OUTER).circle(GROOVE_INNER)
              .extrude(GROOVE_DEPTH))
    return workplane.cut(key).cut(groove)


def test_workplane_out_is_the_solid(small: Impeller) -> None:
    wp = impeller_workplane(small)
    assert isinstance(wp, cq.Workplane)
    assert wp.val().Volume() == pytest.approx(volume(small.solid), rel=1e-12)
    for role, count in small.role_counts().items():
        tagged = wp.faces(tag=role).vals() if count else []
        assert len(tagged) == count, role
        assert all(isinstance(face, cq.Face) for face in tagged)


def test_keyway_and_groove_keep_roles(small: Impeller) -> None:
    roles = FaceRoles.of(small)
    wp = impeller_workplane(small)
    edited = _edited(wp)
    removed = keyway_volume(small.spec.bore_radius, bore_height(small.spec)) + groove_volume()
    assert wp.val().Volume() - edited.val().Volume() == pytest.approx(removed, rel=1e-5)
    before, after = roles.counts(wp), roles.counts(edited)
    for role in ("pressure", "suction", "fillet", "leading_edge", "trailing_edge", "hub",
                 "shroud"):
        assert after[role] == before[role]
    assert after["bore"] == 1 and after["back"] == 2 and after[None] == 6
    tagged = roles.tag(edited)
    assert len(tagged.faces(tag="back").vals()) == 2
    assert len(tagged.faces(tag="pressure").vals()) == small.spec.blades
    assert tagged.val().Volume() == pytest.approx(edited.val().Volume(), rel=1e-12)


def test_step_export_of_the_edit(small: Impeller, tmp_path) -> None:
    edited = _edited(impeller_workplane(small))
    path = tmp_path / "edited.step"
    cq.exporters.export(edited, str(path))
    back = cq.importers.importStep(str(path))
    assert back.val().Volume() == pytest.approx(edited.val().Volume(), rel=1e-6)


def _script_hub(spec):  # noqa: ANN001, ANN202 - a cadquery script's own hub
    spline, closing = hub_points(spec)
    xz = [(x, z) for x, _, z in spline]
    rest = [(x, z) for x, _, z in closing]
    sketch = cq.Workplane("XZ").spline(xz, includeCurrent=False).polyline(rest).close()
    return sketch.revolve(360.0, (0, 0, 0), (0, 1, 0))


def test_script_hub_builds_the_impeller(small: Impeller) -> None:
    hub = _script_hub(small.spec)
    profile = meridional_profile(hub)
    assert pappus_volume(profile) == pytest.approx(hub.val().Volume(), rel=2e-4)
    spec = with_hub(load_spec(SMALL), hub, samples=33)
    impeller = Impeller(spec)
    assert impeller.role_counts() == small.role_counts()
    assert volume(impeller.solid) == pytest.approx(volume(small.solid), rel=2e-4)


def test_script_blank_becomes_the_stock() -> None:
    from cam.verify import Stock

    blank = cq.Workplane("XY").circle(42.0).circle(4.0).extrude(33.0)
    mesh = solid_mesh(blank, tolerance=0.005)
    exact = np.pi * (42.0**2 - 4.0**2) * 33.0
    assert mesh.volume == pytest.approx(exact, rel=1e-3)
    stock = Stock.from_mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), 0.5)
    assert stock.volume() == pytest.approx(exact, rel=0.02)
    with pytest.raises(InputError, match="not a shape"):
        solid_mesh(cq.Workplane("XY"))
