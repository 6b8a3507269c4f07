"""Machining order of the finished passes: per operation and passage, zig-zag.

Inside each passage of an operation every second pass is run backwards (zig-zag),
so consecutive passes start where the previous one ended and the link between them
is a short move across the stepover instead of a return to the other end. The
reversed pass has the same postures in reverse order: its A and C still move one
way (reversed), the posture rules (normal angle, lead and tilt limits) hold as they
are symmetric in the feed direction; what changes is the cutting sense (climb and
conventional alternate). ``zigzag=False`` keeps every pass leading to trailing edge.

A pass with ``breaks`` (a hub pass whose tool axis turns too fast somewhere,
``posture.axis_breaks``) is handed on as its pieces (``posture.axis_pieces``) in
machining order; each piece after the first is entered from the air
(``PassEnds.from_air``: never by a feed link), so the tool changes side lifted.
The pieces of a pass cut where postures break a rule (``PathResult.piece_of``,
``pieces.finish_runs``) are machined as one pass (one zig-zag direction, the pieces
in reverse order when reversed), each piece after the first entered from the air:
the tool never feeds across the postures left out.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from cam.finishing.driven import driven_roles
from cam.finishing.linking import PassEnds
from cam.finishing.plan import PathResult
from cam.finishing.posture import axis_pieces

__all__ = ["escape_normal", "ordered_passes"]

Array = NDArray[np.float64]


def escape_normal(result: PathResult, index: int) -> Array:
    """Unit direction away from the surfaces the ball touches at posture ``index``.

    Hub and blade passes: the contact normal. Junction paths touch hub and blade:
    the sum of the hub normal and the blade's outward normal (the fillet bisector).
    """
    path = result.path
    normal = np.asarray(path.normal[index], dtype=np.float64)
    if path.operation == "junction":
        normal = normal + np.asarray(path.away[index], dtype=np.float64)
    return np.asarray(normal / np.linalg.norm(normal))


def ordered_passes(results: Sequence[PathResult], zigzag: bool = True) -> list[PassEnds]:
    """``PassEnds`` of one operation's paths in machining order.

    Parameters
    ----------
    results : sequence of PathResult
        The operation's finished paths, grouped by passage, in planning order.
    zigzag : bool
        Reverse every second pass of each passage.
    """
    out: list[PassEnds] = []
    count = 0
    passage = None
    for group in _passes(results):
        if group[0].path.passage != passage:
            passage, count = group[0].path.passage, 0
        reverse = zigzag and count % 2 == 1
        for j, r in enumerate(group[::-1] if reverse else group):
            out += _piece_ends(r, reverse, from_air=j > 0)
        count += 1
    return out


def _passes(results: Sequence[PathResult]) -> list[list[PathResult]]:
    """The results grouped into passes: the pieces of a cut pass (``piece_of``) together."""
    groups: list[list[PathResult]] = []
    for r in results:
        if groups and r.piece_of is not None and groups[-1][-1].piece_of == r.piece_of:
            groups[-1].append(r)
        else:
            groups.append([r])
    return groups


def _piece_ends(r: PathResult, reverse: bool, from_air: bool) -> list[PassEnds]:
    """``PassEnds`` of one path result (its axis-break pieces), reversed or not; the
    first entered from the air when ``from_air``, the others always."""
    n = len(r.tip)
    order = np.arange(n, dtype=np.intp)
    if reverse:
        order = order[::-1]
    # breaks in machining order: move i -> i + 1 becomes move n - 2 - i reversed
    breaks = np.sort(n - 2 - r.breaks) if reverse else r.breaks
    pieces = axis_pieces(n, breaks)
    out = []
    for k, piece in enumerate(pieces):
        rows = order[piece]
        label = " (reversed)" if reverse else ""
        if len(pieces) > 1:
            label += f" (piece {k + 1} of {len(pieces)})"
        out.append(PassEnds(
            name=r.path.name + label,
            tip=np.ascontiguousarray(r.tip[rows]), axis=np.ascontiguousarray(r.axis[rows]),
            escape_start=escape_normal(r, int(rows[0])),
            escape_end=escape_normal(r, int(rows[-1])),
            joints_start=np.asarray(r.joints_after[rows[0]]),
            joints_end=np.asarray(r.joints_after[rows[-1]]),
            from_air=from_air or k > 0, driven=driven_roles(r.path)))
    return out
