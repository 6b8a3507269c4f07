"""report.html in a real headless browser (Debian ``chromium``): DOM, images, screenshot.

The browser renders the page from ``file://`` with no network; the test reads the
DOM it dumps (``--dump-dom``), checks that every section and its heading is there,
that every image is an inline PNG that decodes to a non-empty picture, cross-checks
numbers against the JSON files beside the report, and saves a screenshot (trimmed to
the page) into the test's tmp_path and into tests/output/report/ (printed).

Inputs: the synthetic folder of ``tests.cam.report_sample`` (always) and the chain's
``chain_small`` fixture when a conftest provides it. Without chromium the test is
skipped, except under CI (``CI=true``) where it fails.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import struct
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

from cam.report import SECTION_IDS, build_report
from cam.report.html import format_number
from tests.cam.report_sample import write_sample

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "tests" / "output" / "report"
WIDTH = 1400
#: Window height of the screenshot; the picture is trimmed to the page afterwards.
HEIGHT = 16000
TIMEOUT_S = 180
HEADINGS = {
    "summary": "Summary", "render": "Impeller", "toolpaths": "Tool paths",
    "stock": "Stock after roughing and finishing", "deviation": "Deviation from the design",
    "angles": "A/C angular displacement before and after smoothing",
    "umr": "Unit machining regions (UMR)", "cycle-time": "Cycle time",
    "indexing": "Indexing-time optimisation", "servo": "Predicted servo deviation",
    "events": "Verification events",
}


def chromium() -> str:
    """Path of the chromium binary; skip (or fail under CI) when it is missing."""
    found = shutil.which("chromium") or (
        "/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)
    if found is None:
        message = "chromium not installed (Debian package chromium; scripts/setup.sh --dev)"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(message)
        pytest.skip(message)
    return found


def browser(binary: str, profile: Path, *args: str) -> subprocess.CompletedProcess[str]:
    command = [binary, "--headless", "--no-sandbox", "--disable-gpu",
               "--disable-background-networking", "--hide-scrollbars",
               "--no-first-run", f"--user-data-dir={profile}", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT_S,
                          check=False)


class DomReader(HTMLParser):
    """Sections (id -> heading, text) and image sources of a dumped DOM."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.sections: dict[str, dict[str, str]] = {}
        self.images: list[tuple[str | None, str | None]] = []  # (section, src)
        self.current: str | None = None
        self.in_heading = False
        self.tags: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        attributes = dict(attrs)
        if tag == "section":
            self.current = attributes.get("id")
            if self.current is not None:
                self.sections[self.current] = {"heading": "", "text": ""}
        elif tag == "h2" and self.current is not None:
            self.in_heading = True
        elif tag == "img":
            self.images.append((self.current, attributes.get("src")))
        self.tags.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag == "section":
            self.current = None
        elif tag == "h2":
            self.in_heading = False

    def handle_data(self, data: str) -> None:
        if self.current is None:
            return
        if self.in_heading:
            self.sections[self.current]["heading"] += data
        self.sections[self.current]["text"] += " " + data


def png_size(data: bytes) -> tuple[int, int]:
    assert data.startswith(b"\x89PNG\r\n\x1a\n"), "not a PNG"
    assert data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    return int(width), int(height)


def trimmed_screenshot(raw: Path, target: Path) -> tuple[int, int]:
    """Cut the white band below the page off the screenshot; returns (width, height)."""
    import numpy as np
    from PIL import Image

    image = Image.open(raw).convert("RGB")
    pixels = np.asarray(image)
    ink = np.flatnonzero((pixels < 245).any(axis=(1, 2)))
    assert len(ink), "the screenshot is blank"
    bottom = min(pixels.shape[0], int(ink[-1]) + 40)
    image.crop((0, 0, pixels.shape[1], bottom)).save(target)
    return pixels.shape[1], bottom


def pictured_sections(out: Path) -> set[str]:
    """Sections that must hold a picture: the stages' renders always, the motion
    sections when motion.json names a plot for them."""
    wanted = {"render", "toolpaths", "stock", "deviation", "angles"}
    motion = json.loads((out / "motion/motion.json").read_text())
    for key in ("indexing", "servo"):
        part = motion.get(key) or {}
        if part.get("plot") or part.get("plots"):
            wanted.add(key)
    return wanted


def expected_numbers(out: Path) -> dict[str, list[str]]:
    """Numbers from the JSON files that must appear in a section's text, as the report
    formats them (``format_number`` with the section's digits)."""
    expect: dict[str, list[str]] = {}
    rough = json.loads((out / "rough/rough.json").read_text())
    umr = rough["umrs"][0]
    expect["umr"] = [format_number(umr["A_deg"]), format_number(umr["C_deg"])]
    expect["cycle-time"] = [format_number(rough["time_min"]["3axis"]["1000"], 2)]
    if "5axis" in rough["time_min"]:  # a ``rough --compare`` run
        expect["cycle-time"].append(format_number(rough["time_min"]["5axis"]["2000"], 2))
    motion = json.loads((out / "motion/motion.json").read_text())
    expect["cycle-time"].append(format_number(motion["total_s"], 1))
    counts = []
    for stage in ("rough", "finish"):
        verify = json.loads((out / f"verify/{stage}/verify.json").read_text())
        counts.append(str(sum(int(v) for v in verify["event_counts"].values())))
    expect["events"] = counts
    run = json.loads((out / "run.json").read_text())
    seconds = [s["seconds"] for s in run["stages"] if isinstance(s.get("seconds"), float)]
    expect["summary"] = [format_number(seconds[0], 1)] if seconds else []
    return expect


def check_report(out: Path, name: str, tmp_path: Path) -> None:
    binary = chromium()
    report = build_report(out)
    url = report.resolve().as_uri()
    profile = tmp_path / "chromium-profile"
    dumped = browser(binary, profile, "--dump-dom", url)
    assert dumped.returncode == 0, dumped.stderr[-2000:]
    dom = DomReader()
    dom.feed(dumped.stdout)
    # every section, with its heading, in order
    assert tuple(dom.sections) == SECTION_IDS
    for section_id, heading in HEADINGS.items():
        assert dom.sections[section_id]["heading"].strip() == heading
        assert dom.sections[section_id]["text"].strip() != heading  # not blank
    assert "script" not in dom.tags
    # every image inline and decodable
    assert dom.images, "no images in the report"
    for section, src in dom.images:
        assert src is not None and src.startswith("data:image/png;base64,"), (section, src)
        width, height = png_size(base64.b64decode(src.split(",", 1)[1], validate=True))
        assert width > 0 and height > 0
    with_images = {section for section, _ in dom.images}
    assert pictured_sections(out) <= with_images
    # numbers in the DOM are those of the JSON files
    for section_id, numbers in expected_numbers(out).items():
        text = " ".join(dom.sections[section_id]["text"].split())
        for number in numbers:
            assert number in text, (section_id, number)
    # screenshot
    raw = tmp_path / "screenshot-raw.png"
    shot = browser(binary, profile, f"--window-size={WIDTH},{HEIGHT}",
                   f"--screenshot={raw}", url)
    assert shot.returncode == 0 and raw.is_file(), shot.stderr[-2000:]
    target = tmp_path / f"report-{name}.png"
    width, height = trimmed_screenshot(raw, target)
    assert width == WIDTH and height > 1000
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    stable = ARTIFACTS / target.name
    shutil.copyfile(target, stable)
    print(f"report screenshot: {stable} ({width} x {height} px); report: {report}")


def test_report_in_browser_synthetic(tmp_path: Path) -> None:
    out = write_sample(tmp_path / "out")
    check_report(out, "synthetic", tmp_path)


def test_report_in_browser_chain_small(request: pytest.FixtureRequest,
                                       tmp_path: Path) -> None:
    try:
        out = request.getfixturevalue("chain_small")
    except pytest.FixtureLookupError:
        pytest.skip("no chain_small fixture (the chain's conftest provides it)")
    chromium()
    work = tmp_path / "out"
    shutil.copytree(Path(out), work)  # the report is written beside the chain's files
    check_report(work, "chain_small", tmp_path)
