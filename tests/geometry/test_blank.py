"""The turned blank contains the design with the stock allowance over every blade face.

Checked on the B-rep's mesh (independent of the closed-form samples the blank is
built from): every vertex of the part lies inside the blank's meridional profile,
and every vertex of a milled face (blade sides, edges, tips, fillets) lies at least
the stock allowance less ``STEP`` + ``SLACK`` inside its boundary. Designs: the
round-trailing-edge fixture and generated variants (cut and round edges, a
thickness law, splitters, a large fillet).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from geometry.blank import SLACK, STEP, raised_profile, spec_blank_profile

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "impellers"
MILLED = ("pressure", "suction", "leading_edge", "trailing_edge", "fillet", "shroud")


def _inside_and_margin(profile: np.ndarray, points: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Whether (r, z) points lie inside the closed polygon, and their distance to it."""
    a, b = profile[:-1], profile[1:]
    d = b - a
    rel = points[:, None, :] - a[None]
    t = np.clip(np.einsum("nkj,kj->nk", rel, d) / np.einsum("kj,kj->k", d, d), 0.0, 1.0)
    gap = rel - t[..., None] * d[None]
    margin = np.sqrt(np.einsum("nkj,nkj->nk", gap, gap)).min(axis=1)
    straddle = (a[None, :, 1] > points[:, None, 1]) != (b[None, :, 1] > points[:, None, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = a[None, :, 0] + (points[:, None, 1] - a[None, :, 1]) * d[None, :, 0] / d[
            None, :, 1]
    inside = np.count_nonzero(straddle & (cross > points[:, None, 0]), axis=1) % 2 == 1
    return inside, margin


def _check(spec_path: Path) -> None:
    from geometry.impeller import Impeller

    impeller = Impeller.from_spec(spec_path)
    profile = spec_blank_profile(impeller.spec)
    assert np.array_equal(profile[0], profile[-1])
    mesh = impeller.mesh()
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    roles = np.asarray(impeller.triangle_roles())
    rz = np.column_stack([np.hypot(vertices[:, 0], vertices[:, 1]), vertices[:, 2]])
    inside, margin = _inside_and_margin(profile, rz)
    on_boundary = margin < 1e-6  # lathe-finished faces: back, bore, nose
    assert np.all(inside | on_boundary), rz[~(inside | on_boundary)][:5]
    milled = np.unique(faces[np.isin(roles, MILLED)])
    need = impeller.spec.stock_allowance - STEP - SLACK
    assert margin[milled].min() >= need, (margin[milled].min(), need)


@pytest.mark.slow
def test_round_trailing_edges_are_inside_the_blank_with_the_allowance() -> None:
    _check(FIXTURES / "round_te" / "spec.toml")


@pytest.mark.slow
@pytest.mark.parametrize("changes", [
    {"trailing_edge": "cut", "thickness_mm": (2.5, 2.5), "fillet_radius": 2.0},
    {"trailing_edge": "round", "splitters": 1, "stock_allowance": 0.6,
     "thickness_u": (0.0, 0.5, 1.0), "thickness_mm": (1.0, 2.0, 1.6)},
], ids=["thick_cut", "round_splitters"])
def test_generated_designs_are_inside_their_blank(changes: dict, tmp_path: Path) -> None:
    from geometry.design import load_design
    from geometry.design_files import write_design

    params = dataclasses.replace(load_design(FIXTURES / "small" / "design.toml"), **changes)
    _check(write_design(params, tmp_path / "variant"))


def test_raised_profile_takes_the_higher_of_profile_and_envelope() -> None:
    # a box blank r 5..20, z 0..10; the envelope demands z = 12 for r in [10, 12]
    box = np.array([[5.0, 0.0], [20.0, 0.0], [20.0, 10.0], [5.0, 10.0], [5.0, 0.0]])
    radii = np.arange(0.0, 30.0 + 1e-9, 0.5)
    top = np.where((radii >= 10.0) & (radii <= 12.0), 12.0, -np.inf)
    raised = raised_profile(box, radii, top)
    assert np.array_equal(raised[0], raised[-1])
    inside, _ = _inside_and_margin(raised, np.array([[11.0, 11.9], [15.0, 9.9], [6.0, 1.0]]))
    assert inside.tolist() == [True, True, True]
    outside, _ = _inside_and_margin(raised, np.array([[15.0, 10.1], [4.0, 5.0], [21.0, 5.0]]))
    assert not outside.any()
    # the envelope beyond the box's outer diameter is stock from z = 0 up
    wider = raised_profile(box, radii, np.where(radii >= 19.0, 4.0, -np.inf))
    assert _inside_and_margin(wider, np.array([[25.0, 3.9]]))[0].all()
    assert wider[:, 0].max() == pytest.approx(30.0)
