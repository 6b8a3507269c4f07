"""The rest operation: a semi-finish where the rough stock left finishing short.

Roughing's 3+2 layers leave ``eta + scallop`` on the faces they reach, but more where
their ball cannot follow the blade (inlet ends of the pressure sides, next to the
fillets, the leading edges): on the splitter fixture 3.1-3.9 mm. Finishing keeps its
neck, shank and holder clear of that stock (``cam.finishing.stock_clearance``), so it
leaves out the postures there (finish.json ``cut_short``). The finish stage
(``stages.finish_stage``) therefore:

1. **finishes against the rough stock** (``run_finish``), every pass's plan kept
   (``cam.finishing.plan_memo``);
2. **where**: takes its left-out postures that the rough stock caused
   (``rest_trigger.stock_left_out``: in their pass's plan they meet the stock, not the
   design or the machine, and verified rough-stock samples on the milled faces --
   ``cam.run.regions.face_groups``: blade sides, hub between the blades, fillets,
   edges; not the lathe skin over the tips -- farther than ``eta + rest_threshold_mm``
   from the design lie within flute length + R of the ball centre; ``eta``: the
   finishing allowance of rough.json). None: no rest operation, nothing written but
   ``rest/rest.json`` (the stock is not even measured when no left-out posture meets
   it); roughing leaves more than its allowance in many places where finishing copes
   (nine_blade), and those call for nothing;
3. **plans the rest operation** (``plan_rest``): the five-axis finishing planner with
   the finishing tool, the finish stage's clearances from the design and from the
   rough stock, ball centres ``R + eta`` from the design
   (``FinishOptions.allowance_mm``) and the roughing scallop (at most half the ball
   radius), on the junction, blade and hub passes cut to the points whose ball comes
   within ``R + eta + stepover / 2`` of such a sample in any passage and within flute
   length + R of such a left-out posture's ball (``RestTrim``, passage 0's frame),
   widened by ``PAD`` points each way along the pass. Every check of finishing
   applies (collisions with the design, the rough stock and the machine; links); it
   writes ``rest/`` (``rest_*.apt``, its finish.json);
4. **verifies** the rest programs, posted as the post stage will, on the rough stock
   into ``verify/rest/``; then, **in rounds**: where this round's own plan left
   postures out for the stock it met (near samples of the stock it left beyond the
   limit: ``rest_trigger.stock_left_out`` on its ``cut_short``), another round is
   planned the same way on the stock it left (``rest/round<k>/``, prefix
   ``rest<k>``) and verified on it (``verify/rest/round<k>/``), while that number
   falls, at most ``MAX_ROUNDS`` rounds. One plan is checked against the stock before
   it as a whole, so a posture whose neck meets excess stock that another pass of the
   same round removes is left out: on the splitter fixture the inlet ends of the main
   blades' pressure sides carry 3-4 mm of rough stock over some 14 mm of span, and a
   round frees about one flute length of it;
5. **finishes again against the last round's stock**, planning anew only the passes
   that held finishing's left-out postures; every other pass keeps its plan (clean against the rough
   stock, so against the smaller rest stock too). The second run takes over from the
   first what it would make again (``cam.finishing.run_memo``): the design's collision
   scene, the machine reach check, and the links, link checks, machine entries, APT
   text and plots of every operation whose plans are all kept; the stock's scene,
   every path's engagement and the operations holding a pass planned anew are made
   again.

It leaves at most ``eta`` + the roughing scallop, what roughing is meant to leave.
The post stage writes its programs between roughing and finishing (operation
``"rest"``), the verify stage verifies them before the finish programs, and the
motion stage counts their cycle time. ``[machining.finish] rest_machining = false``
turns it off.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.run.stages import Context, finish_options, read_json, rest_round_folder
from impeller_cam.atomic import replace_path, write_text_atomic

if TYPE_CHECKING:
    from cam.finishing.paths import CutterPath
    from cam.finishing.plan_memo import PlanMemo
    from cam.run.rough_stock import RoughStock
    from cam.verify.deviation import Deviation

__all__ = ["MAX_ROUNDS", "PAD", "REST", "REST_VERIFY", "RestPlan", "RestTrim",
           "finish_with_rest", "plan_rest", "rest_samples", "rest_verify_folder"]

#: The rest operation's folder (relative to the output).
REST = "rest"
#: Where the finish stage leaves the rest programs' verification.
REST_VERIFY = "verify/rest"
#: Points added to each end of a run of points that need the rest operation.
PAD = 2
#: Rounds of the rest operation at most, each on the stock the round before left.
MAX_ROUNDS = 3


def rest_samples(points: NDArray[np.float64], signed: NDArray[np.float64],
                 milled: NDArray[np.bool_], limit: float) -> NDArray[np.float64]:
    """The stock samples on milled faces farther than ``limit`` from the design.

    Parameters
    ----------
    points : (n, 3) float64
        Stock surface samples, mm.
    signed : (n,) float64
        Their signed design distance, mm (+: material left).
    milled : (n,) bool
        Whether a sample lies on a milled face.
    limit : float
        Material beyond which the rest operation is needed, mm.

    Returns
    -------
    (k, 3) float64
    """
    return np.asarray(points[milled & (signed > limit)], np.float64)


@dataclass
class RestTrim:
    """The points of finishing passes whose ball comes near too much rough stock.

    A ``cam.finishing.pieces.PassTrim``: ``trim(path)`` keeps the points of a passage-0
    pass whose ball centre, in any of the ``passages`` passages (turned by ``pitch``),
    lies within ``reach`` of a rest sample, widened by ``PAD`` points each way.

    Attributes
    ----------
    samples : (k, 3) float64
        Rest samples (``rest_samples``), mm.
    reach : float
        Largest distance of a sample from the ball centre, mm.
    pitch : float
        Angle between passages, rad.
    passages : int
        Number of passages.
    blocked : (m, 3) float64 or None
        Ball centres (passage 0's frame) of the postures finishing left out because
        of the stock (``rest_trigger.stock_left_out``): only points within ``span``
        of one are kept; None: no such condition.
    span : float
        Distance from a blocked centre within which points are kept, mm.
    """

    samples: NDArray[np.float64]
    reach: float
    pitch: float
    passages: int
    blocked: NDArray[np.float64] | None = None
    span: float = 0.0

    def __post_init__(self) -> None:
        self._tree = cKDTree(self.samples) if len(self.samples) else None
        self._blocked = (None if self.blocked is None or not len(self.blocked)
                         else cKDTree(self.blocked))

    def needed(self, centres: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which of the (n, 3) passage-0 ball centres (mm) need the rest operation."""
        need = np.zeros(len(centres), dtype=bool)
        if self._tree is None or not len(centres):
            return need
        for k in range(self.passages):
            angle = k * self.pitch
            c, s = np.cos(angle), np.sin(angle)
            turned = centres @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
            distance, _ = self._tree.query(turned, distance_upper_bound=self.reach)
            need |= np.isfinite(distance)
        if self.blocked is not None:
            if self._blocked is None:
                return np.zeros(len(centres), dtype=bool)
            distance, _ = self._blocked.query(centres[need], distance_upper_bound=self.span)
            need[need] = np.isfinite(distance)
        return need

    def __call__(self, path: CutterPath) -> NDArray[np.bool_] | None:
        """The (n,) mask of the points of ``path`` to machine (None: all)."""
        need = self.needed(np.asarray(path.centre, np.float64))
        wide = need.copy()
        for shift in range(1, PAD + 1):
            wide[shift:] |= need[:-shift]
            wide[:-shift] |= need[shift:]
        return None if wide.all() else wide

    def region(self, piece: CutterPath) -> int:
        """Every piece in one region (pieces keep the passes' order)."""
        return 0


def _milled(ctx: Context, rough: RoughStock, points: NDArray[np.float64],
            signed: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Whether each sample lies on a milled face (``regions.face_groups``)."""
    from cam.run.regions import LabelledDesign, face_groups

    design = LabelledDesign(ctx.spec, impeller=rough.design)
    role = design.face_roles[faces]
    groups, _ = face_groups(design, points, role, np.abs(signed), 0.0,
                            design.face_splitter[faces], skin_gap=0.0)
    milled = np.zeros(len(points), dtype=bool)
    for mask in groups.values():
        milled |= mask
    return milled


def rest_options(ctx: Context) -> dict[str, Any]:
    """The rest operation's planner options: the finish stage's, ball centres
    ``R + eta`` off the design, the roughing scallop (at most half the ball radius),
    no edge passes, point milling of the blades."""
    from cam.tools import resolve_tool

    rough = read_json(ctx, "rough/rough.json", "rough")
    radius = resolve_tool(ctx.settings.finish_tool).radius
    options = finish_options(ctx)
    options.update(allowance_mm=float(rough["finishing_allowance_mm"]),
                   scallop_mm=min(float(rough["options"]["scallop_mm"]), 0.5 * radius),
                   edge_passes=False, blade_strategy="point", rest_machining=False)
    return options


@dataclass
class RestPlan:
    """What the rest operation left for finishing.

    Attributes
    ----------
    stock : Path
        ``verify/rest/stock.npz`` after the rest programs, else the rough stock.
    replan : frozenset of str
        Finishing passes to plan again against ``stock`` (those whose postures the
        rough stock left out, ``rest_trigger.stock_left_out``); empty: keep the plan.
    """

    stock: Path
    replan: frozenset[str]


def plan_rest(ctx: Context, rough: RoughStock, finished: dict[str, Any]) -> RestPlan:
    """Plan and verify the rest operation where the rough stock left finishing short.

    Writes ``rest/rest.json`` (always: whether it was needed and why) and, when
    needed, the rest APT files (``run_finish``, prefix ``rest``) and their
    verification in ``verify/rest``, and those of the later rounds (module docstring,
    step 4: ``rest/round<k>``, prefix ``rest<k>``, ``verify/rest/round<k>``;
    rest.json ``rounds``); an earlier ``rest/`` and ``verify/rest`` are replaced.

    Parameters
    ----------
    ctx : Context
    rough : RoughStock
        The verified rough stock (``rough_stock.verify_rough``).
    finished : dict
        finish.json of finishing planned against that stock (its ``cut_short``).

    Returns
    -------
    RestPlan
    """
    from cam.finishing.command import run_finish
    from cam.finishing.options import FinishOptions, scallop_stepover
    from cam.run.rest_trigger import meets_stock, stock_left_out
    from cam.tools import resolve_tool

    folder, verified = ctx.out / REST, ctx.out / REST_VERIFY
    for old in (folder, verified):
        if old.exists():
            shutil.rmtree(old)
    finish = FinishOptions.from_mapping(dict(ctx.settings.finish))
    eta = float(read_json(ctx, "rough/rough.json", "rough")["finishing_allowance_mm"])
    limit = eta + finish.rest_threshold_mm
    cut_short = finished.get("cut_short", [])
    record: dict[str, Any] = {"format": "impeller-cam rest 2",
                              "enabled": finish.rest_machining,
                              "finishing_allowance_mm": eta,
                              "threshold_mm": finish.rest_threshold_mm, "limit_mm": limit,
                              "left_out_before": _by_passage(cut_short),
                              "planned": False}
    nothing = RestPlan(rough.path, frozenset())
    if not finish.rest_machining or not meets_stock(cut_short):
        _write_record(folder, record)
        return nothing
    samples = _rough_samples(ctx, rough, limit, record)
    tool = resolve_tool(ctx.settings.finish_tool)
    spec = rough.design.surfaces.spec
    span = tool.flute_length + tool.radius
    blocked = stock_left_out(cut_short, samples, span, float(spec.pitch))
    record.update(span_mm=round(span, 4), stock_left_out_points=blocked.points,
                  stock_left_out_passes=sorted(blocked.passes))
    if not blocked.points:
        _write_record(folder, record)
        return nothing
    options = rest_options(ctx)
    stepover = scallop_stepover(tool.radius, float(options["scallop_mm"]))
    allowance = eta + float(options["scallop_mm"])
    reach = tool.radius + float(options["allowance_mm"]) + 0.5 * stepover
    stock_path, replan = rough.path, blocked.passes
    rounds: list[dict[str, Any]] = []  # the rounds after the first
    document: dict[str, Any] = {}
    deviation: Deviation | None = None
    for round_ in range(1, MAX_ROUNDS + 1):
        if round_ > 1:  # where the round before left postures out for the stock it met
            if deviation is None or not meets_stock(document["cut_short"]):
                break
            samples = rest_samples(deviation.points, deviation.distance,
                                   _milled(ctx, rough, deviation.points, deviation.distance,
                                           _faces(rough, deviation)), limit)
            again = stock_left_out(document["cut_short"], samples, span, float(spec.pitch))
            rounds.append({"round": round_, "stock_left_out_points": again.points})
            if not again.points or again.points >= blocked.points:
                break
            blocked = again
        trim = RestTrim(samples, reach, float(spec.pitch), int(spec.blades),
                        blocked=blocked.centres, span=span)
        document = run_finish(ctx.spec, ctx.machine, ctx.settings.finish_tool,
                              ctx.out / rest_round_folder(round_),
                              options=FinishOptions.from_mapping(options), progress=False,
                              plots=False, stock=stock_path, design=rough.design,
                              design_distance=rough.distance, keep=trim,
                              prefix="rest" if round_ == 1 else f"rest{round_}")
        if round_ == 1:
            record.update(planned=True, reach_mm=round(trim.reach, 4))
        else:
            rounds[-1].update(folder=rest_round_folder(round_))
        entry = record if round_ == 1 else rounds[-1]
        summary = document["summary"]
        entry.update(paths=summary["paths"], points=summary["points"],
                     left_out_points=summary["left_out_points"],
                     operations=sorted(document["operations"]))
        if not document["operations"]:
            break
        stock_path, deviation = _verify_rest(ctx, rough, document, allowance, stock_path,
                                             round_)
        entry["verify"] = rest_verify_folder(round_)
    record["rounds"] = rounds
    _write_record(folder, record)
    return nothing if stock_path == rough.path else RestPlan(stock_path, replan)


def finish_with_rest(ctx: Context, rough: RoughStock,
                     finish: Callable[[Path, PlanMemo], dict[str, Any]]) -> dict[str, Any]:
    """Finishing against the rough stock, the rest operation where that stock left
    postures out (``plan_rest``), and finishing again against the stock it left with
    only those postures' passes planned anew (the module docstring, steps 1-5).

    Parameters
    ----------
    ctx : Context
    rough : RoughStock
    finish : callable
        ``finish(stock, memo)``: finishing (``run_finish`` into ``finish/``) against
        the stock ``stock.npz`` with the pass plans ``memo``; returns finish.json.

    Returns
    -------
    dict
        The final finish.json. ``rest/rest.json`` gains ``replanned_passes``,
        ``recalled_plans``, ``rerun_reused`` (what the second run took over from the
        first, ``run_memo.RunMemo.reused``) and ``left_out_after`` when finishing ran
        again.
    """
    from cam.finishing.plan_memo import PlanMemo

    memo = PlanMemo()
    first = finish(rough.path, memo)
    rest = plan_rest(ctx, rough, first)
    if not rest.replan:
        return first
    again = memo.again(rest.replan)
    document = finish(rest.stock, again)
    record = read_json(ctx, f"{REST}/rest.json", "finish")
    record.update(replanned_passes=len(rest.replan), recalled_plans=again.recalled,
                  rerun_reused=dict(again.run.reused),
                  left_out_after=_by_passage(document["cut_short"]))
    _write_record(ctx.out / REST, record)
    return document


def _by_passage(cut_short: list[dict[str, Any]]) -> dict[str, int]:
    """Left-out postures of finish.json's ``cut_short``: ``"all"`` and per passage
    (``"p0"``, ...)."""
    from cam.run.rest_trigger import passage_of

    counts: dict[str, int] = {"all": 0}
    for entry in cut_short:
        key = f"p{passage_of(str(entry['path']))}"
        counts[key] = counts.get(key, 0) + len(entry["left_out"])
        counts["all"] += len(entry["left_out"])
    return counts


def _rough_samples(ctx: Context, rough: RoughStock, limit: float,
                   record: dict[str, Any]) -> NDArray[np.float64]:
    """The rough stock's samples on milled faces beyond ``limit`` (``rest_samples``);
    their counts and the largest excess go into ``record``."""
    from cam.run.rough_stock import DEVIATION, stock_deviation
    from cam.verify.stock import Stock

    deviation = stock_deviation(Stock.load(rough.path), rough.distance,
                                rough.path.parent / DEVIATION)
    faces = deviation.faces
    if faces is None:
        faces = rough.distance.closest(deviation.points)[1]
    milled = _milled(ctx, rough, deviation.points, deviation.distance, faces)
    samples = rest_samples(deviation.points, deviation.distance, milled, limit)
    record.update(milled_samples=int(milled.sum()), samples_over=len(samples),
                  max_mm=round(float(deviation.distance[milled].max()), 4)
                  if milled.any() else None)
    return samples


def _write_record(folder: Path, record: dict[str, Any]) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(folder / "rest.json", json.dumps(record, indent=2) + "\n")


def rest_verify_folder(round_: int) -> str:
    """Where the finish stage leaves the verification of the rest operation's round
    ``round_`` (from 1; relative to the output): ``verify/rest``, then
    ``verify/rest/round<k>`` (the verify stage keeps ``verify/rest`` whole)."""
    return REST_VERIFY if round_ == 1 else f"{REST_VERIFY}/round{round_}"


def _faces(rough: RoughStock, deviation: Deviation) -> NDArray[np.int64]:
    """The closest design face of each sample of ``deviation`` (measured when absent)."""
    if deviation.faces is not None:
        return np.asarray(deviation.faces, np.int64)
    return np.asarray(rough.distance.closest(deviation.points)[1], np.int64)


def _verify_rest(ctx: Context, rough: RoughStock, document: dict[str, Any],
                 allowance: float, start: Path, round_: int) -> tuple[Path, Deviation]:
    """Post the APT files of the rest operation's round ``round_`` and verify them on
    the stock ``start`` (the rough stock, or the round before's) into
    ``rest_verify_folder(round_)``; the stock they leave and its deviation."""
    from cam.verify.command import VerifyOptions, run_verify
    from cam.verify.stock import Stock
    from postproc.command import post_text
    from postproc.machine import load_machine
    from postproc.posts import get_post

    dialect = get_post(ctx.settings.post or load_machine(ctx.machine).post)
    target = ctx.out / rest_verify_folder(round_)
    target.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".rest-staging-", dir=target.parent))
    try:
        (stage / "nc").mkdir()
        programs = []
        for op in _ordered(document["operations"]):
            apt = ctx.out / rest_round_folder(round_) / document["operations"][op]["apt"]
            nc = stage / "nc" / f"{apt.stem}.{dialect.extension}"
            write_text_atomic(nc, post_text(apt, ctx.machine, post=dialect.name))
            programs.append(nc)
        deviation = run_verify(programs, ctx.machine, ctx.settings.finish_tool, str(start),
                               ctx.spec, ctx.settings.verify_resolution_mm, stage,
                               options=VerifyOptions(allowance=allowance,
                                                     render_each_program=False, record=True),
                               progress=False, design_distance=rough.distance,
                               initial_stock=Stock.load(start))
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    assert deviation is not None
    replace_path(stage, target)
    return target / "stock.npz", deviation


def _ordered(operations: dict[str, Any]) -> list[str]:
    """Operation names in machining order (``stages.FINISH_ORDER``)."""
    from cam.run.stages import FINISH_ORDER

    return [op for op in FINISH_ORDER if op in operations] + \
        sorted(set(operations) - set(FINISH_ORDER))
