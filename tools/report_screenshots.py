"""Screenshots of case reports for the documentation (docs/guide/cases.md): the first screen of each report.

Run the cases, then this script on their report folders::

    widesky run cases/pv_plant -o /tmp/reports/report-pv_plant
    widesky run cases/facade -o /tmp/reports/report-facade
    python tools/report_screenshots.py /tmp/reports/report-pv_plant /tmp/reports/report-facade

It writes ``docs/figures/report-<case>.png`` (the name after ``report-``; 1000 x 1300 CSS pixels of the page from
its top: the "At a glance" box and what follows) and, with ``--full``, ``report-<case>-full.png`` (the whole page).
Needs Playwright and a Chromium executable (``chromium`` on the PATH or ``WIDESKY_CHROMIUM``), as
benchmarks/bench_explorer.py.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "docs" / "figures"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reports", nargs="+", type=Path, help="report folders (holding index.html)")
    ap.add_argument("--height", type=int, default=1300, help="screenshot height [CSS pixels]")
    ap.add_argument("--full", action="store_true", help="also the whole page")
    ap.add_argument("--out", type=Path, default=OUT, help="output folder")
    a = ap.parse_args(argv)
    from playwright.sync_api import sync_playwright

    exe = os.environ.get("WIDESKY_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    a.out.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1000, "height": a.height})
        for rep in a.reports:
            index = rep.resolve() / "index.html"
            if not index.is_file():
                sys.exit(f"{rep}: no index.html (not a report folder)")
            name = rep.resolve().name.removeprefix("report-")
            page.goto(index.as_uri())
            page.screenshot(path=str(a.out / f"report-{name}.png"))
            if a.full:
                page.screenshot(path=str(a.out / f"report-{name}-full.png"), full_page=True)
            print(a.out / f"report-{name}.png")
        browser.close()


if __name__ == "__main__":
    main()
