"""Wall time of the main job, ``python launch_scripts/bench.py``, and of each of its stages.

Runs bench.py with its defaults (lock-step, 3 seeds, its default agent kinds,
paper budgets and 2,000-sample validation records; Dyna-Q, if a default kind,
at bench.py's reduced 5 episodes) as a subprocess into a temporary run
directory, then reads the stage timings and the agent kinds bench.py records
in ``run.json``. Baseline in the same run: ``msd-bench paper`` with the same
seeds, agent kinds and budgets in-process (no ROS), so ``bench_over_inprocess``
shows what running every stage through node processes and DDS costs. Floors:
``seconds`` <= 90 and ``bench_over_inprocess`` <= 4. Stages overlap (agents
start while later surrogates are identified), so the stage seconds add up to
the wall time but an agent's share may sit in ``identify``.

    .venv/bin/python benchmarks/bench_bench.py [--seeds 3]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
FLOOR_S = 90.0
RATIO_FLOOR = 4.0


def timed(argv: list[str]) -> float:
    """Seconds a command takes; raises if it fails."""
    t0 = time.perf_counter()
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{argv[1]} failed: {proc.stderr[-2000:]}")
    return time.perf_counter() - t0


def plant_samples(bags: list[Path]) -> int:
    """The plant's ``joint_states`` rows in these bags (one per lock-step step)."""
    from msd_bench.io.bags.reader import bag_info

    return sum(n for b in bags for t, (_, n) in bag_info(b).topics.items() if t.endswith("/joint_states")
               and not t.endswith("truth/joint_states"))


def lockstep_steps(run: Path) -> dict[str, int]:
    """The run's lock-step steps: the recording's (open loop, several commands in flight) and the closed
    loop's (validation runs and Dyna-Q's real steps: each waits for the sample before the next force,
    so each is one round trip)."""
    record = plant_samples([p.parent for p in (run / "excitation").glob("**/metadata.yaml")])
    validation = plant_samples([p.parent for p in (run / "agents").glob("**/metadata.yaml")])
    results = run.glob("agents/*/result.json")
    dyna = sum(json.loads(p.read_text()).get("real_interactions", 0) for p in results)
    return {"record": int(record), "closed_loop": int(validation + dyna)}


def pingpong_rate(steps: int = 5000) -> float:
    """Bare rclpy round trips per second against an echo process (``bench_lockstep.py``'s)."""
    import os
    import random

    sys.path.insert(0, str(REPO / "benchmarks"))
    import bench_lockstep

    from msd_bench.graph import launch

    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 200)))
    with launch.process_group() as procs:
        echo = procs.start(REPO / "benchmarks" / "bench_lockstep.py", name="echo", script_args=["--echo"])
        return float(bench_lockstep.measure(echo, bench_lockstep.PINGPONG_NS, steps))


def main() -> None:
    """Run both, print one JSON object."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        bench_s = timed([sys.executable, "launch_scripts/bench.py", "--seeds", str(args.seeds),
                         "--out", str(run)])
        steps = lockstep_steps(run)
        facts = json.loads((run / "run.json").read_text())
        stages, kinds = facts["timings"], facts["run"]["agents"]
        table = json.loads((run / "report" / "table1.json").read_text())
        paper_s = timed([sys.executable, "-m", "msd_bench.cli", "paper", "--seeds", str(args.seeds),
                         "--agents", ",".join(kinds), "--dyna-episodes", "5", "--val-samples", "2000",
                         "--out", str(Path(tmp) / "p")])
    rate = pingpong_rate()
    print(json.dumps({
        "seconds": round(bench_s, 1),
        "stage_seconds": stages,
        "floor_seconds": FLOOR_S,
        "in_process_paper_seconds": round(paper_s, 1),
        "bench_over_inprocess": round(bench_s / paper_s, 2),
        "ratio_floor": RATIO_FLOOR,
        "meets_floor": bench_s <= FLOOR_S and bench_s / paper_s <= RATIO_FLOOR,
        "record_steps": steps["record"],
        "round_trips": steps["closed_loop"],
        "pingpong_roundtrips_per_s": round(rate, 1),
        "round_trip_bound_s": round(steps["closed_loop"] / rate, 1),
        "agents": kinds,
        "success_rate": {a["kind"]: a["success_rate"] for a in table["agents"]},
    }, indent=2))


if __name__ == "__main__":
    main()
