"""The agent node: ROS-trained == in-process-trained, and plant validation == the core's."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from msd_bench.app import agents
from msd_bench.app.agents import robust_config
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import identify_surrogates, make_records
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.learning.dyna import DynaConfig, train_dyna
from msd_bench.core.learning.qtrain import greedy_rollouts, train
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.bags.reader import read_experiment, read_topic
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.artifacts import ArtifactError
from msd_bench.nodes.agent_node import AgentNode, AgentNodeConfig
from msd_bench.nodes.episode_client import EpisodeError
from msd_bench.nodes.plant_node import ModelSpec, PlantNode, PlantNodeConfig, true_plant_spec
from msd_bench.nodes.spin import make_executor, wants_events_executor
from msd_msgs_py.contract import PLANT_NAMESPACE, REFERENCE
from msd_msgs_py.ros import msg_class, qos
from tests.nodes.conftest import spin_until


def _qc(cfg):
    """The learner the node's kind trains with at its budgets (the design's choice of which)."""
    from msd_bench import designs

    design = designs.agent_kind(cfg.kind).design
    return design.config(designs.request(cfg.kind, None, cfg.settings(), cfg.seeds))

pytestmark = pytest.mark.ros
LOCKSTEP = PlantNodeConfig(lockstep=True, duplicate_check=0.0)


@pytest.fixture(scope="module")
def glm_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    cfg = RunConfig(samples=2000, val_samples=600)
    models, _ = identify_surrogates(make_records(cfg, 0), ["glm"], 0, cfg.plant)
    path = tmp_path_factory.mktemp("models") / "glm.json"
    return artifacts.save_model(models["glm"], path, artifacts.Provenance())


def _run(ctx, executor, cfg: AgentNodeConfig, surrogate=None) -> AgentNode:
    nodes = [PlantNode(true_plant_spec(), config=LOCKSTEP, context=ctx)]
    if surrogate is not None:
        spec = ModelSpec(surrogate, 0.01, 10.0)
        nodes.append(PlantNode(spec, config=LOCKSTEP, namespace="/surrogate/glm", context=ctx))
    agent = AgentNode(cfg, context=ctx)
    for n in [*nodes, agent]:
        executor.add_node(n)
    assert spin_until(executor, agent.done.done, timeout=120.0)
    return agent


def test_ros_training_is_bit_identical_and_validation_matches_core(ctx, executor, glm_path, tmp_path):
    cfg = AgentNodeConfig(kind="glm", model_path=str(glm_path), seeds=(3, 4), episodes=2, steps=150,
                          via_ros=True, surrogate_ns="/surrogate/glm", validation_steps=300,
                          window=100, out_dir=str(tmp_path))
    model = artifacts.load_model(glm_path)
    agent = _run(ctx, executor, cfg, surrogate=model)
    reference = train(model, _qc(cfg), cfg.seeds)
    assert np.array_equal(agent.policy.q, reference.q)
    x_ref, u_ref = greedy_rollouts(plant_model(PlantParams()), reference.q, _qc(cfg), 1.0, 300)
    for i, seed in enumerate(cfg.seeds):
        exp, params = read_experiment(tmp_path / "validation" / f"seed_{seed}")
        assert np.array_equal(exp.y, x_ref[i]) and np.array_equal(exp.u, u_ref[i])
        assert params["seed"] == seed
        assert agent.per_seed[i]["sse"] == compute(x_ref[i], 1.0, 0.01, 100).sse
    doc = json.loads((tmp_path / "result.json").read_text())
    assert doc["training"] == "ros" and len(doc["per_seed"]) == 2 and doc["drive_told"] is None
    arrays, meta = artifacts.load_qtables(tmp_path / "qtables.npz")
    assert np.array_equal(arrays["q"], reference.q)
    assert meta["provenance"]["sources"][0]["sha256"] == artifacts.sha256_path(glm_path)


def test_ros_training_keeps_the_tables_the_batch_selects(ctx, executor, glm_path, tmp_path, monkeypatch):
    """A robust kind trained over ROS rehearses its snapshots as :func:`train` does in-process."""
    every = replace(robust_config(), select_every=1)  # candidates: episodes 4, 3, 2
    monkeypatch.setitem(agents.LEARNERS, "robust", lambda: every)
    cfg = AgentNodeConfig(kind="glm+robust", model_path=str(glm_path), seeds=(3, 4), episodes=4, steps=150,
                          via_ros=True, surrogate_ns="/surrogate/glm", validation_steps=100,
                          window=50, out_dir=str(tmp_path))
    assert _qc(cfg).selection_episodes() == (4, 3, 2)
    model = artifacts.load_model(glm_path)
    agent = _run(ctx, executor, cfg, surrogate=model)
    reference = train(model, _qc(cfg), cfg.seeds)
    assert reference.kept_episodes is not None
    assert np.array_equal(agent.policy.q, reference.q)


def test_dyna_q_interacts_with_the_plant_node(ctx, executor, tmp_path):
    cfg = AgentNodeConfig(kind="dyna-q", planning_steps=5, seeds=(1,), plant_episodes=2,
                          steps=100, validation_steps=200, window=50, out_dir=str(tmp_path))
    agent = _run(ctx, executor, cfg)
    ref = train_dyna(plant_model(PlantParams()), DynaConfig(replace(_qc(cfg)), 5), [1])
    assert np.array_equal(agent.policy.q, ref.q)
    assert agent.policy.facts.real_interactions == 200


def test_validation_announces_the_set_point_and_bags_it(ctx, executor, tmp_path):
    """Each validation run publishes its set-point on <plant_ns>/reference; its bag carries it at t_0."""
    heard: list[float] = []
    listener = Node("reference_listener", context=ctx)
    listener.create_subscription(msg_class(REFERENCE), REFERENCE.resolve(PLANT_NAMESPACE),
                                 lambda m: heard.append(m.data), qos(REFERENCE))
    executor.add_node(listener)
    cfg = AgentNodeConfig(kind="dyna-q", planning_steps=0, seeds=(5, 6), plant_episodes=2,
                          steps=100, target=0.8, validation_steps=120, window=50, out_dir=str(tmp_path))
    _run(ctx, executor, cfg)
    assert spin_until(executor, lambda: len(heard) >= 2, timeout=2.0)
    assert heard == [0.8, 0.8]  # once per validation run, none during training
    for seed in cfg.seeds:
        bag = tmp_path / "validation" / f"seed_{seed}"
        stamps, msgs = read_topic(bag, REFERENCE.resolve(PLANT_NAMESPACE))
        rows, _ = read_topic(bag, "/msd/joint_states")
        assert [m.data for m in msgs] == [0.8] and stamps[0] == rows.min()


def test_bad_configuration_is_one_line(tmp_path):
    with pytest.raises(ConfigError, match="model_path is required"):
        AgentNodeConfig(out_dir=str(tmp_path))
    with pytest.raises(ConfigError, match=r"unknown agent kind 'clever'"):
        AgentNodeConfig(model_path="m.json", out_dir=str(tmp_path), kind="clever")


def test_missing_model_fails_before_any_traffic(ctx, tmp_path):
    cfg = AgentNodeConfig(model_path=str(tmp_path / "nope.json"), out_dir=str(tmp_path))
    with pytest.raises(ArtifactError, match="no such artifact"):
        AgentNode(cfg, context=ctx)


def test_ros_training_on_the_events_executor_is_bit_identical(ctx, glm_path, tmp_path):
    """The executor launched agents and lock-step plant-like nodes spin on (:func:`make_executor`)."""
    cfg = AgentNodeConfig(kind="glm", model_path=str(glm_path), seeds=(5,), episodes=2, steps=150,
                          via_ros=True, surrogate_ns="/surrogate/glm", validation_steps=200,
                          window=50, out_dir=str(tmp_path))
    events = make_executor(context=ctx, events=True)
    assert not isinstance(events, SingleThreadedExecutor)
    try:
        agent = _run(ctx, events, cfg, surrogate=artifacts.load_model(glm_path))
        assert agent.done.result() == 0
        assert np.array_equal(agent.policy.q, train(artifacts.load_model(glm_path), _qc(cfg), cfg.seeds).q)
    finally:
        events.shutdown()


def test_a_user_error_in_a_callback_ends_the_agent_through_done(ctx, executor, tmp_path, glm_path):
    """No surrogate answers: the episode client's EpisodeError completes ``done`` (one line from the
    process) instead of escaping into the executor."""
    cfg = AgentNodeConfig(kind="glm", model_path=str(glm_path), seeds=(0,), episodes=1, steps=10,
                          via_ros=True, surrogate_ns="/surrogate/nobody", out_dir=str(tmp_path),
                          match_timeout=0.3)
    agent = AgentNode(cfg, context=ctx)
    executor.add_node(agent)
    assert spin_until(executor, agent.done.done, timeout=20.0)
    with pytest.raises(EpisodeError, match="no plant-like node answers under /surrogate/nobody"):
        agent.done.result()
    assert wants_events_executor(agent)
