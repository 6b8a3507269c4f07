"""Shared kernel of impeller-cam: errors, tolerances, atomic output.

The product packages are ``geometry`` (camber data to solids and meshes),
``cam`` (tools, toolpaths, roughing, finishing, verification, CLI) and
``postproc`` (machines, kinematics, post-processors, APT and NC I/O). This small
package holds what all three need, so none of them has to import another's
internals.
"""

from impeller_cam.errors import InputError
from impeller_cam.tolerances import DEFAULT_TOLERANCES, Tolerances

__version__ = "0.1.0"

__all__ = ["DEFAULT_TOLERANCES", "InputError", "Tolerances", "__version__"]
