"""``CollisionScene``: posture and motion checks of a tool against named meshes.

The scene holds, per role (``"hub"``, ``"pressure"``, ``"blade3"``, ...), an fcl
``BVHModel`` (OBBRSS) of the mesh, a grid of lower bounds of the distance to it
(all grids on one frame; the scene's grid is their minimum) and its triangles in
a bounding-volume hierarchy (numba). Each tool part is covered by spheres on its
axis. A check of ``n`` postures runs in stages, each deciding what it can:

1. **Whole scene** (numba, all postures, one kernel per part,
   ``exact_phase.classify_part``): spheres that clear the lower bound of the
   distance to the whole scene (coarse grid, then the role mask or the fine
   grid) are clear of every role; a posture with none left is clear.
2. **Role grids + exact sphere tests** (same kernel, the remaining spheres,
   role by role in order, only the roles in the sphere's mask): each sphere
   is tested against the role's grids, then against the exact distance to the
   role's triangles near it. The pair (part, role) is *clear* (every sphere
   clear), a *definite hit* (a surface point strictly inside the true part,
   whose surface piece also reaches outside the part mesh), or *undecided*.
   A definite hit ends the posture; postures settled by a definite hit of an
   earlier part are not classified again.
3. **fcl** (Python loop, only postures whose first non-clear pair in the order
   cutter, shank, holder x roles is undecided): ``fcl.collide`` on the
   undecided pairs in that order until the first contact.

A plain loop over every posture, part and role with ``fcl.collide`` (see
``reference.plain_fcl_check``) gives identical answers: pairs skipped here are
proven contact-free, definite hits are contacts fcl must report.

Contact semantics are fcl's for meshes: two *surfaces* intersect or touch. A
part buried entirely inside a closed scene mesh without crossing its surface is
not a contact (it cannot get there without crossing it; ``check_motion``
catches the crossing within its stated bound).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import fcl
import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from cam.collision.broad_phase import (
    grid_frame,
    outer_grid,
    surface_grid,
)
from cam.collision.clearance import body_clearance, settle_undecided
from cam.collision.distance_grid import DistanceGrid, RoleMask
from cam.collision.exact_phase import HIT, SceneArrays, TriangleSet, classify_part
from cam.collision.fcl_objects import InOrder, RoleObjects, check_meshes
from cam.collision.narrow_phase import first_contacts
from cam.collision.postures import (
    motion_bound,
    rotations_to,
    subdivide_motion,
    validate_postures,
)
from cam.collision.tool_mesh import (
    DEFAULT_ARC_STEP,
    DEFAULT_SECTIONS,
    PART_NAMES,
    bvh_model,
    concatenate,
)
from cam.collision.tool_model import ToolModel, build_tool_model
from cam.tools import Tool
from impeller_cam.errors import InputError
from impeller_cam.threads import run_on_threads

#: Safety margin of the broad phase over fcl's own contact tolerance, mm.
BROAD_MARGIN = 1e-4
#: Distance up to which the role masks list the roles near a grid node, mm.
_MASK_LIMIT = 8.0


@dataclass
class PostureReport:
    """Answers for ``n`` postures (or ``n`` motion segments).

    Attributes
    ----------
    collides : (n,) bool
        Some checked tool part touches or crosses a scene surface.
    part : (n,) int8
        First part found in contact in the order cutter (0), shank (1),
        holder (2); -1 for none.
    hit_role : list of (str or None), length n
        The scene role that part touched first (roles in scene order).
    clearance : (n,) float64
        Distance of the shank and holder meshes (cutter excluded) to the scene,
        mm; 0 in contact. Exact (fcl distance of the meshes) up to
        ``clearance_cap``; above it a guaranteed lower bound (>= cap). NaN when
        clearance was not asked for or the tool has neither shank nor holder.
    bound : float
        For motion checks: the tool between sub-samples may come up to this
        much closer to the scene than reported, mm (0 for posture checks).
    checks : dict of str to int
        Counters of the queries run (broad phase, exact phase, fcl).
    """

    collides: NDArray[np.bool_]
    part: NDArray[np.int8]
    hit_role: list[str | None]
    clearance: NDArray[np.float64]
    bound: float = 0.0
    checks: dict[str, int] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.collides)

    def blocked(self, min_clearance: float = 0.0) -> NDArray[np.bool_]:
        """In contact, or shank/holder closer than ``min_clearance``.

        Roughing's "nothing closer than eta": check with ``cutter_allowance=-eta``
        and use ``blocked(eta)``. Needs the clearance when ``min_clearance > 0``.

        Parameters
        ----------
        min_clearance : float
            Smallest shank/holder clearance accepted, mm (0: contact only).

        Returns
        -------
        (n,) bool
        """
        if min_clearance <= 0:
            return self.collides.copy()
        if np.isnan(self.clearance).any():
            raise ValueError("blocked(min_clearance > 0) needs a report with clearance")
        return self.collides | (self.clearance < min_clearance)


class CollisionScene:
    """Named triangle meshes (roles) against which tool postures are checked.

    Parameters
    ----------
    meshes : mapping of str to trimesh.Trimesh
        Scene meshes by role, in the workpiece frame, mm. The role order is the
        order in which contacts are reported.
    sample_spacing : float
        Broad-phase surface sample spacing, mm; the covering radius is at most
        ``sample_spacing / sqrt(3)``.
    grid_spacing : float
        Spacing of the broad-phase distance grids, mm. Smaller decides more
        postures without fcl but costs memory (one float32 per node and role).
    grid_margin : float
        The grids reach this far beyond the scene's bounding box, mm (beyond
        it, the distance to the bounding box is the bound).
    max_reach : float
        Covering spheres larger than this skip the exact test (fcl decides), mm
        (default: none do).
    sections : int
        Sections of the revolved tool meshes (see ``tool_mesh``).
    arc_step_deg : float
        Largest angular step of circumscribed ball/corner arcs, degrees.
    slack : float
        Largest excess of a broad-phase sphere over the part radius, mm.
    """

    def __init__(
        self,
        meshes: Mapping[str, trimesh.Trimesh],
        *,
        sample_spacing: float = 0.5,
        grid_spacing: float = 1.0,
        grid_margin: float = 10.0,
        max_reach: float = math.inf,
        sections: int = DEFAULT_SECTIONS,
        arc_step_deg: float = math.degrees(DEFAULT_ARC_STEP),
        slack: float = 0.25,
    ) -> None:
        check_meshes(meshes)
        if not (sample_spacing > 0 and grid_spacing > 0 and slack > 0 and arc_step_deg > 0):
            raise InputError(
                "sample_spacing, grid_spacing, slack and arc_step_deg must be positive",
                field="sample_spacing/grid_spacing/slack/arc_step_deg",
                value=(sample_spacing, grid_spacing, slack, arc_step_deg),
            )
        self.roles: tuple[str, ...] = tuple(meshes)
        self.meshes = {role: meshes[role] for role in self.roles}
        self.sections = int(sections)
        self.arc_step = math.radians(arc_step_deg)
        self.slack = float(slack)
        #: fcl object per role (built on first use: the exact kernel settles most pairs)
        self.objects = RoleObjects(self.meshes)
        self.triangles = {
            role: TriangleSet(m.vertices, m.faces) for role, m in self.meshes.items()
        }
        merged = concatenate(list(self.meshes.values()))
        origin, shape = grid_frame(merged.vertices, grid_spacing, grid_margin)
        # the roles' grids and the outer grid are independent and their kernels release
        # the GIL: built on threads (nine_blade's design scene 5.5 -> 2.9 s of wall time
        # on 2 cores, the same grids)
        jobs: list[Callable[[], DistanceGrid]] = [
            partial(surface_grid, self.triangles[role].bvh, sample_spacing, origin, shape,
                    grid_spacing)
            for role in self.roles
        ]
        #: the whole scene on a coarse grid far beyond ``grid_margin`` (clearance bounds)
        jobs.append(partial(outer_grid, np.concatenate([self.triangles[r].bvh.tris
                                                        for r in self.roles])))
        sizes = [len(self.triangles[role].bvh.tris) for role in self.roles]
        built = run_on_threads(jobs, costs=[*sizes, sum(sizes) / 8])  # outer: 4 mm spacing
        self.grids = dict(zip(self.roles, built[:-1], strict=True))
        self.outer = built[-1]
        self.whole = DistanceGrid.minimum(list(self.grids.values()))
        self.role_mask = (
            RoleMask(list(self.grids.values()), min(_MASK_LIMIT, grid_margin))
            if len(self.roles) <= 62
            else None
        )
        self.max_reach = float(max_reach)
        self.arrays = SceneArrays.build(
            [self.grids[r] for r in self.roles],
            self.whole,
            self.role_mask,
            [self.triangles[r] for r in self.roles],
        )
        self._merged = merged
        self._whole_object: fcl.CollisionObject | None = None
        self._tools: dict[tuple[Tool, float], ToolModel] = {}

    @property
    def whole_object(self) -> fcl.CollisionObject:
        """fcl object of all scene meshes merged (clearance queries; built on first use)."""
        if self._whole_object is None and len(self.roles) == 1:
            # one role: its mesh is the merged one (the same vertices and faces), so
            # its fcl object is shared rather than its BVH built a second time
            self._whole_object = self.objects[self.roles[0]]
        if self._whole_object is None:
            merged = self._merged
            self._whole_object = fcl.CollisionObject(
                bvh_model(merged.vertices, merged.faces), fcl.Transform()
            )
        return self._whole_object

    # -- what is built on first use (``impeller_cam.processes``: a fork inherits it) --

    def built(self) -> tuple[frozenset[str], bool, frozenset[tuple[Tool, float]]]:
        """What this scene has built on first use so far.

        Returns
        -------
        roles : frozenset of str
            The roles whose fcl objects are built.
        whole : bool
            Whether the merged object is.
        tools : frozenset of (Tool, float)
            The tool models, by tool and cutter offset (mm).
        """
        return (frozenset(self.objects.built), self._whole_object is not None,
                frozenset(self._tools))

    def build(self, roles: Iterable[str], whole: bool,
              tools: Iterable[tuple[Tool, float]]) -> None:
        """Build here what ``built`` names (what a forked process built).

        Parameters
        ----------
        roles : iterable of str
            Roles whose fcl objects to build.
        whole : bool
            Build the merged object.
        tools : iterable of (Tool, float)
            Tool models to build, by tool and cutter offset (mm).
        """
        for role in roles:
            self.objects[role]  # noqa: B018 (built on access)
        if whole:
            self.whole_object  # noqa: B018
        for tool, offset in tools:
            self.tool_model(tool, offset)

    def fork_prepare(self) -> None:
        """Before a fork: build the fcl objects of the in-process stock's mesh (a
        wrapper's ``stock`` scene), which the forked processes would each build, and
        this one again after them. Its objects are asked for wherever material is
        near (every chain run builds them); the design's only where the exact phase
        cannot decide (often never), so those are left to be built on first use
        (and built here after a fork that did: ``merge_fork_delta``)."""
        for stock in scenes_within(self, via="stock"):
            stock.build(stock.roles, False, ())

    def fork_mark(self) -> Any:
        """What the scenes within this one (``scenes_within``) have built, now (the
        fork protocol of ``impeller_cam.processes.map_forked``).

        Returns
        -------
        list
            ``built()`` of each scene within.
        """
        return [scene.built() for scene in scenes_within(self)]

    def fork_delta(self, mark: Any) -> Any:
        """What the scenes within this one built since ``mark``.

        Parameters
        ----------
        mark : list
            ``fork_mark()`` as it was.

        Returns
        -------
        list
            Per scene, what ``build`` takes (picklable).
        """
        new = []
        for scene, (roles0, whole0, tools0) in zip(scenes_within(self), mark, strict=True):
            roles, whole, tools = scene.built()
            new.append((roles - roles0, whole and not whole0, tools - tools0))
        return new

    def merge_fork_delta(self, delta: Any) -> None:
        """Build here what a forked process built (the next fork inherits it).

        Parameters
        ----------
        delta : list
            That process's ``fork_delta``.
        """
        for scene, (roles, whole, tools) in zip(scenes_within(self), delta, strict=True):
            scene.build(roles, whole, tools)

    # -- tool models ---------------------------------------------------------------

    def tool_model(self, tool: Tool, cutter_offset: float = 0.0) -> ToolModel:
        """The (cached) meshes, fcl objects and sphere covers of a tool.

        Parameters
        ----------
        tool : Tool
            The tool (mm).
        cutter_offset : float
            Signed offset of the cutter only, mm (> 0 grows).

        Returns
        -------
        ToolModel
        """
        key = (tool, float(cutter_offset))
        if key not in self._tools:
            self._tools[key] = build_tool_model(tool, float(cutter_offset), self.sections,
                                                self.arc_step, self.slack)
        return self._tools[key]

    # -- checks --------------------------------------------------------------------

    def check_postures(
        self,
        tool: Tool,
        tip: ArrayLike,
        axis: ArrayLike,
        *,
        parts: Collection[str] = PART_NAMES,
        cutter_allowance: float = 0.0,
        cutter_roles: Collection[str] | None = None,
        clearance: bool = True,
        clearance_cap: float = math.inf,
        clearance_limits: Sequence[float] = (),
    ) -> PostureReport:
        """Check ``n`` tool postures against the scene.

        Parameters
        ----------
        tool : Tool
            The tool (cutter, shank, holder; mm).
        tip, axis : (n, 3) array-like
            Tool tips (mm) and unit axes in the scene frame.
        parts : collection of str
            Parts to check for contact: any of ``"cutter"``, ``"shank"``,
            ``"holder"`` (parts the tool lacks are skipped).
        cutter_allowance : float
            The cutter is checked shrunk by this much, mm (negative grows it).
            Finishing: a small positive allowance (above the scene tessellation
            error) lets the ball touch the surface it cuts. Roughing: ``-eta``
            keeps the cutter ``eta`` away from the design surfaces.
        cutter_roles : collection of str, optional
            Roles the cutter is checked against (default: all). Shank and
            holder are always checked against all roles.
        clearance : bool
            Compute the shank+holder clearance.
        clearance_cap : float
            Clearances above this are reported as a lower bound (>= cap) from
            the broad phase instead of an exact distance, mm.
        clearance_limits : sequence of float
            Limits the caller compares the clearance with, mm: a clearance
            within ``clearance.BAND`` (1e-6 mm) of one is fcl's own distance,
            so such comparisons are exactly those of fcl's values (elsewhere
            the exact kernel agrees with fcl to rounding, see docs/collision.md).

        Returns
        -------
        PostureReport
        """
        tip_a, axis_a = validate_postures(tip, axis)
        unknown = set(parts) - set(PART_NAMES)
        if unknown:
            raise InputError(
                "unknown tool part", field="parts", value=sorted(unknown), accepted=str(PART_NAMES)
            )
        if not math.isfinite(cutter_allowance):
            raise InputError("cutter_allowance must be finite", field="cutter_allowance")
        if not clearance_cap >= 0:
            raise InputError(
                "clearance_cap must be >= 0", field="clearance_cap", value=clearance_cap,
                accepted="a distance >= 0 mm or inf",
            )
        roles_for_cutter = self._roles(cutter_roles)
        model = self.tool_model(tool, -float(cutter_allowance))
        n = len(tip_a)
        rot = rotations_to(axis_a)
        active = [p for p in PART_NAMES if p in parts and p in model.parts]
        state = np.zeros((n, len(PART_NAMES), len(self.roles)), dtype=np.int8)  # CLEAR
        settled = np.zeros(n, dtype=bool)  # a definite hit earlier in the order decides
        for p in active:
            todo = np.flatnonzero(~settled)
            if not todo.size:
                break
            code = PART_NAMES.index(p)
            heights, radii = model.spheres[p]
            roles = roles_for_cutter if p == "cutter" else self.roles
            role_on = np.array([r in roles for r in self.roles])
            allow_hit = np.array(
                [self.triangles[r].smallest_component > model.size[p] + BROAD_MARGIN
                 for r in self.roles]
            )
            result = classify_part(
                self.arrays,
                tip_a[todo],
                axis_a[todo],
                heights,
                radii,
                model.inner[p],
                model.parts[p].profile,
                model.parts[p].arc_excess,
                role_on,
                allow_hit,
                margin=BROAD_MARGIN,
                max_reach=self.max_reach,
            )
            state[todo, code, :] = result
            settled[todo[(result == HIT).any(axis=1)]] = True
        kernel_pairs = settle_undecided(self, model, tip_a, rot, state)
        part_objects = [model.objects.get(name) for name in PART_NAMES]
        role_objects = InOrder(self.objects, self.roles)
        collides, part_hit, role_hit, calls = first_contacts(
            part_objects, role_objects, tip_a, rot, state
        )
        clear = np.full(n, np.nan)
        if clearance and model.clear_object is not None and model.clear_spheres is not None:
            clear, counts = body_clearance(self, model, tip_a, axis_a, rot, part_hit,
                                           clearance_cap, clearance_limits)
            calls.update(counts)
        calls["kernel_pairs"] = kernel_pairs
        hit_role = [None if r < 0 else self.roles[r] for r in role_hit]
        return PostureReport(collides, part_hit, hit_role, clear, 0.0, calls)

    def check_motion(
        self,
        tool: Tool,
        tip: ArrayLike,
        axis: ArrayLike,
        *,
        max_step_mm: float,
        max_step_deg: float,
        parts: Collection[str] = PART_NAMES,
        cutter_allowance: float = 0.0,
        cutter_roles: Collection[str] | None = None,
        clearance: bool = True,
        clearance_cap: float = math.inf,
        clearance_limits: Sequence[float] = (),
        ends: PostureReport | None = None,
    ) -> PostureReport:
        """Check the motion between consecutive postures by subdivision.

        The tip moves linearly and the axis turns on the great circle between
        postures; sub-samples are at most ``max_step_mm`` and ``max_step_deg``
        apart and are checked with ``check_postures`` (same keyword options).

        Parameters
        ----------
        tool : Tool
            The tool (cutter, shank, holder; mm).
        tip, axis : (n, 3) array-like
            Tool tips (mm) and unit axes in the scene frame, n >= 2.
        max_step_mm : float
            Largest tip move between sub-samples.
        max_step_deg : float
            Largest axis turn between sub-samples.
        parts, cutter_allowance, cutter_roles, clearance, clearance_cap, clearance_limits
            As ``check_postures`` (lengths in mm).
        ends : PostureReport, optional
            ``check_postures``' report on the same postures (same tool, parts, roles,
            allowance; ``clearance_cap`` at least this one): only the sub-samples
            between the postures are then checked.

        Returns
        -------
        PostureReport
            ``n - 1`` entries, one per segment ``i -> i+1`` (both end postures
            included): the first contact along the segment and the minimum
            clearance over its sub-samples. ``bound`` (mm) is the largest
            approach of the tool between sub-samples that can be missed:
            ``max_step_mm / 2 + 2 L sin(max_step / 4)``, L the largest distance
            of a tool point from the tip. A segment with no contact and
            clearance above ``bound`` is contact-free for shank and holder; the
            cutter is contact-free if also checked with ``cutter_allowance``
            lowered by ``bound``.
        """
        tip_a, axis_a = validate_postures(tip, axis)
        if len(tip_a) < 2:
            raise InputError("a motion needs at least two postures", field="tip", value=len(tip_a))
        step_rad = math.radians(max_step_deg)
        sub_tip, sub_axis, starts = subdivide_motion(tip_a, axis_a, max_step_mm, step_rad)
        between = np.ones(len(sub_tip), dtype=bool)
        if ends is not None:
            if len(ends) != len(tip_a):
                raise InputError("ends must report on the postures", field="ends")
            between[starts] = False
        report = self.check_postures(
            tool,
            sub_tip[between],
            sub_axis[between],
            parts=parts,
            cutter_allowance=cutter_allowance,
            cutter_roles=cutter_roles,
            clearance=clearance,
            clearance_cap=clearance_cap,
            clearance_limits=clearance_limits,
        )
        if ends is not None:
            report = _merged(report, between, ends, starts)
        model = self.tool_model(tool, -float(cutter_allowance))
        first = starts[:-1]
        last = starts[1:]
        index = np.arange(len(sub_tip))
        hit_index = np.where(report.collides, index, len(sub_tip))
        first_hit = np.minimum(np.minimum.reduceat(hit_index, first), hit_index[last])
        collides = first_hit < len(sub_tip)
        safe = np.where(collides, first_hit, 0)
        part = np.where(collides, report.part[safe], -1).astype(np.int8)
        roles = [
            report.hit_role[int(i)] if c else None
            for i, c in zip(safe, collides, strict=True)
        ]
        clear = np.minimum(np.minimum.reduceat(report.clearance, first), report.clearance[last])
        bound = motion_bound(model.reach, max_step_mm, step_rad)
        checks = dict(report.checks, substeps=len(sub_tip))
        return PostureReport(collides, part, roles, clear, bound, checks)

    # -- internals -----------------------------------------------------------------

    def _roles(self, roles: Collection[str] | None) -> tuple[str, ...]:
        if roles is None:
            return self.roles
        unknown = set(roles) - set(self.roles)
        if unknown:
            raise InputError(
                "unknown scene role",
                field="cutter_roles",
                value=sorted(unknown),
                accepted=", ".join(self.roles),
            )
        return tuple(r for r in self.roles if r in roles)


def _merged(inner: PostureReport, between: NDArray[np.bool_], ends: PostureReport,
            starts: NDArray[np.int64]) -> PostureReport:
    """One report of all sub-samples: ``inner`` where ``between``, ``ends`` at ``starts``."""
    m = len(between)
    collides, part, clear = np.zeros(m, dtype=bool), np.full(m, -1, np.int8), np.full(m, np.nan)
    roles = np.full(m, None, dtype=object)
    for index, source in ((np.flatnonzero(between), inner), (starts, ends)):
        collides[index], part[index] = source.collides, source.part
        clear[index], roles[index] = source.clearance, np.array(source.hit_role, dtype=object)
    return PostureReport(collides, part, roles.tolist(), clear, 0.0, inner.checks)


def scenes_within(scene: Any, via: str | None = None) -> list[CollisionScene]:
    """The collision scenes that hold meshes within ``scene`` (itself, or what its
    wrappers wrap: ``inner``, ``design``, the in-process ``stock``), each once, in a
    fixed order; ``via``: only those reached through that attribute."""
    found: list[CollisionScene] = []
    todo: list[tuple[Any, str | None]] = [(scene, None)]
    while todo:
        item, name = todo.pop(0)
        own = vars(item)
        if "objects" in own and (via is None or name == via) \
                and not any(item is f for f in found):
            found.append(item)
        todo += [(own[n], n) for n in ("inner", "design", "stock")
                 if own.get(n) is not None]
    return found
