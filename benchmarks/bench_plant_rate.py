"""Real-time plant rate, measured from outside: a plant process and a separate subscriber process.

The plant (``launch_scripts/plant.py``, real-time 100 Hz) and a subscriber
(this file with ``--subscriber``) run as two processes; the subscriber
records the monotonic arrival time of every ``/msd/joint_states`` sample (and
its stamp) for ``--seconds`` and prints the statistics. The spec: mean rate
100.0 Hz within 0.1 %, inter-arrival p99 <= 15 ms.

    .venv/bin/python benchmarks/bench_plant_rate.py [--seconds 20]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor

from msd_bench.graph import launch
from msd_msgs_py.contract import JOINT_STATES, PLANT_NAMESPACE
from msd_msgs_py.ros import msg_class, qos

WARMUP_S = 2.0
"""Seconds of arrivals discarded after the first sample."""


def subscribe(seconds: float) -> dict[str, float]:
    """Collect arrivals for ``seconds`` after the first sample; summarise them."""
    arrivals: list[float] = []
    stamps: list[int] = []

    def on_sample(msg: object) -> None:
        arrivals.append(time.monotonic())
        s = msg.header.stamp  # type: ignore[attr-defined]
        stamps.append(s.sec * 1_000_000_000 + s.nanosec)

    with rclpy.init(args=[]):
        node = rclpy.create_node("rate_probe")
        topic = JOINT_STATES.resolve(PLANT_NAMESPACE)
        node.create_subscription(msg_class(JOINT_STATES), topic, on_sample, qos(JOINT_STATES))
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        deadline = time.monotonic() + 30.0
        while not arrivals and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        warm = time.monotonic() + WARMUP_S  # discovery and start-up transients are not the rate
        while time.monotonic() < warm:
            executor.spin_once(timeout_sec=0.1)
        arrivals.clear()
        stamps.clear()
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
        node.destroy_node()
    return summarise(np.array(arrivals), np.array(stamps))


def summarise(arrivals: np.ndarray, stamps: np.ndarray) -> dict[str, float]:
    """Mean rate and inter-arrival percentiles (receiver clock), plus the stamp-based rate."""
    gaps = np.diff(arrivals) * 1e3
    stamp_gaps = np.diff(stamps) / 1e6
    return {
        "samples": int(arrivals.size),
        "mean_rate_hz": float((arrivals.size - 1) / (arrivals[-1] - arrivals[0])),
        "stamp_rate_hz": float((stamps.size - 1) / ((stamps[-1] - stamps[0]) / 1e9)),
        "interarrival_ms_p50": float(np.percentile(gaps, 50)),
        "interarrival_ms_p99": float(np.percentile(gaps, 99)),
        "interarrival_ms_max": float(gaps.max()),
        "stamp_gap_ms_p99": float(np.percentile(stamp_gaps, 99)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--subscriber", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.subscriber:
        print("RESULT " + json.dumps(subscribe(args.seconds)), flush=True)
        return
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 200)))
    with launch.process_group() as procs:
        procs.start("plant.py", ["-p", "duplicate_check:=0.0"])
        probe = procs.start(
            Path(__file__).resolve(), name="probe",
            script_args=["--subscriber", "--seconds", str(args.seconds)],
        )
        line = probe.wait_for_line(r"^RESULT ", timeout=args.seconds + 40.0)
    stats = json.loads(line.removeprefix("RESULT "))
    stats["rate_error_percent"] = round(100.0 * abs(stats["mean_rate_hz"] - 100.0) / 100.0, 4)
    stats["meets_spec"] = stats["rate_error_percent"] <= 0.1 and stats["interarrival_ms_p99"] <= 15.0
    print(json.dumps({"benchmark": "plant_rate", "seconds": args.seconds, **stats}, indent=2))


if __name__ == "__main__":
    main()
