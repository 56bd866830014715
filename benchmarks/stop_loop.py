"""Stop the plant process with SIGINT (or SIGTERM) at random moments, start-up included.

    python benchmarks/stop_loop.py [--runs 40] [--signal INT|TERM] [--max-delay 4.0] [--seed 1]

Every stop must exit 0 with no ``error:`` line and no traceback (a supervisor
reads status 2 as a usage error). Prints one JSON object: runs, statuses,
failures (with the last output line) and the delays used.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from msd_bench.graph.launch import ros_env, start


def one_stop(delay: float, sig: signal.Signals, domain: int) -> dict[str, object]:
    """Start the plant, signal its process group after ``delay`` s, return what happened."""
    proc = start("plant.py", ["-p", "duplicate_check:=0.0"], env=ros_env(domain))
    time.sleep(delay)
    os.killpg(proc.pid, sig)
    try:
        status = proc.popen.wait(20.0)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        status = proc.popen.wait(5.0)
    proc.close_output()
    bad = [i for i, ln in enumerate(proc.lines) if "Traceback" in ln or "error:" in ln]
    return {"delay": round(delay, 3), "status": status,
            "bad_line": proc.lines[bad[0]] if bad else "",
            "bad_output": proc.lines[bad[0]:][-12:] if bad else []}


def _commit() -> str:
    proc = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parents[1])
    return proc.stdout.strip()


def main() -> int:
    """Run the loop and print the JSON summary; exit 1 if any stop was not clean."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--runs", type=int, default=40)
    p.add_argument("--signal", choices=("INT", "TERM"), default="INT")
    p.add_argument("--max-delay", type=float, default=4.0)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--domain-id", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    p.add_argument("--out", type=Path, help="also write the JSON here (e.g. docs/results/stop_loop.json)")
    args = p.parse_args()
    rng = random.Random(args.seed)
    sig = signal.Signals[f"SIG{args.signal}"]
    results = [one_stop(rng.uniform(0.0, args.max_delay), sig, args.domain_id) for _ in range(args.runs)]
    failures = [r for r in results if r["status"] != 0 or r["bad_line"]]
    doc = {"runs": args.runs, "signal": args.signal, "clean": args.runs - len(failures),
           "failures": failures, "statuses": sorted({str(r["status"]) for r in results}),
           "delays": [r["delay"] for r in results], "command": " ".join(sys.argv),
           "commit": _commit(), "machine": f"{platform.node()} ({os.cpu_count()} cores)"}
    text = json.dumps(doc, indent=1)
    print(text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
