"""Lock-step plant speed between two processes, beside a bare rclpy ping-pong.

Both measurements drive a *separate process* from this one, one message out,
one reply back, so the ratio isolates what the plant node adds over the
middleware round trip:

* ``pingpong``: an echo node (subscribes ``/bench_pingpong/force``, republishes
  the value on ``/bench_pingpong/position``) on rclpy's default executor
  (SingleThreadedExecutor), as bare rclpy spins a node; the lock-step plant, the
  surrogate and the agent run on rclpy's events executor (msd_bench/nodes/spin.py),
  so ratios above 1 are possible;
* ``pingpong_events``: the same echo on the events executor, the like-for-like
  baseline: ``lockstep_over_pingpong_events`` says what the plant node adds
  over the round trip on the executor it runs on (reported, no floor);
* ``lockstep``: ``launch_scripts/plant.py -p lockstep:=true``; each force
  command yields joint_states, position and /clock, and the driver waits for
  ``position`` (x_{k+1});
* ``via_ros``: the agent node training over a lock-step surrogate node's
  topics (``-p via_ros:=true``), timed between its own log stamps.

    .venv/bin/python benchmarks/bench_lockstep.py [--steps 5000]

Prints JSON: steps/s of each round, the median ratio ``lockstep_over_pingpong`` of
``--rounds`` interleaved pairs (floor 0.8), and the absolute floor (1,500 steps/s).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Float64

from msd_bench.graph import launch
from msd_bench.nodes.spin import main as spin_main
from msd_msgs_py.contract import FORCE, POSITION
from msd_msgs_py.ros import float64, qos

PINGPONG_NS = "/bench_pingpong"
FLOOR = 1500.0
RATIO_FLOOR = 0.8
"""Lock-step must reach this share of the bare round trip (median of interleaved rounds)."""
VIA_ROS_FLOOR = 0.7
"""``--via-ros`` training must reach this share of the bare round trip."""
REPO = Path(__file__).resolve().parents[1]


class Echo(Node):
    """Republish every force value as a position: the bare round trip."""

    def __init__(self) -> None:
        super().__init__("echo", namespace=PINGPONG_NS)
        self._pub = self.create_publisher(Float64, POSITION.name, qos(POSITION))
        self.create_subscription(Float64, FORCE.name, lambda m: self._pub.publish(m), qos(FORCE))


class EventsEcho(Echo):
    """The echo on rclpy's events executor, as the plant, surrogate and agent nodes spin."""

    events_executor = True


class Driver(Node):
    """Send one command, spin until the reply arrives, repeat."""

    def __init__(self, namespace: str) -> None:
        super().__init__("bench_driver", namespace=namespace)
        self.pub = self.create_publisher(Float64, FORCE.name, qos(FORCE))
        self.sub = self.create_subscription(Float64, POSITION.name, self._on_reply, qos(POSITION))
        self.replies = 0

    def _on_reply(self, _msg: Float64) -> None:
        self.replies += 1

    def wait_matched(self, executor: SingleThreadedExecutor, timeout: float = 20.0) -> None:
        deadline = time.monotonic() + timeout
        while self.pub.get_subscription_count() == 0 or self.sub.get_publisher_count() == 0:
            if time.monotonic() > deadline:
                raise launch.LaunchError(f"{self.get_namespace()}: peer not matched in {timeout} s")
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic() + 0.5  # let the peer's side of the match settle
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)

    def run(self, executor: SingleThreadedExecutor, steps: int) -> float:
        """Round trips per second over ``steps`` commands."""
        t0 = time.perf_counter()
        for k in range(steps):
            self.pub.publish(float64(0.001 * (k % 100)))
            deadline = time.monotonic() + 5.0
            while self.replies <= k:
                executor.spin_once(timeout_sec=0.1)
                if time.monotonic() > deadline:
                    raise launch.LaunchError(f"reply {k} lost")
        return steps / (time.perf_counter() - t0)


def measure(proc: launch.NodeProcess, ns: str, steps: int) -> float:
    """Round trips per second against the process ``proc`` serving namespace ``ns``."""
    with rclpy.init(args=[]):
        driver = Driver(ns)
        executor = SingleThreadedExecutor()
        executor.add_node(driver)
        try:
            driver.wait_matched(executor)
            driver.run(executor, min(200, steps))  # warm-up
            driver.replies = 0
            return driver.run(executor, steps)
        finally:
            driver.destroy_node()
            launch.stop(proc)


LOG_TIME = re.compile(r"\[(\d+\.\d+)\]")
MODEL = REPO / "tests" / "data" / "pinned" / "plm.json"
"""A stored PLM artifact: the surrogate node that ``--via-ros`` training steps."""


def _log_time(line: str) -> float:
    match = LOG_TIME.search(line)
    if match is None:
        raise launch.LaunchError(f"no timestamp in log line {line!r}")
    return float(match.group(1))


def via_ros(procs: launch.ProcessSet, steps: int, tmp: Path) -> float:
    """Training steps per second of the agent node's ``via_ros`` path against a lock-step surrogate.

    The agent process logs when its first training episode starts over the
    surrogate's topics (once the surrogate is matched) and when training ends
    (before validation); the steps between the two log stamps are the figure,
    so start-up, discovery and validation are excluded (the resets between
    episodes are not).
    """
    episodes = max(1, steps // 1000)
    plant = procs.start("plant.py", ["-p", "lockstep:=true", "-p", "duplicate_check:=0.0"])
    surrogate = procs.start("surrogate.py", ["-p", f"model_path:={MODEL}", "-p", "lockstep:=true",
                                             "-r", "__ns:=/surrogate/plm"])
    agent = procs.start("agent.py", [
        "-p", "kind:=plm+improved", "-p", f"model_path:={MODEL}", "-p", "seeds:=[0]",
        "-p", f"episodes:={episodes}", "-p", "steps:=1000", "-p", "via_ros:=true",
        "-p", "surrogate_ns:=/surrogate/plm", "-p", "validation_steps:=500", "-p", "window:=100",
        "-p", f"out_dir:={tmp / f'agent_{time.monotonic_ns()}'}"])
    start = _log_time(agent.wait_for_line(r"first training episode under way", timeout=60.0))
    end = _log_time(agent.wait_for_line(r"trained; validating", timeout=600.0))
    for proc in (agent, surrogate, plant):
        launch.stop(proc)
    return episodes * 1000 / (end - start)


def one_round(procs: launch.ProcessSet, steps: int, tmp: Path) -> tuple[float, float, float, float]:
    """Ping-pong (default and events executor), lock-step and ``--via-ros`` training, each against fresh
    processes."""
    me = Path(__file__).resolve()
    ping = measure(procs.start(me, name="echo", script_args=["--echo"]), PINGPONG_NS, steps)
    ping_events = measure(procs.start(me, name="echo-events", script_args=["--echo", "--events"]),
                          PINGPONG_NS, steps)
    plant_proc = procs.start("plant.py", ["-p", "lockstep:=true", "-p", "duplicate_check:=0.0"])
    return ping, measure(plant_proc, "/msd", steps), via_ros(procs, steps, tmp), ping_events


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--rounds", type=int, default=3,
                        help="interleaved ping-pong/lock-step pairs; the ratio is their median")
    parser.add_argument("--echo", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--events", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:  # the ping-pong peer: this file is its own launch script
        sys.exit(spin_main(EventsEcho if args.events else Echo, args=[]))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.randint(101, 200)))
    with launch.process_group() as procs, tempfile.TemporaryDirectory() as tmp:
        rounds = [one_round(procs, args.steps, Path(tmp)) for _ in range(args.rounds)]
    ratios = [plant / ping for ping, plant, _, _ in rounds]
    via_ratios = [via / ping for ping, _, via, _ in rounds]
    like_for_like = [plant / ping_events for _, plant, _, ping_events in rounds]
    ratio = float(statistics.median(ratios))
    plant = float(statistics.median(p for _, p, _, _ in rounds))
    print(json.dumps({
        "benchmark": "lockstep",
        "steps": args.steps,
        "rounds": args.rounds,
        "loadavg_1min": os.getloadavg()[0],
        "pingpong_roundtrips_per_s": [round(p, 1) for p, _, _, _ in rounds],
        "pingpong_events_roundtrips_per_s": [round(p, 1) for _, _, _, p in rounds],
        "lockstep_steps_per_s": [round(p, 1) for _, p, _, _ in rounds],
        "via_ros_training_steps_per_s": [round(v, 1) for _, _, v, _ in rounds],
        "lockstep_over_pingpong_each": [round(r, 3) for r in ratios],
        "lockstep_over_pingpong": round(ratio, 3),
        "via_ros_over_pingpong": round(float(statistics.median(via_ratios)), 3),
        "lockstep_over_pingpong_events": round(float(statistics.median(like_for_like)), 3),
        "ratio_floor": RATIO_FLOOR,
        "via_ros_ratio_floor": VIA_ROS_FLOOR,
        "floor_steps_per_s": FLOOR,
        "meets_floor": plant >= FLOOR and ratio >= RATIO_FLOOR
        and statistics.median(via_ratios) >= VIA_ROS_FLOOR,
    }, indent=2))


if __name__ == "__main__":
    from msd_bench.dds import confine_process

    confine_process()  # this process's own participants stay on loopback, as the bench's do
    main()
