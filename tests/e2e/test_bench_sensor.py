"""bench.py recording through a sensor: measured bags with the truth beside them, fits scored on both."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.physics.plant import preset, simulate
from msd_bench.io.bags.reader import bag_info, read_experiment
from msd_msgs_py.contract import JOINT_STATES, TRUTH_JOINT_STATES

pytestmark = pytest.mark.e2e
REPO = Path(__file__).resolve().parents[2]
NOISE = 0.002


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    out = tmp_path_factory.mktemp("bench_sensor") / "run"
    argv = [sys.executable, "launch_scripts/bench.py", "--out", str(out), "--record-noise", str(NOISE),
            "--stages", "record,identify", "--samples", "600", "--val-samples", "400", "--agents", "glm",
            "--domain-id", os.environ["ROS_DOMAIN_ID"]]
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=300)
    return out, proc


def test_records_only_what_the_glm_needs_and_exits_cleanly(run):
    out, proc = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    assert sorted(p.name for p in (out / "excitation").iterdir()) == ["broad", "val_broad"]
    assert "% vs truth)" in proc.stderr  # the identify stage reports the fit against the truth


@pytest.mark.parametrize("name", ["broad", "val_broad"])
def test_bags_hold_measured_rows_and_the_truth_of_every_sample(run, name):
    out, _ = run
    bag = out / "excitation" / name
    topics = bag_info(bag).topics
    exp, params = read_experiment(bag)
    n = len(exp)
    assert n == (600 if params["role"] == "train" else 400)
    assert topics[JOINT_STATES.resolve("/msd")][1] == topics[TRUTH_JOINT_STATES.resolve("/msd")][1] == n
    assert exp.truth is not None
    x, _, _ = simulate(exp.u, preset("default"))
    assert np.array_equal(exp.truth, x)  # the truth topic is the emulated plant, bit for bit
    err = exp.y - exp.truth
    assert exp.truth[0] == 0.0 and exp.y[0] != 0.0  # started at rest; the sensor reads noise there
    assert abs(float(np.std(err)) - NOISE) < 0.2 * NOISE, float(np.std(err))


def test_fits_carry_the_fit_against_the_truth(run):
    out, _ = run
    fits = json.loads((out / "models" / "fits.json").read_text())
    glm = fits["glm"]
    assert glm["sim_fit_truth"] is not None and math.isfinite(glm["sim_fit_truth"])
    # 2 mm of noise on a stroke-wide record moves the fit a little, not a lot
    assert abs(glm["sim_fit_truth"] - glm["sim_fit"]) < 2.0
    assert glm["sim_fit_truth"] != glm["sim_fit"]


def test_plant_args_carry_the_sensor_only_for_recording(tmp_path):
    from msd_bench.app.config import RunConfig
    from msd_bench.graph.bench import BenchConfig, plant_args, record_plan

    noisy = BenchConfig(tmp_path, RunConfig(record_noise=NOISE, record_quant=0.0005, id_first_seed=4,
                                            agents=("glm",)))
    args = plant_args(noisy, sensor=True)
    assert {"sensor_noise:=0.002", "sensor_quant:=0.0005", "sensor_seed:=4"} <= set(args)
    assert not any(a.startswith("sensor_") for a in plant_args(noisy, sensor=False))  # agents: ideal plant
    assert not any(a.startswith("sensor_") for a in plant_args(BenchConfig(tmp_path), sensor=True))
    assert [s.name for s in record_plan(noisy)] == ["broad", "val_broad"]
    with_plm = BenchConfig(tmp_path, RunConfig(agents=("plm+improved",)))
    assert len(record_plan(with_plm)) == 12
