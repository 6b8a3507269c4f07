"""The post-processor registry: built-ins, entry-point plug-ins, broken plug-ins, CLI."""

from __future__ import annotations

from importlib import metadata

import pytest

import postproc.posts.base as base
from cam.cli import main
from impeller_cam.errors import InputError
from postproc.posts import GCodeWriter, PostProcessor, available_posts, get_post


class _ThirdPartyPost(GCodeWriter):
    name = "acme"
    description = "ACME controller (test plug-in)"
    extension = "acm"


def _points(*points: metadata.EntryPoint):
    def entry_points(group: str | None = None, **_: object):
        assert group == base.ENTRY_POINT_GROUP
        return list(points)

    return entry_points


@pytest.fixture
def fresh_registry(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(base, "_REGISTRY", dict(base._REGISTRY))
    monkeypatch.setattr(base, "_ENTRY_POINTS_SCANNED", False)
    return monkeypatch


def test_builtins_are_listed_and_follow_the_protocol() -> None:
    names = [name for name, _, _ in available_posts()]
    assert {"linuxcnc", "fanuc"} <= set(names)
    for name in ("linuxcnc", "fanuc"):
        post = get_post(name)
        assert isinstance(post, PostProcessor)
        assert post.supports_tcp


def test_unknown_post_is_input_error() -> None:
    with pytest.raises(InputError) as error:
        get_post("okuma")
    assert error.value.field == "--post" and "linuxcnc" in str(error.value)


def test_entry_point_plugin_is_listed_and_used(fresh_registry: pytest.MonkeyPatch) -> None:
    point = metadata.EntryPoint("acme", f"{__name__}:_ThirdPartyPost", base.ENTRY_POINT_GROUP)
    fresh_registry.setattr(base.metadata, "entry_points", _points(point))
    rows = {name: (description, source) for name, description, source in available_posts()}
    assert rows["acme"][0] == "ACME controller (test plug-in)"
    assert "entry point" in rows["acme"][1]
    assert isinstance(get_post("acme"), _ThirdPartyPost)


def test_plugin_cannot_replace_a_builtin(fresh_registry: pytest.MonkeyPatch) -> None:
    point = metadata.EntryPoint("linuxcnc", f"{__name__}:_ThirdPartyPost",
                                base.ENTRY_POINT_GROUP)
    fresh_registry.setattr(base.metadata, "entry_points", _points(point))
    assert not isinstance(get_post("linuxcnc"), _ThirdPartyPost)


def test_broken_plugin_stays_listed_and_raises_its_import_error_when_used(
    fresh_registry: pytest.MonkeyPatch,
) -> None:
    point = metadata.EntryPoint("broken", "impeller_cam_missing_dependency_xyz:Post",
                                base.ENTRY_POINT_GROUP)
    fresh_registry.setattr(base.metadata, "entry_points", _points(point))
    rows = {name: description for name, description, _ in available_posts()}
    assert "unavailable" in rows["broken"] and "impeller_cam_missing_dependency_xyz" in rows[
        "broken"]
    with pytest.raises(ModuleNotFoundError) as first:
        get_post("broken")
    with pytest.raises(ModuleNotFoundError) as second:
        get_post("broken")
    assert first.value is second.value  # the original error, re-raised


def test_register_unavailable_builtin(fresh_registry: pytest.MonkeyPatch) -> None:
    error = ImportError("No module named 'vendor_sdk'")
    base.register_unavailable("vendor", "Vendor controller", error)
    assert any(name == "vendor" and "unavailable" in text for name, text, _ in available_posts())
    with pytest.raises(ImportError) as raised:
        get_post("vendor")
    assert raised.value is error


def test_cli_posts_lists_name_description_source(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["posts"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["name", "description", "source"]
    assert any(line.startswith("linuxcnc ") and line.endswith("built-in") for line in out)
    assert any(line.startswith("fanuc ") for line in out)
