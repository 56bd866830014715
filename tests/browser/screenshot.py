"""Remake the report screenshot in docs/: a run's ``index.html`` drawn by headless Chromium as a PNG.

Usage (from the checkout, after ``apt-get install -y chromium``)::

    .venv/bin/python -m msd_bench.cli paper --seeds 3 --agents glm,plm,greybox,plm+improved,plm+robust \\
        --out /tmp/report-run
    .venv/bin/python -m tests.browser.screenshot /tmp/report-run/index.html docs/img/report.png

The picture is the page's first ``--height`` pixels at 1280 px wide (its
first screen and a half: Table 1, the robustness heat map, the first figures).
It refuses to overwrite a file that is not a PNG.
"""

from __future__ import annotations

import argparse
import base64
import sys
from pathlib import Path

from tests.browser.cdp import CHROMIUM, Browser, console_errors, network_requests, open_page

PNG = b"\x89PNG\r\n\x1a\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="tests.browser.screenshot", description=__doc__.splitlines()[0])
    p.add_argument("page", type=Path, help="a run's index.html")
    p.add_argument("png", type=Path, help="where the screenshot goes (a new file, or a PNG to replace)")
    p.add_argument("--width", type=int, default=1280)
    p.add_argument("--height", type=int, default=1400)
    args = p.parse_args(argv)
    if not CHROMIUM.exists():
        print(f"screenshot: error: {CHROMIUM} not found (apt-get install -y chromium)", file=sys.stderr)
        return 2
    if not args.page.is_file():
        print(f"screenshot: error: {args.page}: no such page", file=sys.stderr)
        return 2
    if args.png.exists() and args.png.read_bytes()[:8] != PNG:
        print(f"screenshot: error: {args.png}: exists and is not a PNG; not overwritten", file=sys.stderr)
        return 2
    with Browser(args.width, args.height) as b:
        b.call("Emulation.setDeviceMetricsOverride", width=args.width, height=args.height,
               deviceScaleFactor=1, mobile=False)
        open_page(b, args.page)
        problems = network_requests(b) + console_errors(b)
        if problems:
            print(f"screenshot: error: the page is not clean: {problems[0]}", file=sys.stderr)
            return 1
        shot = b.call("Page.captureScreenshot", format="png")
    args.png.parent.mkdir(parents=True, exist_ok=True)
    args.png.write_bytes(base64.b64decode(shot["data"]))
    print(f"screenshot: {args.png} ({args.width}x{args.height})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
