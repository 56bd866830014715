"""launch_scripts/supervisor.py as a real process: it starts and prints its limits, and a bad
options file is one line and exit 2 (for the node and for bench.py's --supervisor-params)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from msd_bench.graph import launch

pytestmark = pytest.mark.e2e


def test_a_bad_options_file_exits_with_one_line(tmp_path: Path) -> None:
    opts = tmp_path / "opts.json"
    opts.write_text('{"envelope": 2.45, "margin": 0.1}')
    proc = launch.start("supervisor.py", ["-p", f"options_file:={opts}"])
    assert proc.wait(120.0) == 2
    time.sleep(0.1)  # let the reader thread collect the last line
    lines = [ln for ln in proc.lines if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "must stay below the stop" in lines[0]


def test_it_prints_its_limits_and_stops_cleanly() -> None:
    proc = launch.start("supervisor.py", [])
    proc.wait_for_line("supervisor: envelope ±2.25 m", timeout=30.0)
    assert launch.stop(proc) == 0


def test_bench_with_a_bad_params_file_is_one_line_and_starts_nothing(tmp_path: Path) -> None:
    """bench.py --plant-ns with a --supervisor-params file whose envelope reaches the stop: one line,
    exit 2, before any node process starts or --out is written."""
    opts = tmp_path / "opts.json"
    opts.write_text('{"envelope": 2.45, "margin": 0.1}')
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "launch_scripts/bench.py", "--plant-ns", "/nowhere",
                           "--supervisor-params", str(opts), "--out", str(out)],
                          cwd=launch.REPO_ROOT, capture_output=True, text=True, timeout=120,
                          env=launch.ros_env(int(os.environ["ROS_DOMAIN_ID"])))
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"bench: error: --supervisor-params {opts}: ")
    assert "must stay below the stop" in lines[0] and "Traceback" not in proc.stderr
    assert not out.exists()
