"""bench.py --plant-ns behind the supervisor, read from the suite's shared real-time runs
(tests/e2e/realtime_runs.py): the two quick looks validate behind it by default (msd face and
ros2_control face) and its counts reach the report; the PLM run opts out and says so. In the slow
tier, an e-stop latched from outside during a whole (lock-step) run aborts its validation runs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from msd_bench.graph import launch
from tests.e2e.realtime_runs import PLANT_NS, R2C_NS, REPO, Run

pytestmark = pytest.mark.e2e


def validation_runs(result: Path) -> int:
    """Runs an agent validated: every seed nominally, plus every scenario per seed."""
    doc = json.loads(result.read_text())
    return len(doc["per_seed"]) + sum(c["n"] for c in doc["on_node_scenarios"].values())


@pytest.mark.realtime
@pytest.mark.parametrize(("name", "ns"), [("plant", PLANT_NS), ("r2c", R2C_NS)])
def test_validation_runs_behind_the_supervisor_and_its_counts_reach_the_report(
        realtime_runs: dict[str, Run], name: str, ns: str) -> None:
    run = realtime_runs[name]
    out, proc = run.out, run.proc
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"validation behind {ns}/supervisor; recording unsupervised" in proc.stderr
    assert "envelope ±2.25 m" in proc.stderr  # the limits, printed at start
    record = json.loads((out / "agents" / "supervisor.json").read_text())
    totals = record["totals"]  # printed by the node as it closed: it was in the graph all along
    assert totals is not None and totals["steps"] > 0
    per_kind = {r.parent.name: validation_runs(r) for r in (out / "agents").glob("*/result.json")}
    expected = sum(per_kind.values())
    assert expected > 0 and len(record["runs"]) == expected == totals["runs"]
    assert all(r["complete"] and r["samples"] > 0 for r in record["runs"])
    assert record["by_kind"]["attributed"]
    for kind, n in per_kind.items():  # each kind's runs, back in its own directory
        mine = json.loads((out / "agents" / kind / "supervisor.json").read_text())
        assert len(mine["runs"]) == n and {r["scenario"] for r in mine["runs"]} >= {"nominal"}
    table = json.loads((out / "report" / "table1.json").read_text())
    facts = table["run"]["supervisor"]
    assert facts["on"] and facts["runs"] == expected
    assert sum(facts["overrides"].values()) == sum(r["overridden"] for r in record["runs"])
    line = (out / "report" / "table1.md").read_text().rstrip().splitlines()[-1]
    assert line.startswith("Supervisor: on for validation") and f"{expected} validation runs" in line
    assert line == facts["line"]
    assert (out / "jobs" / "supervisor.json").is_file()  # the options it held the run to


@pytest.mark.realtime
def test_no_supervisor_runs_without_it_and_says_so(realtime_runs: dict[str, Run]) -> None:
    run = realtime_runs["plm"]
    out, proc = run.out, run.proc
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Supervisor: off (--no-supervisor); recording unsupervised" in proc.stderr
    assert not (out / "agents" / "supervisor.json").exists()
    assert not (out / "jobs" / "supervisor.json").exists()
    assert not list((out / "agents").glob("*/supervisor.json"))
    facts = json.loads((out / "report" / "table1.json").read_text())["run"]["supervisor"]
    assert facts == {"on": False, "line": "Supervisor: off (--no-supervisor)."}
    assert "Supervisor: off (--no-supervisor)." in (out / "report" / "table1.md").read_text()


ESTOPPER = """
import sys
import time
import rclpy
from std_msgs.msg import Empty
rclpy.init()
node = rclpy.create_node("estopper")
pub = node.create_publisher(Empty, "/msd/supervisor/estop", 10)
try:
    while pub.get_subscription_count() == 0:
        time.sleep(0.05)
    sys.stdin.readline()
    while True:
        pub.publish(Empty())
        time.sleep(0.2)
except KeyboardInterrupt:
    pass
finally:
    node.destroy_node()
    rclpy.try_shutdown()
"""
"""Latches the supervisor's e-stop from outside, five times a second (each latch is counted), from
the line it is given on stdin on. It starts with the bench and matches the supervisor while the bench
records, so the latch reaches the supervisor as soon as it is given (a process started at that moment
spends seconds on its own start and discovery, and a loaded machine let validation end before it)."""


@pytest.mark.slow
def test_an_estop_during_validation_aborts_the_runs_and_bench_completes(tmp_path: Path) -> None:
    """The emulator in lock-step behind the supervisor (--supervisor); once recording is over an
    outside process latches the e-stop: from the first run it reaches on, every validation run ends as
    aborted (estop), each named in its kind's record and in the report line, and bench.py still exits
    0 (opt-in: a whole run)."""
    domain, out = int(os.environ["ROS_DOMAIN_ID"]), tmp_path / "run"
    argv = [sys.executable, "launch_scripts/bench.py", "--supervisor", "--out", str(out), "--agents", "glm",
            "--seeds", "3", "--episodes", "5", "--samples", "600", "--val-samples", "400",
            "--validation-steps", "600", "--domain-id", str(domain)]
    err: list[str] = []
    given = False
    estopper = subprocess.Popen([sys.executable, "-c", ESTOPPER], cwd=REPO, stdin=subprocess.PIPE,
                                text=True, env=launch.ros_env(domain))
    assert estopper.stdin is not None
    try:
        with subprocess.Popen(argv, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              text=True, env=launch.ros_env(domain)) as bench:
            assert bench.stderr is not None
            try:
                for line in bench.stderr:
                    err.append(line)
                    if "identifying surrogates" in line and not given:  # recording is over
                        estopper.stdin.write("latch\n")
                        estopper.stdin.flush()
                        given = True
                assert bench.wait(600) == 0, "".join(err)[-3000:]
            finally:
                if bench.poll() is None:
                    bench.send_signal(signal.SIGINT)
                    bench.wait(60)
    finally:
        estopper.send_signal(signal.SIGINT)
        estopper.wait(30)
        estopper.stdin.close()
    assert given and "Traceback" not in "".join(err)
    mine = json.loads((out / "agents" / "glm" / "supervisor.json").read_text())
    reasons = [r["aborted"] for r in mine["runs"]]
    latched = reasons.index("estop")  # when the latch came is the outside process's timing; from then
    assert len(reasons) == 3 and reasons[latched:] == ["estop"] * (3 - latched)  # on it holds
    assert [(a["seed"], a["reason"]) for a in mine["aborted"]] == [(s, "estop") for s in range(latched, 3)]
    line = (out / "report" / "table1.md").read_text().rstrip().splitlines()[-1]
    assert f"aborted runs: {3 - latched}" in line and "glm nominal seed 2 (estop)" in line
