"""finish.json's stock entry measures each path with the tool that cuts it.

The fillet passes are cut with the fillet pencil's ball, not the finishing tool:
``_engagement`` (cam/finishing/command.py) must hand that ball to the engagement
depth and to the stock-blocking check of those paths.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from cam.finishing import command
from cam.tools import resolve_tool


class _Excess:
    def summary(self) -> dict[str, Any]:
        return {"voxel_mm": 0.5}


def _path(operation: str) -> SimpleNamespace:
    tip = np.zeros((3, 3))
    axis = np.tile([0.0, 0.0, 1.0], (3, 1))
    interference = SimpleNamespace(interfering_points=np.array([1]), hit_role=[None] * 3)
    return SimpleNamespace(path=SimpleNamespace(operation=operation, name=f"p0.{operation}"),
                           tip=tip, axis=axis, interference=interference)


def test_each_path_is_measured_with_its_operations_tool(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    finish, fillet = resolve_tool("ball6_taper"), resolve_tool("ball2_taper")
    seen: list[tuple[str, str]] = []

    def engagement(excess: Any, tool: Any, tip: Any, axis: Any) -> Any:
        seen.append(("engagement", tool.name))
        return np.full(len(tip), 0.1), np.zeros(len(tip), dtype=bool)

    def stock_blocked(scene: Any, tool: Any, tip: Any, axis: Any, allowance: float,
                      clearance: float) -> Any:
        seen.append(("blocked", tool.name))
        return np.zeros(len(tip), dtype=bool)

    monkeypatch.setattr(command, "engagement", engagement)
    monkeypatch.setattr(command, "stock_blocked", stock_blocked)
    options = SimpleNamespace(cutter_allowance_mm=0.05, stock_clearance_mm=0.5)
    result = SimpleNamespace(paths=[_path("blade"), _path("fillet")], tool=finish,
                             options=options)
    entries: list[dict[str, Any]] = [{}, {}]
    scene = SimpleNamespace(excess=_Excess())
    entry = command._engagement(scene, result, entries,  # type: ignore[arg-type]
                                {"blade": finish, "fillet": fillet})
    assert seen == [("engagement", finish.name), ("blocked", finish.name),
                    ("engagement", fillet.name), ("blocked", fillet.name)]
    assert entry["paths_blocked_by_stock"] == []
    assert entries[1]["stock_engagement"]["max_depth_mm"] == pytest.approx(0.1)
