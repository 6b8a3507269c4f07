"""Five-axis finishing without reverse movements of the rotary axes (M3).

One module per step of the method (seeds 000, second half, and 001):

* ``paths``: cutter-centre paths (hub/blade junctions, blade-side and hub passes);
* ``posture``: initial tool axes (ruling, C turned away from the blade, minimum
  angle to the contact normal, lead/tilt, eq. 7 Cmax);
* ``reversals``: reverse movements of the axes, shift by phi_L and least-squares
  cubic B-spline smoothing until monotone;
* ``interference``: collision checks and the dC remedy up to Cmax;
* ``repair``: postures the remedy cannot fix (axis near the C axis) and the
  normal-angle / lead / tilt limits: cone search, blended into A and C monotonically;
* ``plan``: the procedure per path and its result (``monotone_joints``: A and C made
  monotone); ``pieces``: what the repair cannot free is left out, the pass cut into
  its clean pieces; ``linking``: one toolpath per operation; ``plots``: Figs. 12-13;
  ``command``: ``impeller-cam finish``.

The front door: ``FinishOptions`` and the reversal tools import at once (light);
``plan_finishing``, ``FinishResult``, ``finish_toolpaths`` and ``run_finish`` load on
first use (they pull in the collision service).
"""

from typing import TYPE_CHECKING

from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.reversals import count_reversals, reversal_points, smooth_monotone
from impeller_cam.lazy import lazy_exports

if TYPE_CHECKING:
    from cam.finishing.command import finish_toolpaths, run_finish
    from cam.finishing.plan import FinishResult, plan_finishing

_EXPORTS = {
    "FinishResult": "cam.finishing.plan",
    "plan_finishing": "cam.finishing.plan",
    "finish_toolpaths": "cam.finishing.command",
    "run_finish": "cam.finishing.command",
}

__all__ = [
    "FinishOptions",
    "FinishResult",
    "count_reversals",
    "finish_toolpaths",
    "plan_finishing",
    "reversal_points",
    "run_finish",
    "scallop_stepover",
    "smooth_monotone",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
