"""The stage log of long jobs: one line per stage start and end, and a heartbeat."""

from __future__ import annotations

import io
import re
import time

from impeller_cam.progress import StageLog, count_line


def test_stage_lines_and_heartbeat() -> None:
    stream = io.StringIO()
    with StageLog("nine_blade", heartbeat_s=0.05, stream=stream) as log:
        log.start("finish", 3, 7)
        time.sleep(0.3)
        log.end()
        log.start("post", 4, 7)
        log.end("failed")
    lines = stream.getvalue().splitlines()
    assert re.fullmatch(r"\[\d\d:\d\d:\d\d\] nine_blade: finish \(3/7\) started", lines[0])
    beats = [line for line in lines if "finish still running" in line]
    assert len(beats) >= 2  # 0.3 s at one line per 0.05 s
    assert re.search(r"finish done in 0\.\d s$", lines[len(beats) + 1])
    assert lines[-2].endswith("post (4/7) started")
    assert re.search(r"\] nine_blade: post failed in \d+\.\d s$", lines[-1])
    # after close no heartbeat is written any more
    size = len(stream.getvalue())
    time.sleep(0.15)
    assert len(stream.getvalue()) == size


def test_no_heartbeat_between_stages() -> None:
    stream = io.StringIO()
    with StageLog("small", heartbeat_s=0.02, stream=stream) as log:
        log.start("geometry", 1, 7)
        log.end()
        time.sleep(0.1)
    assert "still running" not in stream.getvalue()


def test_count_line() -> None:
    stream = io.StringIO()
    text = count_line("sweep", {"total": 8, "done": 3, "failed": 1, "running": 2}, stream)
    assert text == "sweep: done 3/8, failed 1, running 2"
    assert re.fullmatch(r"\[\d\d:\d\d:\d\d\] sweep: done 3/8, failed 1, running 2\n",
                        stream.getvalue())
