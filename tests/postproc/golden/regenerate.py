"""Rewrite the golden NC files: ``python -m tests.postproc.golden.regenerate``.

Run it only when a change of the posted programs is intended, then review the diff.
"""

from __future__ import annotations

from impeller_cam.atomic import write_text_atomic
from tests.postproc.golden.cases import CASES, GOLDEN, render


def main() -> None:
    for name in CASES:
        write_text_atomic(GOLDEN / name, render(name))
        print(f"wrote {GOLDEN / name}")


if __name__ == "__main__":
    main()
