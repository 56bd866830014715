"""A bad job file, handed to a real node process as bench.py hands it: one line, exit 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from msd_bench.app.config import RunConfig
from msd_bench.graph.bench import BenchConfig, identifier_job

REPO = Path(__file__).resolve().parents[2]


def _identifier(path: Path) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "launch_scripts/identifier.py", "--ros-args", "-p", f"job:={path}"]
    return subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=120)


def test_a_bad_job_file_is_one_line_and_exit_2(tmp_path):
    """One process (a node start costs seconds): the other bad files are tests/graph/test_job.py's."""
    path, needle = tmp_path / "identifier.json", "field dt: -1.0 is outside"
    doc = identifier_job(BenchConfig(run_dir=tmp_path, run=RunConfig(agents=("glm",))))
    path.write_text(json.dumps({**doc, "params": {**doc["params"], "dt": -1.0}}))
    proc = _identifier(path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    err = proc.stderr.strip()
    assert err.count("\n") == 0 and needle in err and str(path) in err, err
    assert "Traceback" not in proc.stdout + proc.stderr
