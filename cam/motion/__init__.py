"""Machine motion and dynamics (methods M5 and M6).

Modules, one step of the method each:

* ``scurve``: seven-segment asymmetric jerk profiles, vectorised (seed 000).
* ``plant``: the two-degree-of-freedom indexing-table plant, exact ZOH simulation.
* ``identify``: plant parameters from a measured response CSV (least squares).
* ``positioning``: positioning time = access + settling, closed form.
* ``optimise`` / ``plots``: the paper's grid search on Dask, Figs. 9 and 10.
* ``feeddrive`` / ``synchronisation``: feed-drive model, Best K_FFP, torque
  saturation, the circle test (seed 004).
* ``program_servo``: servo lag of a joint-space program mapped to the tool tip.
* ``cycle_time``: program and index-move times under axis limits.
* ``cli``: the ``impeller-cam motion`` sub-commands.

Heavy modules are not imported here (the front door below is lazy).

The front door (lazy)::

    from cam.motion import program_cycle_time, simulate_program
    from postproc import load_machine, read_nc

    machine = load_machine("fixtures/machines/trunnion-500.toml")
    program = read_nc("out/nine_blade/nc/finish_blade.ngc", machine=machine)
    times = program_cycle_time(program, machine)    # CycleTime, s
    servo = simulate_program(program, machine)      # ServoReport: contour error, mm
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from impeller_cam.lazy import lazy_exports

if TYPE_CHECKING:
    from cam.motion.axis_models import AxisModels, machine_axis_models
    from cam.motion.blending import BlendedTime, blended_program_time
    from cam.motion.contour import ContourError, contour_error
    from cam.motion.cycle_time import CycleTime, program_cycle_time
    from cam.motion.program_servo import ServoReport, simulate_program
    from cam.motion.scurve import SCurveProfiles, plan_scurve, sample_scurve

_EXPORTS = {
    "AxisModels": "cam.motion.axis_models",
    "machine_axis_models": "cam.motion.axis_models",
    "BlendedTime": "cam.motion.blending",
    "blended_program_time": "cam.motion.blending",
    "ContourError": "cam.motion.contour",
    "contour_error": "cam.motion.contour",
    "CycleTime": "cam.motion.cycle_time",
    "program_cycle_time": "cam.motion.cycle_time",
    "ServoReport": "cam.motion.program_servo",
    "simulate_program": "cam.motion.program_servo",
    "SCurveProfiles": "cam.motion.scurve",
    "plan_scurve": "cam.motion.scurve",
    "sample_scurve": "cam.motion.scurve",
}

__all__ = ["AxisModels", "BlendedTime", "ContourError", "CycleTime", "SCurveProfiles",
           "ServoReport", "blended_program_time", "contour_error", "machine_axis_models",
           "plan_scurve", "program_cycle_time", "sample_scurve", "simulate_program"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
