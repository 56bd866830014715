"""The recording stage through real processes: bags equal plant.simulate bit for bit, nothing is left."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from msd_bench.core.identification import excitation as exc
from msd_bench.core.physics.plant import preset, simulate
from msd_bench.graph import launch
from msd_bench.graph.jobs import JobFiles
from msd_bench.graph.record import (
    ExperimentSpec,
    RecordError,
    RecordServers,
    paper_plan,
    record_experiments,
)
from msd_bench.io.bags.reader import bag_info, read_experiment, read_topic

pytestmark = pytest.mark.e2e

SPECS = [
    ExperimentSpec("prbs_p5", "prbs",
                   exc.PrbsConfig(bias=5.0, amplitude=6.0, n_samples=250, hold=7, settle=50),
                   seed=11, params={"role": "train", "bias": 5.0}),
    ExperimentSpec("multi", "multilevel", exc.MultilevelConfig(n_samples=300, min_dwell=10, max_dwell=60),
                   seed=4, params={"role": "validation"}),
]


def _alive(pid: int) -> bool:
    try:
        os.killpg(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _rows(bag) -> np.ndarray:
    """(stamp, position, velocity, effort) of every joint_states message, in bag order."""
    _, msgs = read_topic(bag, "/msd/joint_states")
    return np.array([(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, m.position[0], m.velocity[0],
                      m.effort[0]) for m in msgs])


def _regenerate(params: dict) -> np.ndarray:
    if params["signal"] == "prbs":
        return exc.prbs(exc.PrbsConfig(**params["prbs"]), params["seed"])
    ml = params["multilevel"]
    return exc.multilevel(exc.MultilevelConfig(**{**ml, "levels": tuple(ml["levels"])}), params["seed"])


def test_two_experiments_record_exactly_what_the_plant_simulates(tmp_path):
    seen: list[tuple[int, int, str]] = []
    with launch.process_group() as procs:
        plant = procs.start("plant.py", ["-p", "lockstep:=true", "-p", "duplicate_check:=0.0"])
        plant.wait_for_line("ready", timeout=20.0)
        plant_pid = plant.pid
        servers = RecordServers.launch(procs)
        jobs = JobFiles(tmp_path / "run")
        bags = record_experiments(SPECS, tmp_path, procs, progress=lambda *a: seen.append(a), servers=servers,
                                  jobs=jobs)
        with pytest.raises(RecordError, match=r"^experiment multi: bag .* already exists"):
            record_experiments(SPECS[1:], tmp_path, procs, jobs=jobs)  # the bag exists: the recorder refuses
        pids = [p.pid for p in procs.procs]
    assert seen == [(1, 2, "prbs_p5"), (2, 2, "multi")]
    # lock-step: the second experiment reused the endpoints the first had matched (nodes/endpoints.py)
    assert servers.recorder.proc.output().count("pooled subscription /msd/joint_states") == 1
    assert servers.excitation.proc.output().count("pooled publisher /msd/force") == 1
    assert bags == [tmp_path / "prbs_p5", tmp_path / "multi"]
    assert np.abs(SPECS[0].force()).max() > 10.0  # saturation at F = 10 N is exercised
    for spec, bag in zip(SPECS, bags, strict=True):
        x, v, u = simulate(spec.force(), preset("default"))
        rows = _rows(bag)
        assert np.array_equal(rows[:, 0], np.arange(u.size) * 10_000_000)  # reset: sample 0 at t = 0
        # Lock-step bags are timed in sim time: log times are the stamps, the duration their span.
        assert np.array_equal(read_topic(bag, "/msd/joint_states")[0], rows[:, 0].astype(np.int64))
        assert bag_info(bag).duration_s == pytest.approx((u.size - 1) * 0.01, abs=1e-9)
        assert np.array_equal(rows[:, 1], x) and np.array_equal(rows[:, 2], v)
        assert np.array_equal(rows[:, 3], u)
        experiment, params = read_experiment(bag)
        assert np.array_equal(experiment.y, x) and np.array_equal(experiment.u, u)
        assert params == json.loads(json.dumps(spec.bag_params())) and params["role"] == spec.params["role"]
        assert np.array_equal(_regenerate(params), spec.force())  # the bag says how to replay it
    assert not any(_alive(pid) for pid in [plant_pid, *pids])
    # each node ran from its job file, kept in the run directory as the record of what it was asked
    ex_job = json.loads((tmp_path / "run" / "jobs" / "excitation-prbs_p5.json").read_text())
    assert ex_job["role"] == "excitation" and ex_job["params"]["prbs.bias"] == 5.0
    assert ex_job["params"]["dt"] == preset("default").dt
    rec_job = json.loads((tmp_path / "run" / "jobs" / "recorder-multi.json").read_text())
    assert rec_job["params"]["bag_path"] == str(tmp_path / "multi")


def test_paper_plan_has_the_papers_experiments():
    plan = paper_plan(id_seed=3, n_samples=1200, val_samples=400)
    names = [s.name for s in plan]
    assert names == ["bias_m10", "bias_m5", "bias_0", "bias_p5", "bias_p10", "broad",
                     "val_bias_m10", "val_bias_m5", "val_bias_0", "val_bias_p5", "val_bias_p10", "val_broad"]
    train, val = plan[:6], plan[6:]
    assert [s.config.bias for s in train[:5]] == [-10.0, -5.0, 0.0, 5.0, 10.0]
    assert all(s.config.amplitude == 1.0 and s.config.n_samples == 1200 for s in train[:5])
    assert all(s.config.n_samples == 400 for s in val)
    assert {s.params["role"] for s in train} == {"train"}
    assert {s.params["role"] for s in val} == {"validation"}
    for t, v in zip(train, val, strict=True):  # other seeds: other data at the same operating point
        assert t.seed != v.seed and not np.array_equal(t.force()[-400:], v.force()[-400:])
