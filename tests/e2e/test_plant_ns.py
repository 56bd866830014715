"""bench.py --plant-ns end to end: the README's short configuration against a separately started
real-time plant-like node (no emulator started by the bench, no reset used), on the caller's domain."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from msd_bench.io.bags import read_experiment
from tests.e2e.realtime_runs import PLANT_NS, Run

pytestmark = pytest.mark.e2e
NS = PLANT_NS


@pytest.fixture(scope="module")
def run(realtime_runs: dict[str, Run]) -> tuple[Path, subprocess.CompletedProcess[str], int]:
    plant = realtime_runs["plant"]
    return plant.out, plant.proc, plant.domain


def test_completes_without_a_traceback_and_says_what_it_does(run) -> None:  # type: ignore[no-untyped-def]
    out, proc, domain = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    assert f"plant-like node {NS}: no emulator started" in proc.stderr
    assert "expected real-time duration about" in proc.stderr
    assert f"ROS_DOMAIN_ID={domain})" in proc.stderr  # the caller's, not a claimed one
    assert f"report: {out / 'report'}" in proc.stderr


def test_report_has_no_plant_kinds_and_states_the_dyna_budget(run) -> None:  # type: ignore[no-untyped-def]
    out, *_ = run
    table = (out / "report" / "table1.md").read_text()
    doc = json.loads((out / "report" / "table1.json").read_text())
    kinds = [r["kind"] for r in doc["agents"]]
    assert set(kinds) == {"glm+improved", "greybox+robust", "dyna-q"}
    assert doc["run"]["plant_ns"] == NS and "dyna_budget" in doc["run"]
    assert "true plant" not in table
    assert "Dyna-Q trained on /fakerig in real time: 2 seed(s) x 1 episode(s) x 300 steps" in table
    assert not (out / "models" / "plant.json").exists()  # the emulator's own model is never written


def test_robustness_is_measured_on_the_node(run) -> None:  # type: ignore[no-untyped-def]
    out, *_ = run
    rob = json.loads((out / "report" / "robustness.json").read_text())
    text = json.dumps(rob)
    assert "setpoint=0.5" in text and "noise=" not in text and "mass=" not in text
    result = json.loads((out / "agents" / "greybox+robust" / "result.json").read_text())
    cell = result["on_node_scenarios"]["setpoint=0.5"]
    assert cell["n"] == 2 and len(cell["sse"]) == 2
    for seed in (0, 1):
        exp, params = read_experiment(out / "agents" / "greybox+robust" / "scenarios" / "setpoint_0.5" /
                                      f"seed_{seed}", NS)
        assert params["target"] == 0.5 and len(exp) == 600


def test_episodes_start_from_a_measured_rest_position(run) -> None:  # type: ignore[no-untyped-def]
    out, *_ = run
    for kind in ("glm+improved", "dyna-q"):
        x0 = json.loads((out / "agents" / kind / "result.json").read_text())["x0"]["nominal"]
        assert set(x0) == {"0", "1"}
        for seed, value in x0.items():
            exp, _ = read_experiment(out / "agents" / kind / "validation" / f"seed_{seed}", NS)
            assert abs(value) < 0.2  # at rest near the spring's equilibrium (friction may hold it off)
            assert abs(exp.y[0] - value) < 0.02  # the episode starts where the rest was measured


def test_only_the_broad_records_are_recorded_and_identified(run) -> None:  # type: ignore[no-untyped-def]
    out, *_ = run
    assert sorted(p.name for p in (out / "excitation").iterdir()) == ["broad", "val_broad"]
    fits = json.loads((out / "models" / "fits.json").read_text())
    assert set(fits) == {"glm", "greybox"}
    run_doc = json.loads((out / "run.json").read_text())
    assert run_doc["plant_ns"] == NS and run_doc["realtime"] is True
