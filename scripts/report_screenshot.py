"""Open a trackroom report in a real headless browser, check it rendered, take a screenshot.

    python -m scripts.report_screenshot cmp/report.html --out docs/img/report.png

Checks (``inspect_report``): every image decoded (``naturalWidth > 0``), the summary table has
rows, and the page logged no console error or uncaught exception. The browser is Playwright's
Chromium when ``playwright install chromium`` has fetched it, else the system's Chromium
(Debian: ``apt-get install chromium``); ``find_browser`` says which, or why none.
``tests/test_report_browser.py`` runs the same checks on a report from a small comparison.
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

SYSTEM_BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_browser(playwright) -> tuple[dict | None, str]:
    """Launch options for a working headless Chromium, or (None, the reason there is none)."""
    tried = []
    for options in [{}] + [{"executable_path": p} for p in filter(None, map(shutil.which, SYSTEM_BROWSERS))]:
        try:
            playwright.chromium.launch(args=["--no-sandbox"], **options).close()
            return options, ""
        except Exception as e:  # a missing or broken browser: try the next
            tried.append(f"{options.get('executable_path', 'playwright chromium')}: {str(e).splitlines()[0]}")
    return None, "no headless Chromium: " + "; ".join(tried or ["none found"])


def inspect_report(html: Path, screenshot: Path | None = None, options: dict | None = None,
                   width: int = 1280, height: int = 1000, full_page: bool = False) -> dict:
    """Open ``html``; returns ``images`` (natural widths), ``summary_rows``, ``runs_rows``,
    ``errors`` (console errors and page exceptions); writes ``screenshot`` when given."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        if options is None:
            options, why = find_browser(p)
            if options is None:
                raise RuntimeError(why)
        browser = p.chromium.launch(args=["--no-sandbox"], **options)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            errors: list[str] = []
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(Path(html).resolve().as_uri(), wait_until="load")
            page.wait_for_function("Array.from(document.images).every(i => i.complete)")
            images = page.evaluate("Array.from(document.images).map(i => i.naturalWidth)")
            summary_rows = page.locator("#summary-table tbody tr").count()
            runs_rows = page.locator("#runs-table tbody tr").count()
            # sorting works: a click on the first header marks it ascending
            page.locator("#summary-table th").first.click()
            sorted_asc = "asc" in (page.locator("#summary-table th").first.get_attribute("class") or "")
            if screenshot is not None:
                Path(screenshot).parent.mkdir(parents=True, exist_ok=True)
                page.screenshot(path=str(screenshot), full_page=full_page)
        finally:
            browser.close()
    return {"images": images, "summary_rows": summary_rows, "runs_rows": runs_rows, "sorted": sorted_asc,
            "errors": errors}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("html", type=Path)
    ap.add_argument("--out", type=Path, default=Path("report.png"))
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=1000)
    ap.add_argument("--full-page", action="store_true")
    a = ap.parse_args(argv)
    r = inspect_report(a.html, a.out, width=a.width, height=a.height, full_page=a.full_page)
    print(f"{len(r['images'])} images (broken: {sum(w == 0 for w in r['images'])}), summary rows {r['summary_rows']}, "
          f"console errors {len(r['errors'])}; wrote {a.out}")
    return 0 if r["images"] and all(r["images"]) and not r["errors"] else 1


if __name__ == "__main__":
    sys.exit(main())
