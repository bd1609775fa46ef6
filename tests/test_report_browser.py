"""The report in a real headless browser: every image decodes, the tables render and sort, no
console errors; a screenshot is taken (``scripts/report_screenshot.py`` does the browsing).

Needs Playwright (``pip install playwright``) and a Chromium: Playwright's own (``playwright install
chromium``) or the system's (Debian: ``apt-get install chromium``). Without either the test is
skipped, saying which is missing.
"""
from __future__ import annotations

import pytest

from trackroom.cli import main


@pytest.fixture(scope="module")
def browser_options():
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install playwright)")
    from scripts.report_screenshot import find_browser

    with sync_api.sync_playwright() as p:
        options, why = find_browser(p)
    if options is None:
        pytest.skip(f"{why} (playwright install chromium, or apt-get install chromium)")
    return options


def test_report_renders_in_a_headless_browser(browser_options, tmp_path):
    from scripts.report_screenshot import inspect_report

    out = tmp_path / "cmp"
    assert main(["compare", "--scenes", "occlusion_lab", "--seeds", "0-1", "--estimators",
                 "ekf,target_planes[multi_person=true]", "--duration", "3", "--out", str(out), "--html", "--quiet"]) == 0
    shot = tmp_path / "report.png"
    r = inspect_report(out / "report.html", shot, browser_options, full_page=True)
    # a plot per metric in PLOT_METRICS, the error over time, the top-down view and the status timeline
    from trackroom.compare import PLOT_METRICS

    assert len(r["images"]) == len(PLOT_METRICS) + 3 and all(w > 0 for w in r["images"]), r["images"]
    assert r["summary_rows"] == 2 and r["runs_rows"] == 4 and r["sorted"]
    assert r["errors"] == []
    import cv2

    img = cv2.imread(str(shot))
    assert img is not None and img.shape[1] == 1280 and img.shape[0] > 2000  # the whole page
