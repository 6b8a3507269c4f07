"""The cutter allowance only on the faces a pass drives.

The finishing check shrinks the cutter by ``cutter_allowance_mm`` (0.05 mm) so that
the ball may touch the surfaces it cuts: a ball tangent to a concave surface dips
into its tessellation by up to the chordal deflection, and a ball of the fillet's
radius lies in the tessellated fillet along a whole arc. Against every other face
that allowance only lets the tool cut into the part: no path geometry keeps the
cutter off a face the pass does not drive. The splitter's outlet: the flutes of the
last posture of a pressure-side blade pass reached 0.048 mm into the cut trailing
edge next to the tip, the posture was accepted at 0.05, and the controller's joint
interpolation made it 0.052 mm, a gouge over the verifier's 0.05 mm; the flutes of
the topmost passes reached up to 0.047 mm into a wall at its tip corner, past the tip
face (docs/finishing.md).

``DrivenScene`` wraps a pass's scene: the cutter is checked shrunk by the cutter
allowance against the roles the pass drives (``driven_roles``) and by the smaller
``undriven_allowance_mm`` (0.02 mm, the scene's tessellation tolerance: a tool
tangent to a driven face touches a neighbouring face only along their shared edge,
whose vertices lie on both) against all others, in a second, cutter-only check of
the design scene. Shank and holder are checked as before.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from cam.collision.scene_wrapper import SceneWrapper
from cam.collision.tool_mesh import PART_NAMES

if TYPE_CHECKING:
    from cam.collision import CollisionScene
    from cam.collision.scene import PostureReport
    from cam.finishing.options import FinishOptions
    from cam.finishing.paths import CutterPath
    from cam.tools import Tool

__all__ = ["DrivenScene", "design_scene", "driven_roles", "driven_scene"]

#: Blade-side roles by ``Wall.side`` (+1 pressure, -1 suction).
_SIDES = {1: "pressure", -1: "suction"}
#: Roles of the blade edges (the solid's; ``"edges"``: the closed-form scene's).
_EDGES = ("leading_edge", "trailing_edge", "edges")


def driven_roles(path: CutterPath) -> tuple[str, ...] | None:
    """The scene roles a pass's ball is meant to touch.

    Junction paths: their blade side, the hub and the fillet; blade passes: their
    side and the fillet (the lowest passes run into it); hub passes: the hub and the
    fillets; fillet passes (which go round the edges): the fillet, the hub, both
    sides and the edges; edge passes: the edge they go round (named in the path),
    both sides and the fillet. Never the tip faces, the hub body's other faces, and
    for junction and blade passes the edges they end at.

    Parameters
    ----------
    path : CutterPath
        A finishing pass.

    Returns
    -------
    tuple of str or None
        Role names (those of the solid scene, ``cam.finishing.scene``); None for an
        operation this module does not know (checked as before, every role at the
        cutter allowance).
    """
    side = None if path.wall is None else _SIDES.get(path.wall.side)
    sides: tuple[str, ...] = () if side is None else (side,)
    if path.operation == "junction":
        return (*sides, "hub", "fillet")
    if path.operation == "blade":
        return (*sides, "fillet")
    if path.operation == "hub":
        return ("hub", "fillet")
    if path.operation == "fillet":
        return ("fillet", "hub", "pressure", "suction", *_EDGES)
    if path.operation == "edge":
        edges = tuple(e for e in _EDGES if e in path.name.split(".")) or _EDGES
        return (*edges, "pressure", "suction", "fillet")
    return None


def design_scene(scene: Any) -> CollisionScene:
    """The design's ``CollisionScene`` inside the finishing wrappers (machine
    obstacle, in-process stock, ``DrivenScene``)."""
    from cam.collision import CollisionScene
    from cam.finishing.machine_obstacle import MachineObstacle
    from cam.finishing.stock_clearance import StockScene

    while not isinstance(scene, CollisionScene):
        if isinstance(scene, MachineObstacle | DrivenScene):
            scene = scene.inner
        elif isinstance(scene, StockScene):
            scene = scene.design
        else:
            raise TypeError(f"not a finishing scene: {type(scene).__name__}")
    return scene


class DrivenScene(SceneWrapper):
    """A scene whose cutter allowance applies to the driven roles only.

    Parameters
    ----------
    inner : scene
        The pass's scene (``CollisionScene`` or a finishing wrapper of one); it
        answers everything but the cutter's contacts with the other roles.
    driven : collection of str
        Roles the cutter is checked against at the caller's ``cutter_allowance``.
    undriven_allowance : float
        The cutter is checked shrunk by at most this much against every other role
        of the design scene, mm (>= 0).
    """

    def __init__(self, inner: Any, driven: Collection[str], undriven_allowance: float) -> None:
        self.inner = inner
        self.design = design_scene(inner)
        self.driven = tuple(r for r in self.design.roles if r in set(driven))
        self.others = tuple(r for r in self.design.roles if r not in set(driven))
        self.undriven_allowance = float(undriven_allowance)

    def _split(self, parts: Collection[str], cutter_allowance: float,
               cutter_roles: Collection[str] | None
               ) -> tuple[tuple[str, ...] | None, tuple[str, ...], float]:
        """Roles of the first (as asked) and second (cutter only) check; the
        second's allowance. No second check: an empty tuple."""
        asked = set(self.design.roles if cutter_roles is None else cutter_roles)
        allowance = min(cutter_allowance, self.undriven_allowance)
        others = tuple(r for r in self.others if r in asked)
        if "cutter" not in parts or allowance >= cutter_allowance or not others:
            return (None if cutter_roles is None else tuple(cutter_roles)), (), allowance
        return tuple(r for r in self.driven if r in asked), others, allowance

    def check_postures(self, tool: Tool, tip: ArrayLike, axis: ArrayLike, *,
                       parts: Collection[str] = PART_NAMES, cutter_allowance: float = 0.0,
                       cutter_roles: Collection[str] | None = None, clearance: bool = True,
                       clearance_cap: float = math.inf,
                       clearance_limits: Sequence[float] = ()) -> PostureReport:
        """``CollisionScene.check_postures``; the cutter also touches when it comes
        within ``cutter_allowance - undriven_allowance`` of a role not driven."""
        first_roles, others, allowance = self._split(parts, cutter_allowance, cutter_roles)
        first = self.inner.check_postures(
            tool, tip, axis, parts=parts, cutter_allowance=cutter_allowance,
            cutter_roles=first_roles, clearance=clearance, clearance_cap=clearance_cap,
            clearance_limits=clearance_limits)
        if not others:
            return first
        second = self.design.check_postures(tool, tip, axis, parts=("cutter",),
                                            cutter_allowance=allowance,
                                            cutter_roles=others, clearance=False)
        return _combined(first, second)

    def check_motion(self, tool: Tool, tip: ArrayLike, axis: ArrayLike, *,
                     max_step_mm: float, max_step_deg: float,
                     parts: Collection[str] = PART_NAMES, cutter_allowance: float = 0.0,
                     cutter_roles: Collection[str] | None = None, clearance: bool = True,
                     clearance_cap: float = math.inf,
                     clearance_limits: Sequence[float] = (),
                     ends: PostureReport | None = None) -> PostureReport:
        """``CollisionScene.check_motion`` with the rule of ``check_postures``
        (``ends``: this scene's posture check, skipped by the first check only)."""
        first_roles, others, allowance = self._split(parts, cutter_allowance, cutter_roles)
        first = self.inner.check_motion(
            tool, tip, axis, max_step_mm=max_step_mm, max_step_deg=max_step_deg,
            parts=parts, cutter_allowance=cutter_allowance, cutter_roles=first_roles,
            clearance=clearance, clearance_cap=clearance_cap,
            clearance_limits=clearance_limits, ends=ends)
        if not others:
            return first
        second = self.design.check_motion(tool, tip, axis, max_step_mm=max_step_mm,
                                          max_step_deg=max_step_deg, parts=("cutter",),
                                          cutter_allowance=allowance, cutter_roles=others,
                                          clearance=False)
        return _combined(first, second)


def _combined(first: PostureReport, second: PostureReport) -> PostureReport:
    """Contacts of either report (the first's where both), the first's clearances."""
    from cam.collision.scene import PostureReport

    own = np.asarray(first.collides, dtype=bool)
    other = np.asarray(second.collides, dtype=bool)
    part = np.where(own, first.part, second.part).astype(np.int8)
    roles = [a if o else b for a, b, o in zip(first.hit_role, second.hit_role, own,
                                              strict=True)]
    checks = dict(first.checks)
    for key, value in second.checks.items():
        checks[f"undriven_{key}"] = value
    return PostureReport(own | other, part, roles, first.clearance,
                         max(first.bound, second.bound), checks)


def driven_scene(scene: Any, path: CutterPath, options: FinishOptions) -> Any:
    """``scene`` for ``path``: a ``DrivenScene`` when the pass's driven roles are
    known and the undriven allowance is below the cutter allowance, else ``scene``
    itself (also when it already is the pass's ``DrivenScene``)."""
    roles = driven_roles(path)
    base = scene.inner if isinstance(scene, DrivenScene) else scene
    if roles is None or options.undriven_allowance_mm >= options.cutter_allowance_mm:
        return base
    if isinstance(scene, DrivenScene) and scene.driven == tuple(
            r for r in scene.design.roles if r in set(roles)):
        return scene
    return DrivenScene(base, roles, options.undriven_allowance_mm)
