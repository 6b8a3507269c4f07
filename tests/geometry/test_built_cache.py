"""The process's kept solids and meshes (``geometry.built_cache``): a second
``Impeller`` of the same geometry takes over the first one's solid and an equal but
separate mesh; a different geometry is a different key; the oldest is dropped."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from geometry import built_cache
from geometry.impeller import Impeller
from geometry.spec import load_spec

SMALL = Path(__file__).resolve().parents[2] / "fixtures" / "impellers" / "small" / "spec.toml"


def test_a_second_impeller_of_the_same_geometry_takes_the_solid_and_a_mesh_copy() -> None:
    first = Impeller.from_spec(SMALL)
    mesh = first.mesh(tolerance=0.1)
    second = Impeller.from_spec(SMALL)
    assert second.solid is first.solid
    assert second.build_seconds == first.build_seconds > 0.0
    again = second.mesh(tolerance=0.1)
    assert again is not mesh and again.vertices is not mesh.vertices
    assert np.array_equal(again.vertices, mesh.vertices)
    assert np.array_equal(again.faces, mesh.faces)
    assert np.array_equal(second.triangle_roles(0.1), first.triangle_roles(0.1))
    mesh.vertices[:] += 1.0  # a caller's change stays its own
    assert np.array_equal(Impeller.from_spec(SMALL).mesh(tolerance=0.1).vertices,
                          again.vertices)


def test_the_key_is_the_geometry() -> None:
    spec = load_spec(SMALL)
    key = built_cache.geometry_key(spec, True)
    assert built_cache.geometry_key(replace(spec, name="other", source=None), True) == key
    assert built_cache.geometry_key(spec, False) != key
    thicker = replace(spec, thickness_mm=spec.thickness_mm + 0.1)
    assert built_cache.geometry_key(thicker, True) != key
    assert built_cache.geometry_key(replace(spec, fillet_radius=0.5), True) != key


def test_the_oldest_geometry_is_dropped() -> None:
    built_cache.clear()
    entries = [built_cache.BuiltGeometry(object(), 1.0) for _ in range(built_cache.SIZE + 1)]  # type: ignore[arg-type]
    for i, entry in enumerate(entries):
        assert built_cache.store(f"k{i}", entry) is entry
    assert built_cache.lookup("k0") is None
    assert built_cache.lookup(f"k{built_cache.SIZE}") is entries[-1]
    assert built_cache.store("k1", built_cache.BuiltGeometry(object(), 2.0)) is entries[1]  # type: ignore[arg-type]
    built_cache.clear()
    assert built_cache.lookup("k1") is None


def test_the_blank_profile_is_made_once_per_geometry_and_handed_out_as_a_copy() -> None:
    from geometry.blank import _spec_blank_profile, spec_blank_profile

    spec = load_spec(SMALL)
    made = _spec_blank_profile(spec, None)
    first = spec_blank_profile(spec)
    assert np.array_equal(first, made)
    first[:] = 0.0  # the caller's copy
    assert np.array_equal(spec_blank_profile(replace(spec, name="again")), made)
    more = replace(spec, stock_allowance=spec.stock_allowance + 1.0)
    assert not np.array_equal(spec_blank_profile(more), made)
