"""Every passage's passes finished, the passes grouped by name and the groups planned
on the CPUs.

The planners (``plan.plan_finishing``, ``fillet_plan.plan_fillet``) finish the same
passes in every passage (``p<k>.<pass>``). What one pass's plan hands on goes only to
the same pass in a later passage: the eq. 7 remedy step of the previous passage
(``interference.StepHint``) and passage 0's clean plan, turned about the axis
(``turned_plan``). So the passes of one name form a group planned in passage order,
and the groups are independent of one another: ``finish_ordered`` runs them on
forked processes (``impeller_cam.processes.map_forked``, ``IMPELLER_CAM_THREADS``),
the costliest (most points) first, and puts the results back in the planners'
order. The results are those of planning every pass in that order in one process
(tested): the groups share nothing but the scene, whose answers do not depend on
what was asked before; what the scene counts or keeps (the machine model's query
counts and answers, ``MachineObstacle.fork_delta``) is handed back from the
children and added in the caller, and a plan memo (``plan_memo.PlanMemo``) is read in
the children and written in the caller, in the planners' order.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cam.finishing.interference import StepHint
from cam.finishing.options import FinishOptions
from cam.finishing.paths import CutterPath
from cam.finishing.pieces import cut_short_entry, finish_runs
from cam.finishing.plan import PathResult
from cam.finishing.turned_plan import turned_plan
from cam.tools import Tool
from geometry.surfaces import ImpellerSurfaces
from impeller_cam.processes import map_forked
from postproc.kinematics import Kinematics

if TYPE_CHECKING:
    from cam.collision import CollisionScene
    from cam.finishing.plan_memo import PlanMemo

__all__ = ["PassPlan", "finish_ordered", "pass_key"]

Plan = tuple[list[PathResult], NDArray[np.intp], list[str | None]]


@dataclass
class PassPlan:
    """What a group's run made of one pass.

    Attributes
    ----------
    how : str
        ``"recalled"`` (the memo's plan, taken by the caller from its own memo),
        ``"turned"`` (passage 0's plan turned about the axis), ``"planned"``, or
        ``"earlier"`` (planned, but the memo's plan leaves fewer postures out and is
        kept: ``_fewer_left_out``).
    plan : tuple or None
        ``(pieces, left-out postures, their causes)``; None for ``"recalled"`` and
        ``"earlier"``.
    """

    how: str
    plan: Plan | None = None


def pass_key(path: CutterPath) -> str:
    """The pass of ``path`` whatever its passage (its name without ``p<k>.``)."""
    return path.name.split(".", 1)[1]


def _plan_group(paths: Sequence[CutterPath], tool: Tool, kins: Kinematics,
                scene: CollisionScene, options: FinishOptions,
                surfaces: ImpellerSurfaces | None, memo: PlanMemo | None
                ) -> list[PassPlan]:
    """The passes of one name, in passage order (``finish_ordered``); the memo is only
    read."""
    out: list[PassPlan] = []
    hint: StepHint | None = None
    first: tuple[CutterPath, list[PathResult]] | None = None  # passage 0's clean plan
    for path in paths:
        entry: PassPlan | None = None
        plan: Plan | None = None
        if memo is not None:
            plan = memo.lookup(tool.name, path.name)
            entry = None if plan is None else PassPlan("recalled")
        if plan is None and first is not None and surfaces is not None:
            turned = turned_plan(first[1], first[0], path, surfaces.spec.pitch, tool, kins,
                                 scene, options, surfaces)
            if turned is not None:
                plan = (turned, np.zeros(0, dtype=np.intp), [])
                entry = PassPlan("turned", plan)
        if plan is None:
            causes: list[str | None] = []
            plan = (*finish_runs(path, tool, kins, scene, options, surfaces, hint=hint,
                                 causes=causes), causes)
            entry = PassPlan("planned", plan)
            earlier = None if memo is None else memo.plans.get((tool.name, path.name))
            if _fewer_left_out(plan, earlier) is earlier:
                plan, entry = earlier, PassPlan("earlier")
        assert entry is not None and plan is not None
        out.append(entry)
        pieces, lost, _ = plan
        hint = pieces[0].step_hint if len(pieces) == 1 and not lost.size else None
        if path.passage == 0 and pieces and not lost.size:
            first = (path, pieces)
    return out


def finish_ordered(ordered: Sequence[CutterPath], tool: Tool, kins: Kinematics,
                   scene: CollisionScene, options: FinishOptions,
                   surfaces: ImpellerSurfaces | None, memo: PlanMemo | None = None,
                   progress: Callable[[int, int, str], None] | None = None,
                   workers: int | None = None
                   ) -> tuple[list[PathResult], list[dict[str, Any]]]:
    """Every pass of ``ordered`` finished (``finish_runs``): the clean pieces in order and
    finish.json's ``cut_short`` entries.

    The same pass in the previous passage hands on its eq. 7 remedy step
    (``interference.StepHint``), tried first and proven before it is taken, so the
    results are those without it, with fewer checks. A pass that passage 0 planned
    clean (nothing left out) is, in the other passages, first passage 0's plan turned
    about the axis and checked again in full (``turned_plan``); it is planned only
    when that fails a check. With a ``memo``
    (``plan_memo.PlanMemo``) a pass's recorded plan is reused and new plans are
    recorded, each with the causes of its left-out postures; a pass planned anew
    keeps its recorded plan when that leaves fewer postures out (``_fewer_left_out``).

    The passes of one name are planned in order; the names are planned on up to
    ``workers`` processes (default: ``impeller_cam.threads.default_threads()``), with
    the results of one process (module docstring). ``progress(done, total, name)`` is
    called as each name's passes are done.
    """
    groups: dict[str, list[int]] = {}
    for i, path in enumerate(ordered):
        groups.setdefault(pass_key(path), []).append(i)
    members = list(groups.values())

    def job(g: int) -> list[PassPlan]:
        return _plan_group([ordered[i] for i in members[g]], tool, kins, scene, options,
                           surfaces, memo)

    finished = 0

    def done(g: int, plans: list[PassPlan]) -> None:
        nonlocal finished
        finished += len(members[g])
        if progress is not None:
            progress(finished, len(ordered), ordered[members[g][-1]].name)

    costs = [float(sum(len(ordered[i]) for i in m)) for m in members]
    grouped = map_forked(job, len(members), workers, costs, done, keep=scene)
    entries: list[PassPlan | None] = [None] * len(ordered)
    for m, plans in zip(members, grouped, strict=True):
        for i, planned in zip(m, plans, strict=True):
            entries[i] = planned
    results: list[PathResult] = []
    cut_short: list[dict[str, Any]] = []
    for path, entry in zip(ordered, entries, strict=True):
        assert entry is not None
        if entry.how in ("recalled", "earlier"):
            assert memo is not None
            plan = memo.recall(tool.name, path.name) if entry.how == "recalled" \
                else memo.plans[(tool.name, path.name)]
            assert plan is not None
        else:
            assert entry.plan is not None
            plan = entry.plan
        if memo is not None and entry.how != "recalled":
            memo.record(tool.name, path.name, plan)
        pieces, lost, why = plan
        results += pieces
        if lost.size:
            cut_short.append(cut_short_entry(path, lost, why))
    return results, cut_short


def _fewer_left_out(new: Plan, earlier: Any) -> Plan:
    """A pass's new plan, or its ``earlier`` one (a memo's: planned against the rough
    stock) when that leaves fewer postures out.

    The chain plans a pass again after the rest operation, which only removes
    material: the earlier plan's pieces stay clean against the smaller stock, so
    planning anew never leaves more out than before (on the splitter a junction pass
    planned against the rest stock left 8 postures out where its rough-stock plan
    left 5).
    """
    if earlier is not None and len(earlier[1]) < len(new[1]):
        return earlier  # type: ignore[no-any-return]
    return new
