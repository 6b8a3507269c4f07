"""Read the chain's output folder for the report: JSON, PNG and paths, never more.

``RunFolder`` is the only door through which the report sees OUT/: it reads the
files the stages wrote (docs/run.md, the contract of ``impeller-cam run``), caches
them, and turns every missing or unreadable input into a sentence the report
prints instead of a blank ("stage verify did not run", "verify/finish/verify.json
is missing", "cannot read ...: ..."). Reading never raises for a missing input;
only a missing OUT folder itself is bad input.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from impeller_cam.errors import InputError

__all__ = ["STAGE_OF_FOLDER", "RunFolder"]

#: The stage that writes each top-level folder of OUT/.
STAGE_OF_FOLDER = {
    "geometry": "geometry", "rough": "rough", "finish": "finish", "nc": "post",
    "verify": "verify", "motion": "motion",
}


class RunFolder:
    """The output folder of ``impeller-cam run``, read-only.

    Parameters
    ----------
    out : Path
        The OUT/ folder (it must exist).

    Raises
    ------
    InputError
        ``out`` is not a folder.
    """

    def __init__(self, out: str | Path) -> None:
        self.root = Path(out)
        if not self.root.is_dir():
            raise InputError("the run output folder does not exist", file=self.root,
                             accepted="the OUT/ folder of impeller-cam run")
        self._json: dict[str, dict[str, Any] | None] = {}
        self.problems: dict[str, str] = {}

    # ------------------------------------------------------------------ run.json
    @property
    def run(self) -> dict[str, Any]:
        """run.json, or an empty dict when it is missing or unreadable."""
        return self.json("run.json") or {}

    def stage(self, name: str) -> dict[str, Any] | None:
        """The run.json record of stage ``name`` (None when run.json has none)."""
        stages = self.run.get("stages")
        if isinstance(stages, list):
            for record in stages:
                if isinstance(record, dict) and record.get("name") == name:
                    return record
        elif isinstance(stages, dict) and isinstance(stages.get(name), dict):
            return dict(stages[name], name=name)
        return None

    def stage_note(self, name: str) -> str | None:
        """Why a stage's outputs may be missing: "stage X did not run" / "failed: ...",
        None when run.json says it is done or does not know it."""
        record = self.stage(name)
        if record is None:
            return None
        status = str(record.get("status", ""))
        if status == "done":
            return None
        if status == "failed":
            error = record.get("error")
            return f"stage {name} failed" + (f": {error}" if error else "")
        return f"stage {name} did not run"

    # ------------------------------------------------------------------ files
    def path(self, relative: str) -> Path:
        """Absolute path of a file of OUT/ (given relative, ``/``-separated)."""
        return self.root / relative

    def exists(self, relative: str) -> bool:
        """True when OUT/``relative`` is a file."""
        return self.path(relative).is_file()

    def why_missing(self, relative: str) -> str:
        """A sentence saying why OUT/``relative`` cannot be shown."""
        if relative in self.problems:
            return self.problems[relative]
        folder = relative.split("/", 1)[0]
        stage = STAGE_OF_FOLDER.get(folder)
        reason = self.stage_note(stage) if stage else None
        if reason:
            return f"{reason} ({relative} is missing)"
        return f"{relative} is missing"

    def json(self, relative: str) -> dict[str, Any] | None:
        """OUT/``relative`` parsed as a JSON object; None when missing or unreadable
        (``why_missing`` then says which)."""
        if relative not in self._json:
            self._json[relative] = self._read_json(relative)
        return self._json[relative]

    def _read_json(self, relative: str) -> dict[str, Any] | None:
        path = self.path(relative)
        if not path.is_file():
            return None
        try:
            document = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as error:
            self.problems[relative] = f"cannot read {relative}: {error}"
            return None
        if not isinstance(document, dict):
            self.problems[relative] = f"cannot read {relative}: not a JSON object"
            return None
        return document

    def data(self, relative: str) -> bytes | None:
        """The bytes of OUT/``relative``; None when missing, unreadable or empty."""
        path = self.path(relative)
        if not path.is_file():
            return None
        try:
            data = path.read_bytes()
        except OSError as error:
            self.problems[relative] = f"cannot read {relative}: {error.strerror}"
            return None
        if not data:
            self.problems[relative] = f"{relative} is empty"
            return None
        return data

    def png(self, relative: str) -> bytes | None:
        """A PNG of OUT/; None when missing or not a PNG (``why_missing`` says which)."""
        data = self.data(relative)
        if data is not None and not data.startswith(b"\x89PNG\r\n\x1a\n"):
            self.problems[relative] = f"{relative} is not a PNG image"
            return None
        return data

    def glob(self, pattern: str) -> list[str]:
        """Relative paths of the files of OUT/ matching ``pattern``, sorted."""
        return sorted(p.relative_to(self.root).as_posix() for p in self.root.glob(pattern)
                      if p.is_file())

    def text_lines(self, relative: str) -> list[str] | None:
        """Lines of a text file of OUT/ (e.g. an NC program); None when missing."""
        data = self.data(relative)
        if data is None:
            return None
        return data.decode("utf-8", errors="replace").splitlines()
