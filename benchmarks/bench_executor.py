"""Speed-up of a sweep on 1 and on 2 workers of a local Ray cluster, in one run (issue: cluster executor).

Runs the same sweep command twice through ``msd-bench`` — ``--executor ray
--workers 1``, then ``--workers 2`` (each worker single-threaded, each run its
own fresh cluster and output directory) — and prints one JSON object: each
run's wall time, the 1-minute load average at the start of each, the tasks a
run held, the seconds per task on one worker, whether both runs wrote the same
result file (field for field, apart from timings), and ``speedup`` =
t(1 worker) / t(2 workers). Floor: ``speedup`` >= 1.5 on the 2-core bench
machine, for a sweep of at least 5 minutes per worker; a loaded machine shows
in the load figures, so judge the ratio beside them. ``--keep FILE`` keeps the
1-worker run's result file (a ``rigs.json`` holds each rig's time per stage,
which docs/cluster.md's arithmetic uses). ``--warmup "ARGS"`` first
runs a small sweep untimed, so numba's on-disk cache is filled before either
timed run (else the first run pays every compilation). ``--out`` also writes the
JSON (never over an existing file) for the generated docs.

    .venv/bin/python benchmarks/bench_executor.py --result efficiency.json [--out f.json] -- \\
        efficiency --seeds 4 --id-seeds 2 ...
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, NoReturn

REPO = Path(__file__).resolve().parents[1]
VOLATILE = {"seconds", "elapsed_s", "machine", "executor", "started_utc", "finished_utc", "timing"}
"""Fields of a result file that may differ between runs (timings, where and how it ran)."""


def fail(message: str) -> NoReturn:
    """A usage mistake: one line on stderr, exit 2, no traceback."""
    print(f"bench_executor: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def stable(doc: Any) -> Any:
    """``doc`` without its volatile fields, at any depth."""
    if isinstance(doc, dict):
        return {k: stable(v) for k, v in doc.items() if k not in VOLATILE}
    if isinstance(doc, list):
        return [stable(v) for v in doc]
    return doc


def stage_medians(doc: Any) -> dict[str, Any] | None:
    """Median seconds per stage of a task, when the result lists its tasks' timings (``rigs.json``:
    per rig ``seconds`` by stage), with what one task held (kinds, learning seeds)."""
    rows = doc.get("rigs") if isinstance(doc, dict) else None
    if not isinstance(rows, list) or not rows or not isinstance(rows[0].get("seconds"), dict):
        return None
    stages = rows[0]["seconds"]
    return {"kinds": len(doc.get("agents", [])), "learning_seeds": len(doc.get("learning_seeds", [])),
            "median_seconds": {k: round(statistics.median(float(r["seconds"][k]) for r in rows), 3)
                               for k in stages}}


def run_sweep(sweep: list[str], workers: int, out: Path) -> dict[str, Any]:
    """One sweep on a fresh local Ray cluster of ``workers`` CPUs; wall time and load at its start."""
    cmd = [sys.executable, "-m", "msd_bench", *sweep, "--executor", "ray", "--workers", str(workers),
           "--out", str(out)]
    load1 = os.getloadavg()[0]
    t0 = time.monotonic()
    done = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True)
    seconds = time.monotonic() - t0
    if done.returncode != 0:
        fail(f"the sweep on {workers} worker(s) failed (exit {done.returncode}): "
             f"{(done.stderr.strip().splitlines() or ['no output'])[-1]}")
    tasks = len(json.loads((out / "manifest.json").read_text())["tasks"])
    return {"workers": workers, "seconds": round(seconds, 1), "load1_at_start": load1, "tasks": tasks}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--result", required=True, help="the result file to compare, e.g. efficiency.json")
    ap.add_argument("--out", type=Path, help="also write the JSON here (must not exist)")
    ap.add_argument("--warmup", default="", help="a small sweep (quoted options) run untimed first")
    ap.add_argument("--keep", type=Path, help="copy the 1-worker result file here (must not exist)")
    ap.add_argument("sweep", nargs=argparse.REMAINDER, help="-- then the msd-bench sweep and its options")
    args = ap.parse_args()
    sweep = args.sweep[1:] if args.sweep[:1] == ["--"] else args.sweep
    if not sweep or any(a in sweep for a in ("--executor", "--workers", "--out")):
        fail("give the sweep after --, without --executor, --workers or --out (the benchmark sets them)")
    for target in (args.out, args.keep):
        if target is not None and (target.exists() or not target.parent.is_dir()):
            fail(f"{target} exists or its directory does not; not writing there")
    sys.path.insert(0, str(REPO / "scripts"))
    from make_results import commit, machine

    prov = {"command": "benchmarks/bench_executor.py " + shlex.join(sys.argv[1:]), "commit": commit(),
            "machine": machine()}
    with tempfile.TemporaryDirectory(prefix="bench-executor-") as tmp:
        if args.warmup:
            run_sweep(shlex.split(args.warmup), 2, Path(tmp) / "warmup")
        runs = [run_sweep(sweep, n, Path(tmp) / f"w{n}") for n in (1, 2)]
        first = (Path(tmp) / "w1" / args.result).read_text()
        same = stable(json.loads(first)) == stable(json.loads((Path(tmp) / "w2" / args.result).read_text()))
        if args.keep is not None:
            with args.keep.open("x") as f:
                f.write(first)
    one, two = runs
    speedup = one["seconds"] / two["seconds"]
    text = json.dumps({**prov, "sweep": sweep, "warmup": args.warmup, "runs": runs,
                       "per_task": stage_medians(json.loads(first)), "same_result": same,
                       "seconds_per_task_one_worker": round(one["seconds"] / one["tasks"], 2),
                       "speedup": round(speedup, 3), "floor": 1.5, "within_floor": speedup >= 1.5},
                      indent=2)
    print(text)
    if args.out is not None:
        with args.out.open("x") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
