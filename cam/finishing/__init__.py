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
* ``plan``: the procedure per path and its result; ``linking``: one toolpath per
  operation; ``plots``: Figs. 12-13; ``command``: ``impeller-cam finish``.

The package import is light (options and reversals); import ``cam.finishing.plan``
or ``cam.finishing.command`` for the procedure (they pull in the collision service).
"""

from cam.finishing.options import FinishOptions, scallop_stepover
from cam.finishing.reversals import count_reversals, reversal_points, smooth_monotone

__all__ = [
    "FinishOptions",
    "count_reversals",
    "reversal_points",
    "scallop_stepover",
    "smooth_monotone",
]
