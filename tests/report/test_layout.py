"""The report in a real browser at a phone's and a desktop's width: nothing cut off or off screen without a hint,
no label broken inside a word, prediction cards of one size, figures large enough to read (headless Chromium;
skipped where it is not installed: ``apt-get install -y chromium``)."""

from __future__ import annotations

import runpy
import shutil
import sys

import pytest

from tests.util import ROOT

pytestmark = pytest.mark.skipif(not any(shutil.which(c) for c in ("chromium", "chromium-browser", "google-chrome")),
                                reason="no Chromium to look at the page")


@pytest.fixture(scope="module")
def screens():
    sys.path.insert(0, str(ROOT / "bench"))
    try:
        yield runpy.run_path(str(ROOT / "bench" / "report_screens.py"), run_name="imported")
    finally:
        sys.path.remove(str(ROOT / "bench"))


@pytest.mark.parametrize("width", [420, 1400])
def test_the_report_reads_on_a_phone_and_a_desktop(screens, width, tmp_path):
    report = screens["tiny_report"](tmp_path) / "report.html"
    m = screens["measure"](report, width)
    assert m["width"] == width and m["card_widths"] and m["broken_labels"] == []
    assert screens["problems"](m) == []
