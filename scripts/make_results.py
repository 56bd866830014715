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
import signal
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
    "rigs_efficiency": [sys.executable, "-m", "msd_bench.cli", "efficiency", "--rigs", "100",
                        "--first-rig", "1000", "--seeds", "4",
                        "--agents", "plm+robust,nlarx-improved+robust,greybox+robust"],
    "rigs_efficiency_refine": [sys.executable, "-m", "msd_bench.cli", "efficiency", "--rigs", "100",
                               "--first-rig", "1000", "--seeds", "4",
                               "--agents", "nlarx-improved+robust,greybox+robust,plant,dyna-q",
                               "--refine", "2", "--record-samples", "300", "--budgets", "30,300",
                               "--workers", "1"],
    "table1_baselines": [*PAPER, "--seeds", "3", "--id-seeds", "3", "--agents",
                         "glm+pid,glm+pid-continuous,greybox+lqr,plm+mpc,plm+robust,greybox+robust"],
}
"""Named results: the exact ``msd-bench paper`` arguments behind each README table (``--out`` added)."""

RIG_RUNS: dict[str, list[str]] = {
    "rig_full": ["launch_scripts/bench.py", "--plant-ns", "/rig"],
}
"""Named runs of the main job against the rig emulator (``launch_scripts/rig.py``, defaults), real time."""
RIG_DOMAIN = 231
"""The rig run's ROS domain: the rig and the bench must share one, no other run may use it."""

BENCHMARKS: dict[str, list[list[str]]] = {
    "performance": [["benchmarks/bench_training.py"], ["benchmarks/bench_lockstep.py"],
                    ["benchmarks/bench_plant_rate.py"], ["benchmarks/bench_bench.py"]],
    "silverbox": [["scripts/silverbox.py"]],
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
    """The commit the numbers came from (``+dirty`` when the tree had uncommitted changes).

    Stored results (``docs/results/``) do not count: they are what these commands write, not code
    that ran, so regenerating several files one after another does not mark the later ones dirty."""
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True,
                          text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".",
                            ":(exclude)docs/results"],
                           cwd=REPO, capture_output=True, text=True).stdout.strip()
    return head + ("+dirty" if dirty else "")


def provenance(script: str, argv: list[str] | None) -> dict[str, Any]:
    """Command, commit and machine of a results script, taken before it runs (the commit is the code
    that ran); ``argv`` None means this process's own arguments."""
    import shlex

    shown = shlex.join(sys.argv[1:] if argv is None else argv)
    return {"command": f"scripts/{script} {shown}", "commit": commit(), "machine": machine()}


def outputs(out: Path, name: str = "efficiency") -> dict[str, Any]:
    """The JSON a command wrote, without per-seed rows (they stay in the run's own files); its
    efficiency figure, if any, is stored as ``<name>.png``."""
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
            cell.pop("risks", None)  # per-run risk records: the cell's summary stays
    if (out / "efficiency.png").is_file():
        shutil.copyfile(out / "efficiency.png", RESULTS / f"{name}.png")
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
        return store(name, out, commit(), seconds)


def store(name: str, out: Path, ran_at: str, seconds: float) -> Path:
    """Store the JSON outputs of a finished run of the named command in ``out``, with the commit it ran
    at and its wall time. Why apart from :func:`run`: a sweep of hours runs on its own (resumable in
    its run directory, beside other work) and is stored when it has finished."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    doc = {
        "name": name,
        "command": " ".join(["msd-bench", *COMMANDS[name][3:]]),
        "commit": ran_at,
        "machine": machine(),
        "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "seconds": round(seconds, 1),
        **outputs(out, name),
    }
    path = RESULTS / f"{name}.json"
    from msd_bench.io.storage.atomic import write_text_atomic

    write_text_atomic(path, json.dumps(doc, indent=1) + "\n")
    return path


def run_rig(name: str) -> Path:
    """Start the rig emulator, run the main job against it at full size, store its report's JSON."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(RIG_DOMAIN), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    with tempfile.TemporaryDirectory(prefix=f"results_{name}_") as tmp:
        out = Path(tmp) / "run"
        rig = subprocess.Popen([sys.executable, "launch_scripts/rig.py"], cwd=REPO, env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            time.sleep(5.0)  # the bench waits for the node's topics too; this only spares it the wait
            t0 = time.perf_counter()
            argv = [sys.executable, *RIG_RUNS[name], "--out", str(out)]
            proc = subprocess.run(argv, cwd=REPO, env=env, capture_output=True, text=True)
            seconds = time.perf_counter() - t0
        finally:
            rig.send_signal(signal.SIGINT)
            rig.wait(timeout=30)
        if proc.returncode != 0:
            sys.exit(f"{name}: bench.py failed ({proc.returncode}): {proc.stderr.strip()[-800:]}")
        doc = {
            "name": name,
            "command": "python launch_scripts/rig.py & python " + " ".join(RIG_RUNS[name]),
            "commit": commit(),
            "machine": machine(),
            "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
            "seconds": round(seconds, 1),
            "stage_seconds": json.loads((out / "run.json").read_text()).get("timings", {}),
            "log_tail": [ln for ln in proc.stdout.splitlines() if "\r" not in ln][-60:],
            **outputs(out / "report"),
        }
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
    names = ", ".join([*COMMANDS, *RIG_RUNS, *BENCHMARKS])
    p.add_argument("names", nargs="*", help=f"results to make: {names}")
    p.add_argument("--list", action="store_true", help="print the named commands and exit")
    p.add_argument("--from-run", type=Path, metavar="DIR",
                   help="store the finished run directory DIR of the one named command instead of running it")
    p.add_argument("--ran-at", metavar="COMMIT", help="with --from-run: the commit the run ran at")
    args = p.parse_args()
    if args.from_run is not None:
        return _from_run(args.names, args.from_run, args.ran_at)
    if args.list or not args.names:
        for name, argv in COMMANDS.items():
            print(f"{name}: msd-bench {' '.join(argv[3:])}")
        for name, argv in RIG_RUNS.items():
            print(f"{name}: python launch_scripts/rig.py & python {' '.join(argv)}  (about an hour)")
        for name, cmds in BENCHMARKS.items():
            print(f"{name}: " + "; ".join(" ".join(c) for c in cmds))
        return 0
    unknown = [n for n in args.names if n not in {*COMMANDS, *RIG_RUNS, *BENCHMARKS}]
    if unknown:
        known = ", ".join([*COMMANDS, *RIG_RUNS, *BENCHMARKS])
        print(f"make_results: error: unknown result {unknown[0]!r}; choose from {known}", file=sys.stderr)
        return 2
    for name in args.names:
        if name in BENCHMARKS:
            print(run_benchmarks(name))
        else:
            print(run_rig(name) if name in RIG_RUNS else run(name))
    return 0


def _from_run(names: list[str], out: Path, ran_at: str | None) -> int:
    """``--from-run``: one named command's finished run stored, its wall time the run's own."""
    if len(names) != 1 or names[0] not in COMMANDS or not ran_at:
        print("make_results: error: --from-run needs one named command and --ran-at COMMIT", file=sys.stderr)
        return 2
    if not (out / "complete").is_file():
        print(f"make_results: error: {out} is not a finished run directory (no 'complete' marker)",
              file=sys.stderr)
        return 2
    # the run's wall time: from its manifest (written before the first task) to its completion marker
    seconds = (out / "complete").stat().st_mtime - (out / "manifest.json").stat().st_mtime
    print(store(names[0], out, ran_at, seconds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
