"""Roughing as one program per operation (issue 25): the option that selects the
layout of the rough programs.

The layout itself (one NC program with one tool call, every UMR visit a section,
removing the same volume as the one-file-per-visit layout, with a clean
verification) is checked on nine_blade's acceptance roughing, which the acceptance
tests build anyway: ``test_one_program_per_operation_removes_what_the_visits_remove``
in tests/cam/test_roughing_acceptance.py (it had a roughing run of its own, one
passage, about 90 s of a core).
"""

from __future__ import annotations

import pytest

from cam.roughing.options import RoughOptions
from impeller_cam.errors import InputError


def test_program_layout_is_validated() -> None:
    assert RoughOptions().program_layout == "operation"
    assert RoughOptions(program_layout="visit").program_layout == "visit"
    with pytest.raises(InputError, match="program layout"):
        RoughOptions(program_layout="umr")
