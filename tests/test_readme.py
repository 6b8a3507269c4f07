"""The README's Python snippet runs as written (issue 24).

It is executed in a scratch folder holding a link to the project's fixtures, so its
relative paths resolve and what it writes (``small.step``, ``out/small``) stays there.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def python_snippets(text: str) -> list[str]:
    """The fenced ``python`` blocks of a Markdown text."""
    return re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL)


@pytest.mark.slow
def test_readme_python_snippet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    snippets = python_snippets((ROOT / "README.md").read_text())
    assert len(snippets) == 1
    (tmp_path / "fixtures").symlink_to(ROOT / "fixtures")
    cwd = Path.cwd()
    os.chdir(tmp_path)
    try:
        namespace: dict[str, object] = {"__name__": "readme"}
        exec(compile(snippets[0], "README.md", "exec"), namespace)
    finally:
        os.chdir(cwd)
    assert (tmp_path / "small.step").stat().st_size > 0
    assert (tmp_path / "out" / "small" / "geometry").is_dir()
    record = namespace["record"]
    assert isinstance(record, dict)
    status = {s["name"]: s["status"] for s in record["stages"]}
    assert status.pop("geometry") == "done"
    assert set(status.values()) == {"not run"}
    printed = capsys.readouterr().out
    assert "'pressure': 6" in printed and "G" in printed
