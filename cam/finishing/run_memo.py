"""What one run of ``run_finish`` made that the next run, against less stock, reuses.

The chain's rest operation (``cam.run.rest``) runs finishing twice: against the rough
stock, then against the stock the rest operation left -- the rough stock less what it
cut, so contained in it -- planning anew only the passes the rest operation was for
(``plan_memo``). Whatever the second run would make again from the same design and the
same plans is kept from the first (``RunMemo``, carried by the ``PlanMemo``):

* the design's collision scene (its meshes, fcl objects, distance grids) and
  ``scene.stl``: the same impeller and tessellation give the same scene;
* the machine reach check (``machine_reach``): it asks the machine and the part's
  solid of revolution (``machine_scene.part_solid``) about the passes, and with the
  same solid refuses or passes the same passes the same way;
* per operation whose passes are the very plans of the first run (the same objects in
  the same order): its linked toolpath, its links' collision count and its APT text
  (links clear of more material are clear of less: the premise of ``plan_memo``'s
  recalled plans too); with the machine model also its clearance entry and each
  path's machine-blocked postures, when the part's solid of revolution
  (``machine_scene.part_solid``) is the same;
* each such path's angular displacement plot.

What depends on the stock is made again: the excess-stock scene, every path's
engagement and stock-blocked postures, and everything of the passes planned anew and
of the operations they belong to.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    from cam.finishing.plan import PathResult
    from postproc.machine_model import Solid

__all__ = ["MadeOperation", "RunMemo", "same_solid"]


@dataclass
class MadeOperation:
    """One operation as a run made it from its passes' plans.

    Attributes
    ----------
    paths : list of PathResult
        Its finished paths, machining order (the plans' own objects).
    tool : str
        Name of its tool.
    linked : tuple
        ``(toolpath, air mask (n,) bool, link entries)`` (``linked_ops.finish_toolpaths``).
    link_collisions : int
        Air moves found colliding (``linked_ops.check_links``).
    apt : tuple of str or None
        ``(header, text)`` of its APT file (None: not written yet).
    machine : dict or None
        Its machine clearance entry (``machine_obstacle.operation_clearance``).
    """

    paths: list[PathResult]
    tool: str
    linked: tuple[Any, Any, list[dict[str, Any]]]
    link_collisions: int = -1
    apt: tuple[str, str] | None = None
    machine: dict[str, Any] | None = None


@dataclass
class RunMemo:
    """What a finishing run made, for the next run against less stock (module docstring).

    Attributes
    ----------
    design : tuple or None
        ``(key, impeller, surfaces, meshes, collision scene)`` of the last run; key:
        ``(spec, scene source, tessellation mm)``.
    stl : bytes or None
        ``scene.stl`` of those meshes.
    reach : set of tuple
        Keys (machine, tool, options) of the machine reach checks passed.
    part : Solid or None
        The last run's part solid of the machine check (None: none).
    operations : dict
        Operation name -> ``MadeOperation`` of the last run.
    margins : dict
        Path name -> ``(PathResult, machine-blocked posture indices)`` of the last run.
    plots : dict
        Path name -> ``(its PathResults, PNG bytes)`` of the last run (passage 0; the
        pieces of a pass share its name and its plot).
    reused : dict
        What this run took over: counts by kind (``"operations"``, ``"plots"``, ...).
    machine_valid : bool
        Whether this run's part is the last run's (its machine entries hold).
    """

    design: tuple[Any, ...] | None = None
    stl: bytes | None = None
    reach: set[tuple[str, ...]] = field(default_factory=set)
    part: Solid | None = None
    operations: dict[str, MadeOperation] = field(default_factory=dict)
    margins: dict[str, tuple[PathResult, list[int]]] = field(default_factory=dict)
    plots: dict[str, tuple[list[PathResult], bytes]] = field(default_factory=dict)
    reused: dict[str, int] = field(default_factory=dict)
    machine_valid: bool = False

    def start(self) -> None:
        """Start a run: nothing reused yet."""
        self.reused = {}

    def begin(self, part: Solid | None) -> None:
        """Plan with the machine check holding ``part`` (None: no machine check): the
        last run's machine entries hold when it is the same solid."""
        self.machine_valid = same_solid(self.part, part)
        self.part = part

    def count(self, kind: str, n: int = 1) -> None:
        """Add ``n`` to what this run reused of ``kind``."""
        self.reused[kind] = self.reused.get(kind, 0) + n

    def operation(self, op: str, paths: Sequence[PathResult], tool: str
                  ) -> MadeOperation | None:
        """The last run's ``op`` when it holds the same plans (the same objects, same
        order) with the same tool; else None."""
        made = self.operations.get(op)
        if (made is None or made.tool != tool
                or len(made.paths) != len(paths)
                or any(a is not b for a, b in zip(made.paths, paths, strict=True))):
            return None
        self.count("operations")
        return made

    def blocked(self, path: PathResult) -> list[int] | None:
        """The last run's machine-blocked postures of ``path`` when still valid."""
        known = self.margins.get(path.path.name)
        if not self.machine_valid or known is None or known[0] is not path:
            return None
        self.count("machine_paths")
        return known[1]

    def plot(self, name: str, paths: Sequence[PathResult]) -> bytes | None:
        """The last run's plot of pass ``name`` when it was of the same ``paths`` (the
        same plans), else None."""
        known = self.plots.get(name)
        if known is None or len(known[0]) != len(paths) or any(
                a is not b for a, b in zip(known[0], paths, strict=True)):
            return None
        self.count("plots")
        return known[1]


def same_solid(a: Solid | None, b: Solid | None) -> bool:
    """Whether two machine solids have the same mesh and convex pieces."""
    if a is None or b is None:
        return a is b
    return (np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
            and len(a.pieces) == len(b.pieces)
            and all(np.array_equal(p, q) for p, q in zip(a.pieces, b.pieces, strict=True)))
