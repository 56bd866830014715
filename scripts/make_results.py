"""Run a named results command and store what it wrote as ``docs/results/<name>.json``.

Every number in the README comes from one of these files (through
``scripts/readme_results.py``), and each file records the command, the commit
and the machine that produced it, so a reader can rerun it:

    python scripts/make_results.py table1_default     # runs msd-bench paper ..., writes the JSON
    python scripts/make_results.py --list
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as dt
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "docs" / "results"

PAPER = [sys.executable, "-m", "msd_bench.cli", "paper", "--no-figures"]
SURROGATE_ROWS = ",".join(f"{m}{d}" for d in ("", "+improved", "+robust") for m in ("plm", "nlarx-improved",
                                                                                      "greybox"))
COMMANDS: dict[str, list[str]] = {
    "table1_default": [*PAPER, "--seeds", "64"],
    "table1_idseeds": [*PAPER, "--seeds", "64", "--id-seeds", "3", "--id-first-seed", "1",
                       "--first-seed", "1000", "--agents", SURROGATE_ROWS],
    "table1_shaping": [*PAPER, "--seeds", "64", "--agents",
                       ",".join(f"{m}@{r}" for m in ("plant", "plm", "nlarx-improved", "glm")
                                for r in ("away", "toward"))],
    "robust_check": [*PAPER, "--seeds", "20", "--id-first-seed", "7", "--first-seed", "500", "--agents",
                     "plm+robust,nlarx-improved+robust"],
    "table1_noisy_id": [*PAPER, "--seeds", "2", "--id-seeds", "3", "--record-noise", "0.002", "--agents",
                        "greybox,nlarx-improved,plm"],
    "efficiency": [sys.executable, "-m", "msd_bench.cli", "efficiency"],
}
"""Named results: the exact ``msd-bench paper`` arguments behind each README table (``--out`` added)."""

BENCHMARKS: dict[str, list[list[str]]] = {
    "performance": [["benchmarks/bench_training.py"], ["benchmarks/bench_lockstep.py"],
                    ["benchmarks/bench_plant_rate.py"], ["benchmarks/bench_bench.py"]],
}
"""Named benchmark suites: each script prints one JSON object, stored under its file's stem."""


def machine() -> dict[str, str | int | None]:
    """What the numbers were measured on (seeds reproduce bit for bit only on the same CPU)."""
    cpu = ""
    with contextlib.suppress(OSError, StopIteration):
        cpu = next(ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines()
                   if ln.startswith("model name"))
    return {"cpu": cpu or platform.processor(), "cores": os.cpu_count(), "python": platform.python_version(),
            "system": platform.platform()}


def commit() -> str:
    """The commit the numbers came from (``+dirty`` when the tree had uncommitted changes)."""
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True,
                          text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO,
                           capture_output=True, text=True).stdout.strip()
    return head + ("+dirty" if dirty else "")


def outputs(out: Path) -> dict[str, Any]:
    """The JSON a command wrote, without per-seed rows (they stay in the run's own files)."""
    found: dict[str, Any] = {}
    for key in ("table1", "robustness", "efficiency"):
        if (out / f"{key}.json").is_file():
            found[key] = json.loads((out / f"{key}.json").read_text())
    for agent in found.get("table1", {}).get("agents", []):
        agent.pop("per_seed", None)
    for agent in found.get("robustness", {}).get("agents", []):
        for cell in agent["cells"].values():
            cell.pop("sse", None)
            cell.pop("mae", None)
    if (out / "efficiency.png").is_file():
        shutil.copyfile(out / "efficiency.png", RESULTS / "efficiency.png")
    return found


def run(name: str) -> Path:
    """Run the named command into a temporary directory and store its JSON outputs."""
    with tempfile.TemporaryDirectory(prefix=f"results_{name}_") as tmp:
        out = Path(tmp) / "out"
        argv = [*COMMANDS[name], "--out", str(out)]
        t0 = time.perf_counter()
        proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True)
        seconds = time.perf_counter() - t0
        if proc.returncode != 0:
            sys.exit(f"{name}: command failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
        doc = {
            "name": name,
            "command": " ".join(["msd-bench", *argv[3:-2]]),
            "commit": commit(),
            "machine": machine(),
            "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
            "seconds": round(seconds, 1),
            **outputs(out),
        }
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps(doc, indent=1) + "\n")
    return path


def run_benchmarks(name: str) -> Path:
    """Run a named benchmark suite one script at a time and store every script's JSON."""
    results: dict[str, Any] = {}
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    for script, *args in BENCHMARKS[name]:
        proc = subprocess.run([sys.executable, script, *args], cwd=REPO, capture_output=True, text=True)
        if proc.returncode != 0:
            sys.exit(f"{name}: {script} failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
        results[Path(script).stem] = json.loads(proc.stdout)
    doc = {
        "name": name,
        "commands": [" ".join(["python", *cmd]) for cmd in BENCHMARKS[name]],
        "commit": commit(),
        "machine": machine(),
        "loadavg_1min_before": round(load_before, 2),
        "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "seconds": round(time.perf_counter() - t0, 1),
        "benchmarks": results,
    }
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps(doc, indent=1) + "\n")
    return path


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("names", nargs="*", help=f"results to make: {', '.join([*COMMANDS, *BENCHMARKS])}")
    p.add_argument("--list", action="store_true", help="print the named commands and exit")
    args = p.parse_args()
    if args.list or not args.names:
        for name, argv in COMMANDS.items():
            print(f"{name}: msd-bench {' '.join(argv[3:])}")
        for name, cmds in BENCHMARKS.items():
            print(f"{name}: " + "; ".join(" ".join(c) for c in cmds))
        return 0
    unknown = [n for n in args.names if n not in COMMANDS and n not in BENCHMARKS]
    if unknown:
        known = ", ".join([*COMMANDS, *BENCHMARKS])
        print(f"make_results: error: unknown result {unknown[0]!r}; choose from {known}", file=sys.stderr)
        return 2
    for name in args.names:
        print(run_benchmarks(name) if name in BENCHMARKS else run(name))
    return 0


if __name__ == "__main__":
    sys.exit(main())
