"""The record stage's and the surrogate's nodes built from the job files bench.py writes (in-process).

What is checked: a node given ``-p job:=<file>`` runs what the run configuration and the stage's
placement say (the excitation plays exactly the experiment's signal, at the run's ``dt``); an explicit
``-p`` beside the file wins (docs/design.md §Contract); a bad field of any section is one JobError
line naming the file and the field, raised before the node does anything (a recorder creates no bag).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rclpy.parameter import Parameter

from msd_bench.app.config import RunConfig
from msd_bench.app.job import JobError, job_document
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification import excitation as exc
from msd_bench.core.physics.kernels import KIND_LINEAR
from msd_bench.core.physics.model import StepModel
from msd_bench.graph.bench import BenchConfig, surrogate_job
from msd_bench.graph.jobs import JobFiles
from msd_bench.graph.record import (
    ExperimentSpec,
    Placement,
    excitation_placement,
    recorded_topics,
    recorder_placement,
)
from msd_bench.io.storage.artifacts import Provenance, save_model
from msd_bench.nodes.excitation_node import ExcitationNode
from msd_bench.nodes.identifier_node import IdentifierNode
from msd_bench.nodes.params import reject_unknown_parameters
from msd_bench.nodes.recorder_node import RecorderNode
from msd_bench.nodes.surrogate_node import build_surrogate
from msd_msgs_py.interface import MSD_INTERFACE

pytestmark = pytest.mark.ros

RUN = RunConfig(agents=("glm",))
SPEC = ExperimentSpec("multi", "multilevel",
                      exc.MultilevelConfig(levels=(-7.5, 0.1, 3.3), n_samples=120, min_dwell=5, max_dwell=20),
                      seed=9, params={"role": "train"})


def _where(tmp_path: Path, lockstep: bool = True, rest: bool = False) -> Placement:
    return Placement("/msd", lockstep, False, rest, MSD_INTERFACE, 16, JobFiles(tmp_path), RUN)


def _file(tmp_path: Path, name: str, doc: dict) -> Path:
    return JobFiles(tmp_path).write(name, doc)


def _edited(path: Path, **params: object) -> Path:
    doc = json.loads(path.read_text())
    doc["params"].update(params)
    path.write_text(json.dumps(doc))
    return path


def _excitation_job(tmp_path: Path, **where: bool) -> Path:
    placement = excitation_placement(SPEC, tmp_path / "bag", _where(tmp_path, **where))
    doc = job_document("excitation", RUN, placement)
    return _file(tmp_path, "excitation-multi", doc)


def test_an_excitation_from_its_job_file_plays_the_experiment(ctx, tmp_path):
    job = Parameter("job", value=str(_excitation_job(tmp_path)))
    node = ExcitationNode(context=ctx, parameter_overrides=[job])
    assert np.array_equal(node.signal, SPEC.force())  # the signal's fields came through its section exactly
    c = node.config
    assert (c.signal, c.seed, c.lockstep, c.reset_first, c.window, c.pooled, c.dt) == (
        "multilevel", 9, True, True, 16, True, RUN.plant.dt)
    assert c.wait_recorder == str(tmp_path / "bag")
    assert list(node.get_parameter("multilevel.levels").value) == [-7.5, 0.1, 3.3]  # ros2 param get shows it


def test_a_p_beside_the_job_file_wins(ctx, tmp_path):
    path = str(_excitation_job(tmp_path))
    node = ExcitationNode(context=ctx, parameter_overrides=[
        Parameter("job", value=path), Parameter("window", value=3),
        Parameter("multilevel.n_samples", value=40)])
    assert node.config.window == 3 and node.signal.size == 40
    assert node.config.seed == 9 and node.config.lockstep  # the rest is the file's


def test_a_realtime_rig_experiment_rests_instead_of_resetting(ctx, tmp_path):
    path = _excitation_job(tmp_path, lockstep=False, rest=True)
    node = ExcitationNode(context=ctx, parameter_overrides=[Parameter("job", value=str(path))])
    c = node.config
    assert (c.lockstep, c.reset_first, c.rest_first, c.window, c.pooled) == (False, False, True, 1, False)


@pytest.mark.parametrize(("params", "message"), [
    ({"multilevel.min_dwell": 0}, r"field multilevel\.min_dwell: 0 is outside \[1, "),
    ({"multilevel.levels": 2.0}, r"field multilevel\.levels must be a list"),
    ({"multilevel.nope": 1}, r"unknown field 'multilevel\.nope' for a excitation node"),
    ({"dt": -1.0}, r"field dt: -1\.0 is outside"),
    ({"signal": "chirp"}, r"signal must be one of"),
])
def test_a_bad_excitation_job_is_one_line_naming_file_and_field(ctx, tmp_path, params, message):
    path = _edited(_excitation_job(tmp_path), **params)
    with pytest.raises(JobError, match=message) as err:
        ExcitationNode(context=ctx, parameter_overrides=[Parameter("job", value=str(path))])
    assert str(err.value).startswith(f"job file {path}") and "\n" not in str(err.value)


def _recorder_job(tmp_path: Path) -> Path:
    topics = recorded_topics(False)
    placement = recorder_placement(SPEC, tmp_path / "bag", _where(tmp_path), 120, topics)
    doc = job_document("recorder", RUN, placement)
    return _file(tmp_path, "recorder-multi", doc)


def test_a_recorder_from_its_job_file_records_what_the_stage_asks(ctx, tmp_path):
    job = Parameter("job", value=str(_recorder_job(tmp_path)))
    node = RecorderNode(context=ctx, parameter_overrides=[job])
    try:
        c = node.config
        assert (c.bag_path, c.topics, c.max_messages, c.pooled) == (
            str(tmp_path / "bag"), ("joint_states",), 120, True)
        assert c.params() == json.loads(json.dumps(SPEC.bag_params()))
    finally:
        node.destroy_node()


def test_a_stray_recorder_job_field_is_refused_before_a_bag_is_created(ctx, tmp_path):
    path = _edited(_recorder_job(tmp_path), max_mesages=3)
    with pytest.raises(JobError, match=r"unknown field 'max_mesages' for a recorder node") as err:
        RecorderNode(context=ctx, parameter_overrides=[Parameter("job", value=str(path))])
    assert str(path) in str(err.value)
    assert not (tmp_path / "bag").exists()


GLM = StepModel(KIND_LINEAR, np.array([5.0, 0.02, 0.01, -1.6, 0.68, 1.0, 0.5]), name="glm")


def test_a_surrogate_from_its_job_file_and_a_p_beside_it(ctx, tmp_path):
    save_model(replace(GLM, dt=0.02), tmp_path / "models" / "glm.json", Provenance(seed=1))  # the job's rate
    path = _file(tmp_path, "surrogate-glm", surrogate_job(BenchConfig(tmp_path, RUN, via_ros=True), "glm"))
    _edited(path, dt=0.02, force_limit=4.0, duplicate_check=0.0)  # a plant node field: its section too
    node = build_surrogate(context=ctx, parameter_overrides=[Parameter("job", value=str(path))])
    assert node.config.lockstep and node.config.duplicate_check == 0.0  # the plant node's own config
    assert (node.spec.dt, node.spec.force_limit) == (0.02, 4.0)
    node.destroy_node()
    node = build_surrogate(context=ctx, namespace="/surrogate/other", parameter_overrides=[
        Parameter("job", value=str(path)), Parameter("force_limit", value=2.5)])
    assert (node.spec.dt, node.spec.force_limit) == (0.02, 2.5)


def test_a_surrogate_refuses_a_model_of_another_rate_in_one_line(ctx, tmp_path):
    """Issue 32: a model identified at 100 Hz is not served at 50 Hz (never resampled)."""
    save_model(GLM, tmp_path / "models" / "glm.json", Provenance(seed=1))
    path = _file(tmp_path, "surrogate-glm", surrogate_job(BenchConfig(tmp_path, RUN, via_ros=True), "glm"))
    _edited(path, dt=0.02)
    with pytest.raises(InvalidInputError, match=r"identified at dt 0\.01 s \(100 Hz\) but the surrogate node "
                                                r"\(parameter dt\) runs at dt 0\.02 s \(50 Hz\)") as err:
        build_surrogate(context=ctx, parameter_overrides=[Parameter("job", value=str(path))])
    assert "\n" not in str(err.value)


def test_a_bad_surrogate_job_names_the_file_and_the_field(ctx, tmp_path):
    save_model(GLM, tmp_path / "models" / "glm.json", Provenance(seed=1))
    path = _file(tmp_path, "surrogate-glm", surrogate_job(BenchConfig(tmp_path, RUN, via_ros=True), "glm"))
    _edited(path, lockstep="yes")
    with pytest.raises(JobError, match=r"field lockstep must be bool, got 'yes'") as err:
        build_surrogate(context=ctx, parameter_overrides=[Parameter("job", value=str(path))])
    assert str(path) in str(err.value)


def test_a_stray_field_in_a_single_config_job_is_refused_before_the_node_spins(ctx, tmp_path):
    """The agent's and identifier's jobs are read by the same loader: a field no declaration took is
    refused once the node is built (:func:`reject_unknown_parameters`, as spin and serve call it), before
    its first timer runs."""
    place = {"bags_dir": str(tmp_path / "bags"), "out_dir": str(tmp_path / "models"), "namespace": "/msd"}
    path = _edited(_file(tmp_path, "identifier", job_document("identifier", RUN, place)), nlarx_scal=0.5)
    node = IdentifierNode(context=ctx, parameter_overrides=[Parameter("job", value=str(path))])
    with pytest.raises(JobError, match=r"unknown field 'nlarx_scal' for a identifier node") as err:
        reject_unknown_parameters(node)
    assert str(path) in str(err.value) and not (tmp_path / "models").exists()
