"""Progress bars for long commands: shown on a terminal, silent in CI and pipes."""

from __future__ import annotations

import sys
from typing import Any


def progress_bar(enabled: bool | None = None) -> Any:
    """A transient ``rich.progress.Progress``, or ``None`` when disabled.

    Parameters
    ----------
    enabled : bool, optional
        Force on or off; by default on exactly when stderr is a terminal.
    """
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None
    from rich.progress import Progress

    return Progress(transient=True)


class StageLog:
    """One line per stage, and a heartbeat at least once a minute, for logs and CI.

    Where no terminal shows a progress bar (stderr is a pipe or a file), a long job
    still tells the person watching what it does: a line when a stage starts, one when
    it ends (with its wall time), and while a stage runs a line every ``heartbeat_s``
    seconds with the time spent in it so far.

    Parameters
    ----------
    job : str
        Prefix of every line (e.g. the impeller's name).
    heartbeat_s : float
        Seconds between the heartbeat lines of a running stage.
    stream : file-like, optional
        Where to write (default: ``sys.stderr`` at the time of each line).
    """

    def __init__(self, job: str, heartbeat_s: float = 60.0, stream: Any = None) -> None:
        import threading

        self.job = job
        self.heartbeat_s = float(heartbeat_s)
        self.stream = stream
        self._stage: str | None = None
        self._started = 0.0
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    def _write(self, text: str) -> None:
        import time

        stamp = time.strftime("%H:%M:%S")
        stream = self.stream if self.stream is not None else sys.stderr
        with self._lock:
            print(f"[{stamp}] {self.job}: {text}", file=stream, flush=True)

    def _beat(self) -> None:
        import time

        while not self._stop.wait(self.heartbeat_s):
            stage = self._stage
            if stage is not None:
                self._write(f"{stage} still running, {time.monotonic() - self._started:.0f} s")

    def start(self, stage: str, index: int, total: int) -> None:
        """A stage begins (``index`` counts from 1)."""
        import threading
        import time

        self._stage = stage
        self._started = time.monotonic()
        self._write(f"{stage} ({index}/{total}) started")
        if self._thread is None:
            self._thread = threading.Thread(target=self._beat, daemon=True)
            self._thread.start()

    def end(self, status: str = "done") -> None:
        """The current stage ends (``status``: ``done`` or ``failed``)."""
        import time

        if self._stage is not None:
            self._write(f"{self._stage} {status} in {time.monotonic() - self._started:.1f} s")
        self._stage = None

    def close(self) -> None:
        """Stop the heartbeat."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None

    def __enter__(self) -> StageLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def count_line(job: str, counts: dict[str, int], stream: Any = None) -> str:
    """Write one time-stamped line of task counts (``done 3/8, running 2, ...``).

    For jobs of many tasks (a sweep's variants): the caller writes one whenever a task
    ends and at least once a minute while none does.

    Parameters
    ----------
    job : str
        Prefix of the line.
    counts : dict
        ``total`` and the count of each state, in the order to show.
    stream : file-like, optional
        Where to write (default: ``sys.stderr``).

    Returns
    -------
    str
        The line written (without the time stamp).
    """
    import time

    total = counts.get("total")
    parts = [f"{state} {n}" + (f"/{total}" if state == "done" and total else "")
             for state, n in counts.items() if state != "total"]
    text = f"{job}: " + ", ".join(parts)
    print(f"[{time.strftime('%H:%M:%S')}] {text}", file=stream or sys.stderr, flush=True)
    return text
