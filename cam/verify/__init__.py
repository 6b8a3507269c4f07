"""Offscreen material-removal verification of NC programs (docs/verification.md).

Typical use::

    from cam.verify import run_verify

    run_verify([Path("finish.ngc")], Path("fixtures/machines/xyzac-trt.toml"), "ball6",
               "fixtures/impellers/small/spec.toml", Path("fixtures/impellers/small/spec.toml"),
               0.1, Path("out/verify"))

The pieces: ``Stock`` (tri-dexel stock), ``tool_shape`` (tool -> convex primitives),
``program_moves`` (NC blocks -> straight fixed-axis tool moves within a bound),
``Event`` (findings tied to NC lines), ``DesignDistance`` (signed distance from the
design mesh).
"""

from cam.verify.command import VerifyOptions, run_verify
from cam.verify.deviation import DesignDistance, Deviation
from cam.verify.events import EVENT_TYPES, Event
from cam.verify.motion import ToolMoves, program_moves
from cam.verify.stock import Stock
from cam.verify.toolshape import ToolShape, tool_shape

__all__ = [
    # the command
    "VerifyOptions",
    "run_verify",
    # stock and tool
    "Stock",
    "ToolShape",
    "tool_shape",
    # motion
    "ToolMoves",
    "program_moves",
    # results
    "EVENT_TYPES",
    "Event",
    "DesignDistance",
    "Deviation",
]
