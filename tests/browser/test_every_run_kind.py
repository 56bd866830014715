"""Every run kind's ``index.html`` in headless Chromium: efficiency and rigs beside paper's
(tests/browser/test_report_page.py) and bench.py's (tests/e2e/test_bench.py, on that module's run).

Each page is opened from disk; it must draw every image it holds, show at least one table, ask the
network for nothing and log no console error.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.browser.cdp import CHROMIUM, Browser, drawn_images

pytestmark = pytest.mark.browser
REPO = Path(__file__).resolve().parents[2]

if not CHROMIUM.exists():
    pytest.skip(f"browser tier skipped (tests/browser): {CHROMIUM} not found; apt-get install -y chromium "
                "(.ci/run installs it)", allow_module_level=True)

SMALL = ["--seeds", "1", "--episodes", "2", "--steps", "100", "--validation-steps", "200"]
RUNS = {
    "efficiency": [sys.executable, "-m", "msd_bench.cli", "efficiency", "--id-seeds", "1", "--agents",
                   "glm+improved,plant", "--record-samples", "300", "--budgets", "1", *SMALL],
    "rigs": [sys.executable, "-m", "msd_bench.cli", "rigs", "--rigs", "1", "--agents", "glm+robust", *SMALL,
             "--samples", "500", "--val-samples", "400", "--bootstrap", "100", "--workers", "1"],
}
"""A small run of each kind besides paper and bench.py (module docstring)."""


@pytest.fixture(scope="module", params=sorted(RUNS))
def run(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    kind = request.param
    out = tmp_path_factory.mktemp(kind) / "run"
    argv = [*RUNS[kind], "--out", str(out)]
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return kind, out


def test_the_page_draws_everything_it_holds_and_asks_for_nothing(run: tuple[str, Path],
                                                                   browser: Browser) -> None:
    _, out = run
    drawn_images(browser, out / "index.html")
