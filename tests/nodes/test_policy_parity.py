"""Every deterministic design validates bit for bit the same over ROS as in-process.

The agent node drives each design's stepwise controller against a lock-step
plant node; the in-process engine runs the design's compiled rollout. Both must
give the same positions and commands sample for sample, so Table 1 means the
same in both engines. The relay design exists only in the tests: registered
here, it runs through the agent node with no other edit.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import identify_surrogates, make_records
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.bags.reader import read_experiment
from msd_bench.io.storage import artifacts
from msd_bench.nodes.agent_node import AgentNode, AgentNodeConfig
from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec
from tests.designs.relay import RelayDesign
from tests.nodes.conftest import spin_until

pytestmark = pytest.mark.ros
LOCKSTEP = PlantNodeConfig(lockstep=True, duplicate_check=0.0)
STEPS = 400


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    cfg = RunConfig(samples=1500, val_samples=600)
    models, _ = identify_surrogates(make_records(cfg, 0), ["glm", "plm", "greybox"], 0, cfg.plant)
    out = tmp_path_factory.mktemp("models")
    for name, m in models.items():
        artifacts.save_model(m, out / f"{name}.json", artifacts.Provenance())
    return out


@pytest.fixture
def relay() -> Iterator[None]:
    designs.register(RelayDesign())
    yield
    designs.unregister("relay")


def _validate_over_ros(ctx, executor, kind: str, model_path: Path, out: Path) -> AgentNode:
    cfg = AgentNodeConfig(kind=kind, model_path=str(model_path), seeds=(7,), validation_steps=STEPS,
                          window=100, out_dir=str(out))
    plant = PlantNode(true_plant_spec(), config=LOCKSTEP, context=ctx)
    agent = AgentNode(cfg, context=ctx)
    for n in (plant, agent):
        executor.add_node(n)
    assert spin_until(executor, agent.done.done, timeout=120.0)
    assert agent.done.result() == 0
    return agent


def _check_parity(agent: AgentNode, kind: str, model_path: Path, out: Path) -> None:
    model = artifacts.load_model(model_path)
    policy = designs.make(kind, model, agent.config.settings(), [7])
    x, u = designs.nominal_runs(policy, PlantParams(), 1.0, STEPS)
    assert x.shape == (1, STEPS)  # deterministic: one run, not one per seed
    exp, _ = read_experiment(out / "validation" / "seed_7")
    assert np.array_equal(exp.y, x[0]) and np.array_equal(exp.u, u[0])
    doc = json.loads((out / "result.json").read_text())
    assert doc["baseline"] and doc["deterministic"] and doc["real_interactions"] == 0
    back = designs.load(out, model)  # the artifact the node wrote is the policy it validated
    assert np.array_equal(designs.nominal_runs(back, PlantParams(), 1.0, STEPS)[0], x)


@pytest.mark.parametrize("kind", ["glm+pid", "glm+pid-continuous", "greybox+lqr", "plm+mpc"])
def test_a_baseline_validates_the_same_over_ros(ctx, executor, model_dir, tmp_path, kind):
    model_path = model_dir / f"{kind.split('+')[0]}.json"
    agent = _validate_over_ros(ctx, executor, kind, model_path, tmp_path)
    _check_parity(agent, kind, model_path, tmp_path)


def test_a_design_registered_only_here_runs_through_the_agent_node(ctx, executor, model_dir, tmp_path, relay):
    agent = _validate_over_ros(ctx, executor, "glm+relay", model_dir / "glm.json", tmp_path)
    _check_parity(agent, "glm+relay", model_dir / "glm.json", tmp_path)
