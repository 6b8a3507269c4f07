"""Post-processor plug-ins (dialects) and their registry.

Built-ins: ``linuxcnc``, ``fanuc``, ``sinumerik`` and ``heidenhain``. Third-party
dialects register through the entry-point group ``impeller_cam.postprocessors`` (see
docs/postprocessors.md).
"""

from __future__ import annotations

from postproc.posts import fanuc, heidenhain, linuxcnc, sinumerik  # noqa: F401  (built-ins)
from postproc.posts.base import (
    ENTRY_POINT_GROUP,
    PostOptions,
    PostProcessor,
    available_posts,
    get_post,
    register_post,
    register_unavailable,
)
from postproc.posts.gcode import GCodeWriter

__all__ = [
    "ENTRY_POINT_GROUP",
    "GCodeWriter",
    "PostOptions",
    "PostProcessor",
    "available_posts",
    "get_post",
    "register_post",
    "register_unavailable",
]
