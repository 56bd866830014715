"""``plant+dqn`` / ``plant+ppo`` in the agent node: trained over a lock-step plant node, budget charged.

The agent node is given no model file (as bench.py gives an on-plant deep kind,
like Dyna-Q): its design trains over the plant node's topics at the stated
budget (``episodes`` x ``steps``). The plant node's own step counter says what
it really saw; the policy's real interactions must be that count less the
validation runs, and the network the one trained in-process on the plant model.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.core.deeprl.hyper import CHOSEN
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.designs.deeprl_train import train
from msd_bench.io.bags.reader import read_experiment
from msd_bench.nodes.agent_node import AgentNode, AgentNodeConfig
from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec
from tests.nodes.conftest import ctx, executor, spin_until  # noqa: F401 (fixtures)

pytestmark = pytest.mark.ros


@pytest.mark.parametrize("algo", ["dqn", "ppo"])
def test_the_plant_node_sees_exactly_the_steps_charged(ctx, executor, tmp_path, algo):  # noqa: F811
    cfg = AgentNodeConfig(kind=f"plant+{algo}", seeds=(2,), plant_episodes=2, steps=100, validation_steps=150,
                          window=50, out_dir=str(tmp_path))
    plant = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.0),
                      context=ctx)
    agent = AgentNode(cfg, context=ctx)
    for n in (plant, agent):
        executor.add_node(n)
    assert spin_until(executor, agent.done.done, timeout=600.0)
    assert agent.done.result() == 0
    trained_steps = plant.counters["steps"] - cfg.validation_steps * len(cfg.seeds)
    assert trained_steps == 2 * 100
    doc = json.loads((tmp_path / "result.json").read_text())
    assert doc["real_interactions"] == trained_steps == agent.policy.facts.real_interactions
    assert doc["training"] == f"plant-{algo} over the plant"
    ref = train(plant_model(PlantParams()), CHOSEN[algo], 2, 200, episode_steps=100)
    for got, want in zip(agent.policy.net, ref.net, strict=True):
        assert np.array_equal(got, want)
    # validation parity: the node's closed loop over ROS is the compiled rollout of its network, bit for bit
    x, u = designs.nominal_runs(agent.policy, PlantParams(), cfg.target, cfg.validation_steps)
    exp, _ = read_experiment(tmp_path / "validation" / "seed_2")
    assert np.array_equal(exp.y, x[0]) and np.array_equal(exp.u, u[0])
    back = designs.load(tmp_path, None)  # the artifact the node wrote is the policy it validated
    assert np.array_equal(designs.nominal_runs(back, PlantParams(), cfg.target, cfg.validation_steps)[0], x)
