"""bench.py --rig FILE --plant-ns NS against rig.py --rig FILE: a rig that is not our emulator's shape
(issue 37, Done when 1), end to end through real node processes in real time.

The two shipped descriptions: config/rigs/stage_1khz.yaml (1 kHz, 0.25 m, 350 N, 10 ms decisions:
the command held over 10 samples) and config/rigs/long_250hz.yaml (250 Hz, 20 m, 40 N, 8 ms
decisions: 2 samples), each through both faces (msd and ros2_control). The rig emulator serves the
paper's plant in the rig's units (docs/rig-description.md §The emulated plant); the bench is told
nothing but the file. Reduced size (:data:`SMALL`, budgets in paper samples of 10 ms): the four runs
are the slow tier (each a few minutes of real time); the 250 Hz rig through the msd face at
:data:`TINY` is the opt-in ``realtime`` tier's, and the default suite runs the same description on
the bench's own emulated plant in lock-step (no real time, so no load sensitivity). Success is data:
what is asserted is that the run completes, ran at the rig's rate, stroke, force and decision
period, and says so in its report.
"""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from msd_bench.graph import launch
from msd_bench.io.bags.reader import UNCHECKED, read_experiment
from msd_bench.io.rigs.rig_file import read_rig

pytestmark = pytest.mark.e2e
REPO = Path(__file__).resolve().parents[2]
STAGE = REPO / "config" / "rigs" / "stage_1khz.yaml"
LONG = REPO / "config" / "rigs" / "long_250hz.yaml"
R2C = ("--interface", "ros2_control", "--controller", "effort_controller", "--joint", "slider_to_cart")
"""bench.py's options for the rig emulator's ros2_control face (rig.py -p interface:=ros2_control)."""
SMALL = ("--samples", "600", "--val-samples", "400", "--seeds", "2", "--episodes", "20", "--steps", "300",
         "--dyna-episodes", "1", "--validation-steps", "600", "--nlarx-scale", "0.05",
         "--agents", "glm+improved,greybox+robust,dyna-q", "--node-scenarios", "")
"""The slow tier's size: the README's quick look (docs/plant-ns.md) without its on-node scenario."""
TINY = ("--samples", "200", "--val-samples", "400", "--seeds", "1", "--episodes", "2", "--steps", "200",
        "--validation-steps", "300", "--agents", "glm+improved")
"""The smallest run: a 2 s and a 4 s record, one agent, one 3 s validation run."""
_runs = itertools.count()


def _run(rig_file: Path, face: tuple[str, ...], look: tuple[str, ...], out: Path,
         timeout: float) -> subprocess.CompletedProcess[str]:
    """rig.py --rig FILE (with the face asked for) under a namespace of its own, then bench.py against
    it on the caller's domain; the rig is stopped when the bench ends."""
    domain, ns = int(os.environ["ROS_DOMAIN_ID"]), f"/rigd{os.getpid()}_{next(_runs)}"
    node_face = ["-p", "interface:=ros2_control"] if face else []
    with launch.process_group(domain) as procs:
        rig = procs.start("rig.py", [*node_face, "-p", "duplicate_check:=0.0", "-r", f"__ns:={ns}"],
                          script_args=["--rig", str(rig_file)], name="rig")
        rig.wait_for_line(r"ready", timeout=60.0)
        return subprocess.run(
            [sys.executable, "launch_scripts/bench.py", "--rig", str(rig_file), "--plant-ns", ns, *face,
             "--out", str(out), *look], cwd=REPO, capture_output=True, text=True,
            env=launch.ros_env(domain), timeout=timeout, check=False)


def _ran_on_the_rig(rig_file: Path, out: Path, proc: subprocess.CompletedProcess[str],
                    face: str = "msd") -> None:
    """Completed; the report and run.json state the rate, stroke, force limit, decision period and the face
    it ran through; the agent decided every ``samples_per_decision`` samples of the rig's dt."""
    rig = read_rig(rig_file)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and f"report: {out / 'report'}" in proc.stderr
    table = (out / "report" / "table1.md").read_text()
    n = rig.samples_per_decision
    assert (f"Rig (`--rig`): {rig.rate:g} Hz (dt {rig.dt:g} s), stroke {rig.stroke:g} m, force limit "
            f"{rig.force_limit:g} N, {n} sample(s) per {rig.decision_period:g} s decision, "
            f"{face} face") in table
    facts = json.loads((out / "run.json").read_text())["rig"]
    assert (facts["rate_hz"], facts["stroke"], facts["force_limit"], facts["samples_per_decision"]) == (
        rig.rate, rig.stroke, rig.force_limit, n)
    agent = out / "agents" / "glm+improved"
    result = json.loads((agent / "result.json").read_text())
    assert result["config"]["decision_samples"] == n and result["config"]["dt"] == pytest.approx(rig.dt)
    seed = result["per_seed"][0]["seed"]
    # the rows the agent received: at 1 kHz on a loaded machine it misses some (gaps), so unchecked
    exp, params = read_experiment(agent / "validation" / f"seed_{seed}", result["config"]["plant_ns"],
                                  timing=UNCHECKED)
    assert params["target"] == pytest.approx(0.4 * rig.stroke / 2)  # the paper's unit step, in rig units
    assert len(exp) == result["config"]["validation_steps"] and float(abs(exp.y).max()) <= rig.stroke / 2


def test_the_long_stroke_rig_emulated_by_the_bench(tmp_path: Path) -> None:
    """The default suite's run: bench.py --rig long_250hz.yaml without --plant-ns, so the bench's own
    emulated plant serves the description (plant.py --params-file) in lock-step, at :data:`TINY`
    (about 25 s). Real time is the opt-in tiers' (the rest waits alone are 3 s per record)."""
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "launch_scripts/bench.py", "--rig", str(LONG), "--out", str(out),
                           "--domain-id", os.environ["ROS_DOMAIN_ID"], *TINY], cwd=REPO, capture_output=True,
                          text=True, timeout=600, check=False)
    _ran_on_the_rig(LONG, out, proc)
    title = (out / "report" / "table1.md").read_text().splitlines()[0]
    assert "on the true plant (the emulator's plant for the `--rig` description)" in title
    assert "preset" not in title and "Validated behind the safety supervisor" not in title  # it was off
    plant = json.loads((out / "models" / "plant.json").read_text())  # the emulator's plant for the file
    rig = read_rig(LONG)
    assert plant["dt"] == pytest.approx(rig.dt) and plant["force_limit"] == pytest.approx(rig.force_limit)


@pytest.mark.realtime
def test_the_long_stroke_rig_at_a_tiny_size(tmp_path: Path) -> None:
    """250 Hz, 20 m, 40 N, 8 ms decisions, msd face, against rig.py --rig in real time (about 40 s)."""
    out = tmp_path / "run"
    _ran_on_the_rig(LONG, out, _run(LONG, (), (*TINY, "--node-scenarios", ""), out, timeout=600))


@pytest.mark.slow
@pytest.mark.parametrize("rig_file", [STAGE, LONG], ids=["stage_1khz", "long_250hz"])
@pytest.mark.parametrize("face", [(), R2C], ids=["msd", "ros2_control"])
def test_a_rig_not_shaped_like_the_emulator(tmp_path: Path, rig_file: Path, face: tuple[str, ...]) -> None:
    """The slow tier: both shipped rigs through both faces at :data:`SMALL`, behind the supervisor."""
    out = tmp_path / "run"
    _ran_on_the_rig(rig_file, out, _run(rig_file, face, SMALL, out, timeout=3000),
                    "ros2_control" if face else "msd")
