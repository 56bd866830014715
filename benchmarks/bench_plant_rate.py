"""Real-time plant rate against a bare rclpy 100 Hz timer, quiet and under a CPU load made here.

Four measurements, each a publisher process watched by a separate subscriber
process that records the monotonic arrival time and the stamp of every
``joint_states`` sample for ``--seconds``:

* ``plant``: ``launch_scripts/plant.py`` in real time (100 Hz);
* ``bare``: a bare rclpy node whose 10 ms timer publishes a stamped
  ``JointState`` — the best the middleware and the machine allow;

each once on a quiet machine and once while ``--load`` busy-looping processes
(started by this benchmark) compete for the cores. The figures that matter are
ratios within one condition, so the machine's own jitter cancels:
``p99_over_bare_timer_quiet`` and ``p99_over_bare_timer_loaded`` (floor
<= 1.1) and each condition's mean-rate error (floor <= 0.1 %).

    .venv/bin/python benchmarks/bench_plant_rate.py [--seconds 20] [--load 2]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import random
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import JointState

from msd_bench.graph import launch
from msd_msgs_py.contract import JOINT_STATES, PLANT_NAMESPACE
from msd_msgs_py.ros import msg_class, qos

WARMUP_S = 2.0
"""Seconds of arrivals discarded after the first sample."""
BARE_NS = "/bench_bare"
P99_FLOOR = 1.1
RATE_FLOOR_PERCENT = 0.1


def subscribe(topic: str, seconds: float) -> dict[str, float]:
    """Collect arrivals on ``topic`` for ``seconds`` after the first sample; summarise them."""
    arrivals: list[float] = []
    stamps: list[int] = []

    def on_sample(msg: object) -> None:
        arrivals.append(time.monotonic())
        s = msg.header.stamp  # type: ignore[attr-defined]
        stamps.append(s.sec * 1_000_000_000 + s.nanosec)

    with rclpy.init(args=[]):
        node = rclpy.create_node("rate_probe")
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


def bare_timer() -> None:
    """The baseline publisher: a plain 10 ms rclpy timer, one stamped JointState per tick."""
    with rclpy.init(args=[]):
        node = rclpy.create_node("bare_timer", namespace=BARE_NS)
        pub = node.create_publisher(msg_class(JOINT_STATES), JOINT_STATES.name, qos(JOINT_STATES))
        msg = JointState(name=["msd_slider"], position=[0.0], velocity=[0.0], effort=[0.0])

        def tick() -> None:
            msg.header.stamp = node.get_clock().now().to_msg()
            pub.publish(msg)

        node.create_timer(0.01, tick)
        with contextlib.suppress(KeyboardInterrupt):
            rclpy.spin(node)


def summarise(arrivals: np.ndarray, stamps: np.ndarray) -> dict[str, float]:
    """Mean rate and inter-arrival percentiles (receiver clock), plus the stamp-based rate."""
    gaps = np.diff(arrivals) * 1e3
    stamp_gaps = np.diff(stamps) / 1e6
    mean_rate = float((arrivals.size - 1) / (arrivals[-1] - arrivals[0]))
    return {
        "samples": int(arrivals.size),
        "mean_rate_hz": mean_rate,
        "rate_error_percent": round(100.0 * abs(mean_rate - 100.0) / 100.0, 4),
        "stamp_rate_hz": float((stamps.size - 1) / ((stamps[-1] - stamps[0]) / 1e9)),
        "interarrival_ms_p50": float(np.percentile(gaps, 50)),
        "interarrival_ms_p99": float(np.percentile(gaps, 99)),
        "interarrival_ms_max": float(gaps.max()),
        "stamp_gap_ms_p99": float(np.percentile(stamp_gaps, 99)),
    }


@contextlib.contextmanager
def cpu_load(processes: int) -> Iterator[None]:
    """``processes`` busy loops for the duration (the load this benchmark makes itself)."""
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(processes)]
    try:
        time.sleep(1.0)
        yield
    finally:
        for p in busy:
            p.kill()
            p.wait()


def measure(publisher: str, seconds: float) -> dict[str, float]:
    """Start one publisher (``plant`` or ``bare``) and its outside subscriber; return the summary."""
    me = Path(__file__).resolve()
    with launch.process_group() as procs:
        if publisher == "plant":
            procs.start("plant.py", ["-p", "duplicate_check:=0.0"])
            topic = JOINT_STATES.resolve(PLANT_NAMESPACE)
        else:
            procs.start(me, name="bare", script_args=["--bare-timer"])
            topic = JOINT_STATES.resolve(BARE_NS)
        probe = procs.start(me, name="probe",
                            script_args=["--subscriber", topic, "--seconds", str(seconds)])
        line = probe.wait_for_line(r"^RESULT ", timeout=seconds + 40.0)
    return json.loads(line.removeprefix("RESULT "))  # type: ignore[no-any-return]


def condition(seconds: float) -> dict[str, object]:
    """Plant then bare timer under the same condition; the ratio of their p99s."""
    plant = measure("plant", seconds)
    bare = measure("bare", seconds)
    return {"plant": plant, "bare_timer": bare,
            "p99_over_bare_timer": round(plant["interarrival_ms_p99"] / bare["interarrival_ms_p99"], 3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--load", type=int, default=2, help="busy processes for the loaded condition")
    parser.add_argument("--subscriber", metavar="TOPIC", help=argparse.SUPPRESS)
    parser.add_argument("--bare-timer", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.subscriber:
        print("RESULT " + json.dumps(subscribe(args.subscriber, args.seconds)), flush=True)
        return
    if args.bare_timer:
        bare_timer()
        return
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 200)))
    quiet = condition(args.seconds)
    with cpu_load(args.load):
        loaded = condition(args.seconds)
    worst_rate = max(c[k]["rate_error_percent"] for c in (quiet, loaded) for k in ("plant",))  # type: ignore[index]
    result = {
        "benchmark": "plant_rate", "seconds": args.seconds, "load_processes": args.load,
        "loadavg_1min_at_start": os.getloadavg()[0],
        "quiet": quiet, "loaded": loaded,
        "p99_over_bare_timer_quiet": quiet["p99_over_bare_timer"],
        "p99_over_bare_timer_loaded": loaded["p99_over_bare_timer"],
        "plant_rate_error_percent_worst": worst_rate,
    }
    result["meets_floor"] = (worst_rate <= RATE_FLOOR_PERCENT
                             and result["p99_over_bare_timer_quiet"] <= P99_FLOOR  # type: ignore[operator]
                             and result["p99_over_bare_timer_loaded"] <= P99_FLOOR)  # type: ignore[operator]
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    from msd_bench.dds import confine_process

    confine_process()  # this process's own participants stay on loopback, as the bench's do
    main()
