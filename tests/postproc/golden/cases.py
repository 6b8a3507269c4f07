"""The golden-file cases: one APT fixture posted per dialect and mode.

The files next to this module are compared byte for byte by
tests/postproc/test_post_golden.py. Rewrite them only on purpose, with
``python -m tests.postproc.golden.regenerate`` (from the repository root), and
review the diff.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from postproc.command import post_text

ROOT = Path(__file__).resolve().parents[3]
GOLDEN = Path(__file__).resolve().parent
APT = ROOT / "fixtures" / "apt" / "post_impeller_ops.apt"
SIM = ROOT / "fixtures" / "machines" / "xyzac-trt.toml"
TRUNNION = ROOT / "fixtures" / "machines" / "trunnion-500.toml"

#: file name -> keyword arguments of ``post_text``.
CASES: dict[str, dict[str, Any]] = {
    "linuxcnc_joint.ngc": {"machine": SIM, "post": "linuxcnc"},
    "linuxcnc_tcp.ngc": {"machine": SIM, "post": "linuxcnc", "tcp": True},
    "linuxcnc_trunnion_numbered.ngc": {"machine": TRUNNION, "post": "linuxcnc",
                                       "block_numbers": True, "tolerance": 0.005},
    "fanuc_joint.nc": {"machine": TRUNNION, "post": "fanuc", "block_numbers": True,
                       "program_number": 1234},
    "fanuc_tcp.nc": {"machine": TRUNNION, "post": "fanuc", "tcp": True,
                     "angular_tolerance_deg": 0.25},
    "sinumerik_joint.mpf": {"machine": TRUNNION, "post": "sinumerik", "block_numbers": True},
    "sinumerik_traori.mpf": {"machine": SIM, "post": "sinumerik", "tcp": True},
    "sinumerik_vectors.mpf": {"machine": TRUNNION, "post": "sinumerik", "tcp": True,
                              "post_options": {"orientation": "vector", "feed": "path"}},
    "heidenhain_joint.h": {"machine": TRUNNION, "post": "heidenhain"},
    "heidenhain_tcpm.h": {"machine": SIM, "post": "heidenhain", "tcp": True},
    "heidenhain_vectors_m128.h": {"machine": TRUNNION, "post": "heidenhain", "tcp": True,
                                  "post_options": {"orientation": "vector", "tcpm": "m128"}},
    "sinumerik_cycle800.mpf": {"machine": TRUNNION, "post": "sinumerik",
                               "post_options": {"frames": "cycle800"}},
    "heidenhain_plane_spatial.h": {"machine": SIM, "post": "heidenhain", "tcp": True,
                                   "post_options": {"frames": "plane-spatial"}},
    "heidenhain_plane_axial.h": {"machine": TRUNNION, "post": "heidenhain",
                                 "post_options": {"frames": "plane-axial"}},
}


def render(name: str) -> str:
    """The program text of case ``name``, posted now."""
    kwargs = dict(CASES[name])
    machine = kwargs.pop("machine")
    return post_text(APT, machine, **kwargs)
