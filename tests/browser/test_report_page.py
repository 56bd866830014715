"""A real ``msd-bench paper`` run's ``index.html`` in headless Chromium: every table and figure, no request.

The run is a small one (two agent kinds, two seeds, short budgets, the standard
scenarios, figures on), made once for the module. The page is opened from
disk as a browser would open a report someone sent; the counts are checked
against the run's own ``table1.json``, ``robustness.json`` and ``figures/``.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from msd_bench.io.reports.html_report import write_index
from tests.browser.cdp import CHROMIUM, Browser, console_errors, network_requests, open_page

pytestmark = pytest.mark.browser

if not CHROMIUM.exists():  # one line in the summary (-ra) for the whole tier, not one per test
    pytest.skip(f"browser tier skipped (tests/browser): {CHROMIUM} not found; apt-get install -y chromium "
                "(.ci/run installs it)", allow_module_level=True)

PAPER = ["paper", "--seeds", "2", "--id-seeds", "1", "--episodes", "2", "--steps", "100", "--samples", "300",
         "--val-samples", "300", "--validation-steps", "100", "--agents", "glm,glm+improved"]
"""A paper run of about ten seconds of CPU: Table 1, the standard scenarios' robustness, four figures."""


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("paper") / "run"
    proc = subprocess.run([sys.executable, "-m", "msd_bench.cli", *PAPER, "--out", str(out)],
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return out


def _json(path: Path) -> Any:
    return json.loads(path.read_text())


def test_the_page_holds_every_table_and_figure_and_asks_for_nothing(run_dir: Path, browser: Browser) -> None:
    table1, rob = _json(run_dir / "table1.json"), _json(run_dir / "robustness.json")
    figures = sorted(p.name for p in (run_dir / "figures").glob("*.png"))
    assert len(table1["agents"]) == 2 and rob["scenarios"] and len(figures) >= 3
    open_page(browser, run_dir / "index.html")
    sections = browser.evaluate("Object.fromEntries([...document.querySelectorAll('section')].map(s => "
                                "[s.querySelector('h2').textContent, s.querySelectorAll('table').length]))")
    assert {"Table 1", "Robustness", "Figures", "Configuration", "Provenance"} <= set(sections)
    assert sections["Table 1"] == 1 and sections["Robustness"] == 1
    rows = browser.evaluate("[...document.querySelectorAll('section')].find(s => s.querySelector('h2')"
                            ".textContent == 'Table 1').querySelectorAll('tbody tr').length")
    assert rows == len(table1["agents"])
    heat = browser.evaluate("[...document.querySelectorAll('table.heat tbody tr')].map(r => "
                            "r.querySelectorAll('td').length)")
    assert heat == [len(rob["scenarios"])] * len(rob["agents"])
    images = browser.evaluate("[...document.images].map(i => [i.alt, i.complete && i.naturalWidth > 0])")
    assert sorted(alt for alt, _ in images) == [f"figures/{name}" for name in figures]
    assert all(decoded for _, decoded in images)  # each data: URI is a PNG the browser could draw
    assert network_requests(browser) == []
    assert console_errors(browser) == []


def test_markup_in_a_run_file_stays_text_in_the_browser(run_dir: Path, browser: Browser,
                                                        tmp_path: Path) -> None:
    """A received run whose kind label is a script: the browser shows the text and runs nothing."""
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    doc = _json(copy / "table1.json")
    doc["agents"][0]["label"] = "<script>console.error('ran')</script><img src=x onerror=console.error(1)>"
    (copy / "table1.json").write_text(json.dumps(doc))
    write_index(copy, root=copy, title="received run")
    open_page(browser, copy / "index.html")
    assert browser.evaluate("document.scripts.length") == 0
    assert "<script>console.error('ran')</script>" in browser.evaluate("document.body.innerText")
    assert console_errors(browser) == [] and network_requests(browser) == []


def test_the_checks_catch_a_page_that_reaches_out(run_dir: Path, browser: Browser, tmp_path: Path) -> None:
    """The two detectors are not vacuous: an image from a server is blocked by the page's policy and seen."""
    page = tmp_path / "index.html"
    page.write_text((run_dir / "index.html").read_text().replace(
        "</body>", "<img src=\"http://127.0.0.1:9/x.png\"></body>"))
    open_page(browser, page)
    assert network_requests(browser) or console_errors(browser)
