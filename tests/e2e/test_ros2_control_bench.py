"""bench.py --plant-ns with --interface ros2_control against the rig emulator's ros2_control face.

The README's short configuration, end to end: recording (joint_states with an
extra joint first, commands as Float64MultiArray), identification from the
applied force rebuilt from the commands, agents validated through the face,
the report. No msd topic of the rig is ever used: it has none.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from msd_bench.io.bags.bag_interface import MIN_AGREEMENT, read_interface_experiment
from msd_bench.io.bags.reader import bag_info
from msd_msgs_py.interface import make
from tests.e2e.realtime_runs import R2C_NS, Run

pytestmark = [pytest.mark.e2e, pytest.mark.realtime]
NS = R2C_NS


@pytest.fixture(scope="module")
def run(realtime_runs: dict[str, Run]) -> tuple[Path, subprocess.CompletedProcess[str]]:
    return realtime_runs["r2c"].out, realtime_runs["r2c"].proc


def test_completes_through_the_ros2_control_face(run) -> None:  # type: ignore[no-untyped-def]
    out, proc = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    assert f"interface ros2_control (commands {NS}/effort_controller/commands" in proc.stderr
    assert "Through the ros2_control face: commands on `effort_controller/commands`" in \
        (out / "report" / "table1.md").read_text()
    run_doc = json.loads((out / "run.json").read_text())
    assert run_doc["interface"]["kind"] == "ros2_control"
    table = json.loads((out / "report" / "table1.json").read_text())
    assert table["run"]["interface"]["command_topic"] == "effort_controller/commands"


def test_bags_hold_the_face_and_identify_from_the_applied_force(run) -> None:  # type: ignore[no-untyped-def]
    out, _ = run
    iface = make("ros2_control")
    topics = bag_info(out / "excitation" / "broad").topics
    assert topics[f"{NS}/effort_controller/commands"][0] == "std_msgs/msg/Float64MultiArray"
    assert f"{NS}/position" not in topics
    exp, _, src = read_interface_experiment(out / "excitation" / "broad", iface, NS)
    assert len(exp) >= 600  # the played samples at least (real time records a little more)
    assert src.source == "applied" and src.agreement is not None
    # the rig's dead time of one sample, seen in log time: publish jitter and transport let a command
    # overtake a row, or a row lag a command, so the effective dead time reads one sample or a few
    # (3 seen in CI beside other real-time runs) and the fit stays below an offline bag's
    # (docs/ros2-control.md §Force). Both depend on the machine's load, so the test holds the
    # reader's own acceptance, not a figure of a quiet machine; the exact dead time is asserted on
    # offline bags, and a wrong joint or a wrong cut reads far below the acceptance and is refused
    # (tests/io/test_bag_interface.py).
    assert src.agreement.fit_percent >= MIN_AGREEMENT
    inputs = json.loads((out / "models" / "inputs.json").read_text())
    assert {b["source"] for b in inputs["bags"]} == {"applied"}
    fits = json.loads((out / "models" / "fits.json").read_text())
    assert set(fits) == {"glm", "greybox"} and fits["greybox"]["sim_fit"] > 50.0


def test_agents_were_validated_through_the_face(run) -> None:  # type: ignore[no-untyped-def]
    out, _ = run
    result = json.loads((out / "agents" / "glm+improved" / "result.json").read_text())
    assert set(result["x0"]["nominal"]) == {"0", "1"}
    assert all(abs(v) < 0.2 for v in result["x0"]["nominal"].values())
