"""scripts/rig_realtime.py refuses what it must before any run: an existing result, a design rig."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "scripts/rig_realtime.py", *args], cwd=REPO, capture_output=True,
                          text=True, timeout=120)


@pytest.mark.parametrize(("extra", "says"), [
    (["--first-rig", "5"], "held-out rigs only"),
    (["--first-rig", "999999", "--rigs", "2"], "held-out rigs only"),
    (["--rigs", "0"], "--rigs must be between 1 and 20"),
])
def test_a_bad_request_is_one_line_before_any_run(tmp_path: Path, extra: list[str], says: str) -> None:
    proc = _run("--out", str(tmp_path / "r.json"), *extra)
    assert proc.returncode == 2 and says in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "r.json").exists()


def test_an_existing_result_is_never_overwritten(tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    out.write_text("theirs")
    proc = _run("--out", str(out))
    assert proc.returncode == 2 and "exists" in proc.stderr and out.read_text() == "theirs"
