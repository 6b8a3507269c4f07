"""The chain's verdict on its own output folder: what must stop a shop from running it.

``impeller-cam run`` writes NC programs before it verifies them (the verifier reads the
posted programs, as a machine would). A program the verification found unsafe must not
look like a finished job: the command prints what was found and ends with exit code 1.
Unsafe means any of ``FAULT_EVENTS`` in ``verify/rough`` or ``verify/finish`` (a
collision of shank, holder or machine, a gouge, an over-travel, a rapid through stock, a
blank short of the design). Material left over the limit on a milled face
(``verify/regions.json``: ``accepted`` false) is a finishing shortfall, not a danger: it
is printed as a warning (a run of one passage leaves the others unmachined on purpose).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["FAULT_EVENTS", "ChainVerdict", "chain_verdict"]

#: Verification events that make a program unsafe to run.
FAULT_EVENTS = ("holder_collision", "machine_collision", "gouge", "overtravel",
                "rapid_in_stock", "stock_short")


@dataclass
class ChainVerdict:
    """What the chain's verification found.

    Attributes
    ----------
    faults : list of str
        One line per verification (rough, finish) with fault events: the counts and the
        file to read.
    shortfalls : list of str
        Milled faces over their limit (regions.json), one line.
    """

    faults: list[str] = field(default_factory=list)
    shortfalls: list[str] = field(default_factory=list)

    @property
    def safe(self) -> bool:
        """No fault event in any verification."""
        return not self.faults


def chain_verdict(out: str | Path) -> ChainVerdict:
    """Read a chain output folder's verify.json files and regions.json.

    Parameters
    ----------
    out : str or Path
        The chain's output folder (docs/run.md); a verification not run is skipped.

    Returns
    -------
    ChainVerdict
    """
    out = Path(out)
    verdict = ChainVerdict()
    for kind in ("rough", "finish"):
        path = out / "verify" / kind / "verify.json"
        if not path.is_file():
            continue
        counts = json.loads(path.read_text()).get("event_counts") or {}
        found = {name: int(counts.get(name, 0)) for name in FAULT_EVENTS
                 if int(counts.get(name, 0)) > 0}
        if found:
            listed = ", ".join(f"{n} {name.replace('_', ' ')}" for name, n in found.items())
            verdict.faults.append(f"{kind} programs: {listed} (see {path})")
    regions = out / "verify" / "regions.json"
    if regions.is_file():
        finish = json.loads(regions.read_text()).get("finish") or {}
        failed = finish.get("failed") or []
        if failed:
            verdict.shortfalls.append(
                f"milled faces over the {finish.get('limit_mm', 0.0):.3f} mm limit: "
                f"{', '.join(failed)} (see {regions})")
    return verdict
