"""The paper's Table 1 for one run, and where the time goes (move-kind breakdown)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from postproc.toolpath import MoveKind

__all__ = ["breakdown", "table1_markdown"]


def breakdown(tip: NDArray[np.float64], kind: NDArray[np.int8],
              nominal: NDArray[np.float64], limited: NDArray[np.float64]
              ) -> dict[str, dict[str, float]]:
    """Tip length (mm), nominal and limited time (min) per move kind.

    ``tip`` (n, 3), ``kind`` (n,) and the per-move times (n,) (s) of ``block_times``.
    """
    length = np.concatenate([[0.0], np.linalg.norm(np.diff(tip, axis=0), axis=1)])
    out: dict[str, dict[str, float]] = {}
    for k in MoveKind:
        sel = kind == k
        out[k.name.lower()] = {"moves": int(sel.sum()), "length_mm": float(length[sel].sum()),
                               "nominal_min": float(nominal[sel].sum()) / 60.0,
                               "limited_min": float(limited[sel].sum()) / 60.0}
    return out


def table1_markdown(document: dict[str, Any]) -> str:
    """Table 1 of the paper (per-UMR and total times, min) for a ``rough.json`` dict."""
    feeds = list(document["time_min"]["3axis"])
    head = "| feed mm/min | | " + " | ".join(feeds) + " |\n"
    head += "| --- | --- |" + " --- |" * len(feeds) + "\n"
    rows = []
    for u in document["umrs"]:
        times = u.get("time_min", {})
        rows.append(f"| 3+2 (simultaneous three-axis) | UMR {u['index']} | "
                    + " | ".join(f"{times.get(f, float('nan')):.3f}" for f in feeds) + " |")
    for label, key in (("3+2 total", "3axis"), ("simultaneous five-axis", "5axis")):
        for mode, field in (("nominal", "time_min"), ("limited", "time_limited_min")):
            t = document[field][key]
            rows.append(f"| {label} | {mode} | " + " | ".join(f"{t[f]:.3f}" for f in feeds)
                        + " |")
    paper = document.get("paper_table1_min")
    if paper:
        for key, label in (("3axis", "paper 3-axis total"), ("5axis", "paper 5-axis")):
            rows.append(f"| {label} | nominal | "
                        + " | ".join(f"{paper[key][f]:.3f}" for f in feeds) + " |")
    return head + "\n".join(rows) + "\n"
