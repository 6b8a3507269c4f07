"""Plans of finishing passes kept from one run of the planner for the next.

The chain's rest operation (``cam.run.rest``) plans finishing twice: once against the
rough stock, and again, after the rest operation, against the stock it left -- but only
the passes the rest operation was for (those with postures the rough stock blocked).
Every other pass keeps its first plan: the rest operation only removes material, so a
plan clean against the rough stock is clean against the rest stock (what the run made
from the plans is reused the same way where they are kept, ``run_memo``).

``PlanMemo`` is that store: the planners (``plan.plan_finishing``,
``edge_plan.plan_edges``, ``fillet_plan.plan_fillet``) ``recall`` a pass's plan by its
tool and name (``p<k>.<operation>...``) and ``record`` what they plan. ``again(names)``
is the memo for the next run: the same plans, ``names`` planned anew. It carries the
``run_memo.RunMemo`` too: what ``run_finish`` made from the plans (scene, links, files),
taken over by the next run where its plans are the same.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from cam.finishing.run_memo import RunMemo

__all__ = ["PlanMemo"]


@dataclass
class PlanMemo:
    """Pass plans by ``(tool name, pass name)``.

    Attributes
    ----------
    plans : dict
        ``(tool name, pass name) -> plan`` (what the planner's loop made of the pass:
        ``(pieces, lost)`` from ``pieces.finish_runs``, or an edge level's result).
    replan : frozenset of str
        Pass names never recalled (planned anew, their new plan recorded).
    recalled : int
        Plans handed out by ``recall``.
    run : RunMemo
        What the last run made from its plans (``run_memo``).
    """

    plans: dict[tuple[str, str], Any] = field(default_factory=dict)
    replan: frozenset[str] = frozenset()
    recalled: int = 0
    run: RunMemo = field(default_factory=RunMemo)

    def lookup(self, tool: str, name: str) -> Any | None:
        """``recall`` without counting it (``pass_groups``: a child process looks up,
        the caller recalls)."""
        if name in self.replan:
            return None
        return self.plans.get((tool, name))

    def recall(self, tool: str, name: str) -> Any | None:
        """The recorded plan of pass ``name`` with ``tool``; None: plan it."""
        plan = self.lookup(tool, name)
        if plan is not None:
            self.recalled += 1
        return plan

    def record(self, tool: str, name: str, plan: Any) -> None:
        """Keep ``plan`` of pass ``name`` with ``tool``."""
        self.plans[(tool, name)] = plan

    def again(self, names: Iterable[str]) -> PlanMemo:
        """A memo of the same plans in which the passes ``names`` are planned anew."""
        return PlanMemo(self.plans, frozenset(names), run=self.run)
