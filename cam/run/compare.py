"""Two run folders' verification results side by side: the same result or not.

``compare_runs(original, other)`` reads what ``impeller-cam run`` wrote into two
output folders (docs/run.md: ``run.json``, ``geometry/geometry.json``,
``verify/rough/verify.json``, ``verify/finish/verify.json``, ``verify/regions.json``,
``motion/motion.json``) and compares them quantity by quantity. Issue 22 asks that an
impeller exported to an aero designer's format and imported again runs through the
chain "with the same verification result" as the original; here that means
(docs/import-export.md):

* **equal** -- every stage's status; per verification run (rough, finish) the verdict
  (``accepted``, the failed face groups, ``gouge``) and the count of every event kind
  that is a fault (gouge, holder and machine collisions, over-travel, rapids in stock,
  stock short of the design); the verification resolution;
* **lengths** (mm) -- per face group the largest, 99th-percentile, median and smallest
  deviation, the whole part's largest and smallest deviation, d_min and r_max: within
  ``length_mm`` = the round trip's geometric tolerance (blade surfaces within
  0.01 mm, issue 22) + the verification's dexel spacing (a deviation field sampled on
  a grid of spacing h, shifted by less than h, has extremes and percentiles that move
  by up to its slope times h, and the slope of a scallop or an edge is about 1);
* **shares** -- per face group the share of samples over the limit and the share
  machined: within ``share`` (absolute) + the share of the group's samples that
  changed groups (its sample count difference over its count: a sample takes the role
  of its closest design triangle, and the two designs' triangles differ);
* **relative** -- volumes (solid, removed per verification run), the part's sample
  count, cycle times per program, and the ``excess`` event count (one event per NC
  block that left material beyond the allowance, so it follows the programs' block
  counts, which the paths' adaptive refinement makes differ on a blade that differs
  by micrometres): within the given fraction of the original.

Listed without a judgement (``rule = "info"``): block counts and removed volume per
program (where two programs' paths overlap, which one removes a dexel's material
depends on micrometres), sample counts per face group (judged through the shares).
A quantity found in one folder only is a difference (a stage run in one folder but not
the other).

Command line: ``python -m cam.run.compare ORIGINAL OTHER [--markdown]``: prints the
table; exit 0 when the results are the same, 1 when not, 2 when a folder is not a run
folder.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from impeller_cam.errors import InputError

__all__ = ["FAULT_EVENTS", "Quantity", "RunComparison", "Tolerances", "compare_runs",
           "main", "run_quantities"]

#: Event kinds that are faults: their counts must be equal.
FAULT_EVENTS = ("gouge", "holder_collision", "machine_collision", "overtravel",
                "rapid_in_stock", "stock_short")
#: Per face group: the deviation statistics compared as lengths, mm.
FACE_LENGTHS = ("max_mm", "p99_mm", "median_mm", "min_mm")
#: Per face group: the shares compared absolutely.
FACE_SHARES = ("over_limit_share", "machined_share")
#: The verification runs of a chain.
RUNS = ("rough", "finish")

Value = float | int | str | bool | None


@dataclass(frozen=True)
class Tolerances:
    """What "the same" allows.

    Parameters
    ----------
    geometry_mm : float
        Geometric difference of the two designs, mm (issue 22's round trip: blade
        surfaces within 0.01 mm).
    resolution_mm : float or None
        Dexel spacing of the verification, mm; None: the original's
        ``verify/regions.json`` ``resolution_mm`` (0 when it has none).
    share : float
        Absolute tolerance of the shares of samples (over the limit, machined).
    volume : float
        Relative tolerance of volumes and sample counts (issue 22: solid volume
        within 0.1 %).
    cycle_time : float
        Relative tolerance of the cycle times.
    excess : float
        Relative tolerance of the ``excess`` event counts.
    """

    geometry_mm: float = 0.01
    resolution_mm: float | None = None
    share: float = 0.01
    volume: float = 1e-3
    cycle_time: float = 0.01
    excess: float = 0.05

    def length_mm(self, resolution: float) -> float:
        """Allowed difference of deviations and lengths, mm."""
        return self.geometry_mm + (resolution if self.resolution_mm is None
                                   else self.resolution_mm)


@dataclass(frozen=True)
class Quantity:
    """One compared quantity.

    Attributes
    ----------
    name : str
        Dotted name, e.g. ``finish.pressure.max_mm``, ``verify.rough.events.gouge``.
    original, other : float, int, str, bool or None
        The values (None: not in that folder).
    rule : str
        ``equal``; ``length`` (mm) or ``share``: absolute tolerances; ``volume``,
        ``cycle_time`` or ``excess``: relative tolerances (``Tolerances``); ``info``:
        listed, not judged.
    allowed : float or None
        The allowed absolute difference (a relative tolerance times the original),
        None for ``equal`` and ``info``.
    """

    name: str
    original: Value
    other: Value
    rule: str
    allowed: float | None = None

    @property
    def difference(self) -> float | None:
        """other - original for numbers, else None."""
        a, b = self.original, self.other
        if isinstance(a, bool) or isinstance(b, bool):
            return None
        if isinstance(a, int | float) and isinstance(b, int | float):
            return float(b) - float(a)
        return None

    @property
    def same(self) -> bool:
        """Whether the two values are the same under the rule."""
        if self.rule == "info":
            return True
        if self.original is None or self.other is None:
            return self.original is None and self.other is None
        if self.rule == "equal" or self.allowed is None:
            return self.original == self.other
        diff = self.difference
        return diff is not None and math.isfinite(diff) and abs(diff) <= self.allowed + 1e-12


@dataclass(frozen=True)
class RunComparison:
    """Every compared quantity of two run folders.

    Attributes
    ----------
    original, other : Path
        The run folders.
    tolerances : Tolerances
        What was allowed.
    length_mm : float
        The length tolerance used, mm.
    quantities : tuple of Quantity
    """

    original: Path
    other: Path
    tolerances: Tolerances
    length_mm: float
    quantities: tuple[Quantity, ...]

    @property
    def same(self) -> bool:
        """The same verification result: every judged quantity the same."""
        return all(q.same for q in self.quantities)

    @property
    def differing(self) -> list[Quantity]:
        """The quantities that are not the same."""
        return [q for q in self.quantities if not q.same]

    def worst(self, rule: str) -> Quantity | None:
        """The quantity of a rule with the largest difference relative to its allowance."""
        found = [q for q in self.quantities if q.rule == rule and q.allowed
                 and q.difference is not None]
        return max(found, key=lambda q: abs(q.difference or 0.0) / (q.allowed or 1.0),
                   default=None)

    def table(self, prefixes: Sequence[str] | None = None, *, markdown: bool = False) -> str:
        """The quantities (those whose name starts with one of ``prefixes``, default
        all) as a text or Markdown table."""
        rows = [q for q in self.quantities
                if prefixes is None or q.name.startswith(tuple(prefixes))]
        head = ["quantity", "original", "other", "difference", "allowed", "same"]
        body = [[q.name, _text(q.original), _text(q.other), _text(q.difference),
                 _text(q.allowed) if q.allowed is not None else q.rule,
                 "yes" if q.same else "NO"] for q in rows]
        if markdown:
            lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
            lines += ["| " + " | ".join(row) + " |" for row in body]
            return "\n".join(lines)
        widths = [max(len(r[i]) for r in [head, *body]) for i in range(len(head))]
        return "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True))
                         .rstrip() for r in [head, *body])


def _names(quantities: Sequence[Quantity], most: int = 8) -> str:
    names = ", ".join(q.name for q in quantities[:most])
    return names + (f" and {len(quantities) - most} more" if len(quantities) > most else "")


def _text(value: Value) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _read(folder: Path, relative: str) -> dict[str, Any] | None:
    path = folder / relative
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise InputError(f"not valid JSON: {error}", file=path,
                         accepted="a file written by impeller-cam run") from None
    if not isinstance(data, dict):
        raise InputError("not a JSON object", file=path,
                         accepted="a file written by impeller-cam run")
    return data


def run_quantities(folder: str | Path) -> dict[str, tuple[str, Value]]:
    """The comparable quantities of one run folder.

    Parameters
    ----------
    folder : str or Path
        An ``impeller-cam run`` output folder (``run.json`` at least).

    Returns
    -------
    dict
        Dotted name -> (rule, value); the rules as in ``Quantity``. Files of stages
        not run are left out.

    Raises
    ------
    InputError
        When the folder has no ``run.json``, or a file is not a JSON object.
    """
    out = Path(folder)
    record = _read(out, "run.json")
    if record is None:
        raise InputError("not a run folder: run.json is missing", file=out / "run.json",
                         accepted="an output folder of impeller-cam run")
    found: dict[str, tuple[str, Value]] = {}
    for stage in record.get("stages", []):
        found[f"stage.{stage['name']}"] = ("equal", str(stage["status"]))
    geometry = _read(out, "geometry/geometry.json")
    if geometry is not None:
        found["geometry.volume_mm3"] = ("volume", geometry["volume_mm3"])
        found["geometry.d_min_mm"] = ("length", geometry["d_min_mm"])
        found["geometry.r_max_mm"] = ("length", geometry["r_max_mm"])
    for run in RUNS:
        found.update(_verify_quantities(_read(out, f"verify/{run}/verify.json"), run))
    regions = _read(out, "verify/regions.json")
    if regions is not None:
        found["regions.resolution_mm"] = ("equal", regions.get("resolution_mm"))
        for run in RUNS:
            found.update(_region_quantities(regions.get(run), run))
    motion = _read(out, "motion/motion.json")
    if motion is not None:
        for program in motion.get("programs", []):
            found[f"motion.{program['name']}.cycle_time_s"] = ("cycle_time",
                                                               program["cycle_time_s"])
        found["motion.total_s"] = ("cycle_time", motion.get("total_s"))
    return found


def _verify_quantities(data: dict[str, Any] | None, run: str) -> dict[str, tuple[str, Value]]:
    if data is None:
        return {}
    head = f"verify.{run}"
    found: dict[str, tuple[str, Value]] = {}
    counts = data.get("event_counts", {})
    for kind in sorted(set(counts) | set(FAULT_EVENTS) | {"excess"}):
        rule = "excess" if kind == "excess" else "equal"
        found[f"{head}.events.{kind}"] = (rule, int(counts.get(kind, 0)))
    deviation = data.get("deviation") or {}
    for key in ("max_mm", "min_mm"):
        if key in deviation:
            found[f"{head}.deviation.{key}"] = ("length", deviation[key])
    if "samples" in deviation:
        found[f"{head}.deviation.samples"] = ("volume", deviation["samples"])
    found[f"{head}.removed_volume_mm3"] = ("volume", data.get("removed_volume_mm3"))
    for program in data.get("programs", []):
        name = Path(str(program["name"])).stem
        found[f"{head}.{name}.removed_volume_mm3"] = ("info",
                                                     program.get("removed_volume_mm3"))
        found[f"{head}.{name}.blocks"] = ("info", program.get("blocks"))
    return found


def _region_quantities(data: dict[str, Any] | None, run: str) -> dict[str, tuple[str, Value]]:
    if data is None:
        return {}
    found: dict[str, tuple[str, Value]] = {
        f"{run}.accepted": ("equal", bool(data.get("accepted"))),
        f"{run}.failed": ("equal", ",".join(sorted(data.get("failed", []))) or "none"),
        f"{run}.gouge": ("equal", bool(data.get("gouge"))),
        f"{run}.stock_short_samples": ("equal", data.get("stock_short_samples")),
    }
    for role, table in data.get("roles", {}).items():
        for key in FACE_LENGTHS:
            found[f"{run}.{role}.{key}"] = ("length", table.get(key))
        for key in FACE_SHARES:
            found[f"{run}.{role}.{key}"] = ("share", table.get(key))
        found[f"{run}.{role}.samples"] = ("info", table.get("samples"))
        found[f"{run}.{role}.within_limit"] = ("equal", bool(table.get("within_limit")))
    return found


def _allowed(rule: str, original: Value, tolerances: Tolerances, length: float
             ) -> float | None:
    scale = abs(float(original)) if isinstance(original, int | float) else 0.0
    if rule == "length":
        return length
    if rule == "share":
        return tolerances.share
    if rule == "volume":
        return tolerances.volume * scale
    if rule == "cycle_time":
        return tolerances.cycle_time * scale
    if rule == "excess":
        return tolerances.excess * scale
    return None


def _moved_share(name: str, a: dict[str, tuple[str, Value]],
                 b: dict[str, tuple[str, Value]]) -> float:
    """The share of a face group's samples that changed groups: the group's sample
    count difference over its original count (each moved sample may be over the limit
    or not; the groups are the closest design triangle's role)."""
    samples = name.rsplit(".", 1)[0] + ".samples"
    n_a, n_b = a.get(samples, ("", None))[1], b.get(samples, ("", None))[1]
    if not (isinstance(n_a, int | float) and isinstance(n_b, int | float)) or n_a <= 0:
        return 0.0
    return abs(float(n_b) - float(n_a)) / float(n_a)


def compare_runs(original: str | Path, other: str | Path,
                 tolerances: Tolerances | None = None) -> RunComparison:
    """Compare two run folders' verification results.

    Parameters
    ----------
    original, other : str or Path
        ``impeller-cam run`` output folders.
    tolerances : Tolerances, optional
        What "the same" allows (defaults: ``Tolerances()``).

    Returns
    -------
    RunComparison
        Every quantity of either folder with both values and its verdict;
        ``.same`` is the overall verdict.

    Raises
    ------
    InputError
        When a folder is not a run folder.
    """
    tol = tolerances or Tolerances()
    a, b = run_quantities(original), run_quantities(other)
    resolution = a.get("regions.resolution_mm", ("equal", 0.0))[1]
    length = tol.length_mm(float(resolution) if isinstance(resolution, int | float) else 0.0)
    quantities = []
    for name in [*a, *(n for n in b if n not in a)]:
        rule = (a.get(name) or b[name])[0]
        value_a = a[name][1] if name in a else None
        value_b = b[name][1] if name in b else None
        allowed = _allowed(rule, value_a, tol, length)
        if rule == "share" and allowed is not None:
            allowed += _moved_share(name, a, b)
        quantities.append(Quantity(name, value_a, value_b, rule, allowed))
    return RunComparison(Path(original), Path(other), tol, length, tuple(quantities))


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m cam.run.compare ORIGINAL OTHER [--markdown] [--all]``."""
    parser = argparse.ArgumentParser(prog="python -m cam.run.compare",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("original", type=Path)
    parser.add_argument("other", type=Path)
    parser.add_argument("--markdown", action="store_true", help="a Markdown table")
    parser.add_argument("--all", action="store_true",
                        help="every quantity (default: those that differ at all)")
    args = parser.parse_args(argv)
    try:
        result = compare_runs(args.original, args.other)
    except InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    shown = result if args.all else RunComparison(
        result.original, result.other, result.tolerances, result.length_mm,
        tuple(q for q in result.quantities if q.original != q.other))
    print(shown.table(markdown=args.markdown))
    judged = sum(q.rule != "info" for q in result.quantities)
    print(f"{judged} quantities judged ({len(result.quantities) - judged} listed only), "
          f"length tolerance {result.length_mm:g} mm; "
          + ("the same verification result" if result.same else
             f"{len(result.differing)} differ: " + _names(result.differing)))
    return 0 if result.same else 1


if __name__ == "__main__":
    sys.exit(main())
