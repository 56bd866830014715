"""bench.py --rig FILE --plant-ns /rig against rig.py serving a held-out member of the ``stage`` family
(issue 38): a rig not shaped like the emulator, with no equilibrium of its own, end to end in real time.

``msd-bench rig-file`` writes what the member's owner states (rate, stroke, force limit, decision
period, the hold loop its drive runs); ``rig.py -p family:=stage -p population_seed:=1000`` serves the
member, its drive adding the loop's force to every command; bench.py records, identifies the held
system (the bags' effort less the loop's force), trains and validates through the node graph. Reduced
size (the slow tier's :data:`SMALL` of the other rigs, docs/rig-families.md §stage): what is asserted is
that the run completes on the member's rate, stroke, force and decision period, says it ran under the
loop, and that the held system's fits are usable; success is data.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from msd_bench.cli import main as cli_main
from msd_bench.graph import launch
from msd_bench.io.rigs.rig_file import read_rig
from tests.e2e.test_rig_description_bench import SMALL

pytestmark = [pytest.mark.e2e, pytest.mark.slow]
REPO = Path(__file__).resolve().parents[2]
MEMBER = 1000
"""The first held-out stage (500 Hz, 0.75 m, 137 N, 8 samples per decision)."""
AGENTS = ("--agents", "greybox+robust,glm+improved,glm+pid")
"""A robust and a plain Q-agent and a baseline, each deciding every 8 rig samples."""


def test_bench_runs_the_method_on_a_held_out_stage_served_by_the_rig_emulator(tmp_path: Path) -> None:
    rig_file, out = tmp_path / "stage.yaml", tmp_path / "run"
    assert cli_main(["rig-file", "--family", "stage", "--member", str(MEMBER), "--out", str(rig_file)]) == 0
    rig = read_rig(rig_file)
    size = [a for a in SMALL if a not in ("--agents", "glm+improved,greybox+robust,dyna-q")]
    domain, ns = int(os.environ["ROS_DOMAIN_ID"]), f"/stage{os.getpid()}"
    with launch.process_group(domain) as procs:
        served = procs.start("rig.py", ["-p", "family:=stage", "-p", f"population_seed:={MEMBER}",
                                        "-p", "duplicate_check:=0.0", "-r", f"__ns:={ns}"], name="rig")
        served.wait_for_line(r"ready", timeout=60.0)
        proc = subprocess.run(
            [sys.executable, "launch_scripts/bench.py", "--rig", str(rig_file), "--plant-ns", ns,
             "--out", str(out), *size, *AGENTS], cwd=REPO, capture_output=True, text=True,
            env=launch.ros_env(domain), timeout=3000, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    table = (out / "report" / "table1.md").read_text()
    assert (f"Rig (`--rig`): {rig.rate:g} Hz (dt {rig.dt:g} s), stroke {rig.stroke:g} m, force limit "
            f"{rig.force_limit:g} N, {rig.samples_per_decision} sample(s) per {rig.decision_period:g} s "
            "decision, msd face; held by its drive's position loop") in table
    facts = json.loads((out / "run.json").read_text())["rig"]
    assert facts["hold_loop"]["stiffness"] == pytest.approx(rig.hold_stiffness)
    fits = json.loads((out / "models" / "fits.json").read_text())
    assert fits["greybox"]["sim_fit"] > 80.0  # the held system, from the effort less the loop
    for kind in ("greybox+robust", "glm+improved", "glm+pid"):
        result = json.loads((out / "agents" / kind / "result.json").read_text())
        assert result["config"]["decision_samples"] == rig.samples_per_decision
