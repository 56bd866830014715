"""bench.py with only kinds that learn on the plant: nothing to identify, so no identifier runs.

Before, the identifier was handed an empty list of model kinds and the run failed
(``identifier failed (exit 2): … model kinds must be given once each, got []``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.e2e
REPO = Path(__file__).resolve().parents[2]


def test_a_run_of_dyna_q_alone_completes_without_identifying(tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = [sys.executable, "launch_scripts/bench.py", "--agents", "dyna-q", "--seeds", "1",
            "--episodes", "2", "--steps", "200", "--samples", "600", "--val-samples", "400",
            "--validation-steps", "400",
            "--out", str(out), "--domain-id", os.environ["ROS_DOMAIN_ID"]]
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "identifying surrogates" not in proc.stderr + proc.stdout
    rows = json.loads((out / "report" / "table1.json").read_text())["agents"]
    assert [r["kind"] for r in rows] == ["dyna-q"] and len(rows[0]["per_seed"]) == 1
    assert rows[0]["real_interactions"] > 0
    assert not (out / "models" / "fits.json").exists()
