"""Run ``make bench``'s command once; store what it printed and wrote as docs/results/bench_sample.json.

The README shows a trimmed sample of the main job's output and how long it
took; like every number there, the sample is generated (by this script) and
checked (``scripts/readme_results.py``, view ``bench_sample``), never typed:

    python scripts/bench_sample.py            # about a minute on 2 idle cores
"""

from __future__ import annotations

import datetime as dt
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from make_results import REPO, RESULTS, commit, machine

COMMAND = ["launch_scripts/bench.py"]
"""What ``make bench`` runs (Makefile: ``bench``), ``--out`` added."""

TOP_DIRS = ("excitation", "models", "agents", "report")


def written(out: Path) -> dict[str, list[str]]:
    """The run's files by top-level directory, relative to the run (bags as directories)."""
    files: dict[str, list[str]] = {}
    for top in TOP_DIRS:
        root = out / top
        paths = sorted(p for p in root.rglob("*") if p.is_file()) if root.is_dir() else []
        files[top] = [p.relative_to(out).as_posix() for p in paths]
    files["."] = sorted(p.name for p in out.iterdir() if p.is_file())
    return files


def printed(stdout: str, stderr: str, out: Path) -> list[str]:
    """What the run printed (stdout, then the lines it said on stderr), progress bars left out and the
    temporary run directory shown as ``bags/<run-id>``."""
    lines = [ln for ln in (stderr + stdout).split("\n") if "\r" not in ln]
    return [ln.replace(str(out), "bags/<run-id>") for ln in lines]


def main() -> int:
    with tempfile.TemporaryDirectory(prefix="bench_sample_") as tmp:
        out = Path(tmp) / "run"
        load_before = os.getloadavg()[0]
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, *COMMAND, "--out", str(out)], cwd=REPO, capture_output=True,
                              text=True, env={**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
        seconds = time.perf_counter() - t0
        if proc.returncode != 0:
            print(f"bench_sample: error: bench.py failed ({proc.returncode}): {proc.stderr.strip()[-500:]}",
                  file=sys.stderr)
            return 1
        doc = {
            "name": "bench_sample",
            "command": "make bench  (python " + " ".join(COMMAND) + ")",
            "commit": commit(),
            "machine": machine(),
            "loadavg_1min_before": round(load_before, 2),
            "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
            "seconds": round(seconds, 1),
            "stage_seconds": json.loads((out / "run.json").read_text()).get("timings", {}),
            "printed": printed(proc.stdout, proc.stderr, out),
            "written": written(out),
        }
    path = RESULTS / "bench_sample.json"
    path.write_text(json.dumps(doc, indent=1) + "\n")
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
