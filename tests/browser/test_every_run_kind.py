"""Every run kind's ``index.html`` in headless Chromium: bench.py, efficiency and rigs beside paper's.

Each page is opened from disk; it must draw every image it holds, show at least one table, ask the
network for nothing and log no console error. bench.py's Table 1 has a row per agent kind.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.browser.cdp import CHROMIUM, Browser, console_errors, network_requests, open_page

pytestmark = pytest.mark.browser
REPO = Path(__file__).resolve().parents[2]

if not CHROMIUM.exists():
    pytest.skip(f"browser tier skipped (tests/browser): {CHROMIUM} not found; apt-get install -y chromium "
                "(.ci/run installs it)", allow_module_level=True)

SMALL = ["--seeds", "1", "--episodes", "2", "--steps", "100", "--validation-steps", "200"]
RUNS = {
    "bench": [sys.executable, "launch_scripts/bench.py", *SMALL, "--samples", "600", "--val-samples", "400",
              "--agents", "glm,glm+pid"],
    "efficiency": [sys.executable, "-m", "msd_bench.cli", "efficiency", "--id-seeds", "1", "--agents",
                   "glm+improved,plant", "--record-samples", "300", "--budgets", "1", *SMALL],
    "rigs": [sys.executable, "-m", "msd_bench.cli", "rigs", "--rigs", "1", "--agents", "glm+robust", *SMALL,
             "--samples", "500", "--val-samples", "400", "--bootstrap", "100", "--workers", "1"],
}
"""A small run of each kind besides paper (tests/browser/test_report_page.py has paper's)."""
PAGES = {"bench": "report/index.html", "efficiency": "index.html", "rigs": "index.html"}


@pytest.fixture(scope="module", params=sorted(RUNS))
def run(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    kind = request.param
    out = tmp_path_factory.mktemp(kind) / "run"
    argv = [*RUNS[kind], "--out", str(out)]
    if kind == "bench":
        argv += ["--domain-id", os.environ["ROS_DOMAIN_ID"]]
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return kind, out


def test_the_page_draws_everything_it_holds_and_asks_for_nothing(run: tuple[str, Path],
                                                                   browser: Browser) -> None:
    kind, out = run
    open_page(browser, out / PAGES[kind])
    assert browser.evaluate("document.querySelectorAll('table').length") >= 1
    images = browser.evaluate("[...document.images].map(i => i.complete && i.naturalWidth > 0)")
    assert all(images)
    if kind == "bench":
        table1 = json.loads((out / "report" / "table1.json").read_text())
        rows = browser.evaluate("[...document.querySelectorAll('section')].find(s => s.querySelector('h2')"
                                ".textContent == 'Table 1').querySelectorAll('tbody tr').length")
        assert rows == len(table1["agents"]) == 2
        assert len(images) == len(list((out / "report" / "figures").glob("*.png"))) > 0
    assert network_requests(browser) == []
    assert console_errors(browser) == []
