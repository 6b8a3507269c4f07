"""What calls for the rest operation: finishing's postures the rough stock left out.

Finishing plans against the verified rough stock first (``cam.finishing.command.
run_finish``); where its neck, shank or holder would meet that stock, it leaves the
postures out and names them (finish.json ``cut_short``: pass, indices, ball centres).
Some are left out for other reasons (the design: a fillet corner, a trailing edge the
ball cannot lean into; the machine; a posture rule), which a rest operation does not
change. A left-out posture is taken as **left out because of the stock** when, in its
pass's plan, it meets the stock (and neither the design nor the machine: cut_short
``causes``, ``pieces.finish_runs``) and rough stock beyond the rest limit
(``eta + rest_threshold_mm`` from the design on a milled face: ``rest.rest_samples``)
lies within ``span`` of its ball centre -- the tool's reach, flute length plus ball
radius: the material its neck meets. (An entry without ``causes``, from an older
finish.json, is judged by the distance alone.) ``stock_left_out``
returns those postures' ball centres turned into passage 0 (the rest operation is
planned on passage 0's passes and machined in every passage, ``rest.RestTrim``) and
the names of their passes (finishing plans them again after the rest operation,
``cam.finishing.plan_memo``).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from cam.finishing.posture import rotate_about_z
from cam.finishing.stock_clearance import STOCK_ROLE

__all__ = ["StockLeftOut", "meets_stock", "passage_of", "stock_left_out"]

_PASSAGE = re.compile(r"^p(\d+)\.")


def passage_of(name: str) -> int:
    """The passage of a pass named ``p<k>.<operation>...`` (0 if not so named)."""
    match = _PASSAGE.match(name)
    return int(match.group(1)) if match else 0


def meets_stock(cut_short: Sequence[dict[str, Any]]) -> bool:
    """Whether any left-out posture may meet the stock (a ``"stock"`` cause, or an
    entry without ``causes``): if not, nothing calls for the rest operation and the
    stock need not be measured."""
    return any("causes" not in entry or STOCK_ROLE in entry["causes"] for entry in cut_short)


@dataclass
class StockLeftOut:
    """Finishing's left-out postures near rough stock beyond the rest limit.

    Attributes
    ----------
    centres : (k, 3) float64
        Their ball centres turned into passage 0, mm.
    passes : frozenset of str
        Names of the passes that hold them.
    points : int
        Their number (``k``).
    left_out : int
        Every left-out posture (``cut_short``), whatever the cause.
    """

    centres: NDArray[np.float64]
    passes: frozenset[str]
    points: int
    left_out: int


def stock_left_out(cut_short: Sequence[dict[str, Any]], samples: NDArray[np.float64],
                   span: float, pitch: float) -> StockLeftOut:
    """The left-out postures with rest samples within ``span`` of their ball centre.

    Parameters
    ----------
    cut_short : sequence of dict
        finish.json's ``cut_short`` entries (``path``, ``centres_mm``: (m, 3) mm;
        ``causes``: (m,) what each meets, ``"stock"`` counts).
    samples : (n, 3) float64
        Rough-stock samples beyond the rest limit (``rest.rest_samples``), mm.
    span : float
        Largest distance of such a sample from the ball centre, mm.
    pitch : float
        Angle between passages, rad (passage ``k`` is passage 0 turned by ``k pitch``
        about +Z).

    Returns
    -------
    StockLeftOut
    """
    tree = cKDTree(samples) if len(samples) else None
    found: list[NDArray[np.float64]] = []
    passes: set[str] = set()
    total = 0
    for entry in cut_short:
        centres = np.asarray(entry["centres_mm"], np.float64).reshape(-1, 3)
        total += len(centres)
        if tree is None or not len(centres):
            continue
        distance, _ = tree.query(centres, distance_upper_bound=span)
        near = np.isfinite(distance)
        if "causes" in entry:
            near &= np.array([cause == STOCK_ROLE for cause in entry["causes"]], dtype=bool)
        if near.any():
            passes.add(str(entry["path"]))
            turn = -passage_of(str(entry["path"])) * pitch
            found.append(np.asarray(rotate_about_z(centres[near], turn), np.float64))
    centres_0 = np.vstack(found) if found else np.zeros((0, 3))
    return StockLeftOut(centres_0, frozenset(passes), len(centres_0), total)
