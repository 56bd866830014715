"""The step-at-a-time agent is the compiled trainer, bit for bit (basis of --via-ros)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.learning.dyna import DynaConfig, train_dyna
from msd_bench.core.learning.learner import GreedyPolicy, StepwiseLearner
from msd_bench.core.learning.qconfig import QConfig, improved_config
from msd_bench.core.learning.qtrain import greedy_rollouts, train
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams

PLANT = plant_model(PlantParams())
# An ARX-type model (damped double integrator, deviation form): the observer's other state layout.
ARX = StepModel(kernels.KIND_LINEAR, np.array([5.0, 5e-5, 5e-5, -1.975, 0.9802, 0.0, 0.0]), "arx")


def _run_stepwise(cfg: QConfig, seed: int, planning: int = 0, model: StepModel = PLANT) -> StepwiseLearner:
    agent = StepwiseLearner(cfg, seed, planning_steps=planning, observer=model)
    for _ in range(cfg.episodes):
        state = model.initial_state()
        agent.start_episode(0.0)
        while not agent.episode_over:
            agent.learn(model.step(state, agent.act()))
    return agent


ROBUST = improved_config(episodes=4, steps=400, observer="model", obs_gain=0.3, obs_velocity_gain=0.05,
                         train_noise=0.004, train_delay=2)
DAMPED = improved_config(episodes=4, steps=400, observer="model", obs_gain=0.3, obs_velocity_share=0.2,
                         obs_drift_gain=0.002, obs_delay=1, train_noise=0.004, train_delay=2)
"""Every model-observer option away from its default (the delay history, the share, the drift)."""
BIASED = improved_config(episodes=4, steps=400, observer="model", obs_gain=0.1, obs_velocity_share=0.5,
                         obs_bias_gain=20.0, obs_delay=1, train_noise=0.004, train_delay=2)
"""The force-bias state on top of the delay history (its slot sits behind it) and training noise."""
ALPHA_BETA = improved_config(episodes=4, steps=400, observer="alpha-beta", obs_gain=0.3,
                             obs_velocity_gain=0.05, train_noise=0.004)


@pytest.mark.parametrize("cfg", [QConfig(episodes=3, steps=400), improved_config(episodes=3, steps=400),
                                 ROBUST, DAMPED, BIASED, ALPHA_BETA])
@pytest.mark.parametrize("model", [PLANT, ARX], ids=["plant", "arx"])
def test_stepwise_equals_compiled_training(cfg: QConfig, model: StepModel) -> None:
    batch = train(model, cfg, [11])
    agent = _run_stepwise(cfg, 11, model=model)
    assert np.array_equal(agent.q, batch.q[0])
    assert np.array_equal(agent.snapshots[1], batch.snapshots[0, 0])
    assert agent.returns == pytest.approx(list(batch.returns[0]), abs=0)


def test_stepwise_with_planning_equals_dyna_q() -> None:
    cfg = QConfig(episodes=2, steps=300)
    dyna = train_dyna(PLANT, DynaConfig(cfg, planning_steps=7), [5])
    agent = _run_stepwise(cfg, 5, planning=7)
    assert np.array_equal(agent.q, dyna.q[0])
    assert agent.real_steps == int(dyna.real_steps[0]) == 600


@pytest.mark.parametrize("cfg", [improved_config(episodes=5, steps=500), replace(ROBUST, episodes=5),
                                 replace(DAMPED, episodes=5), replace(BIASED, episodes=5),
                                 replace(ALPHA_BETA, episodes=5)])
@pytest.mark.parametrize("model", [PLANT, ARX], ids=["plant", "arx"])
def test_greedy_policy_equals_greedy_rollouts(cfg: QConfig, model: StepModel) -> None:
    q = train(model, cfg, [3]).q
    x_ref, u_ref = greedy_rollouts(model, q, cfg, 1.0, 400)
    policy = GreedyPolicy(cfg, q[0], 1.0, observer=model)
    state, x = model.initial_state(), 0.0
    for k in range(400):
        u = policy.force(x)
        assert (x, u) == (x_ref[0, k], u_ref[0, k])
        x = model.step(state, u)


def test_misuse_is_reported() -> None:
    agent = StepwiseLearner(replace(QConfig(), steps=1), 0)
    with pytest.raises(InvalidInputError, match="start_episode"):
        agent.act()
    agent.start_episode()
    with pytest.raises(InvalidInputError, match="preceding act"):
        agent.learn(0.1)
    with pytest.raises(InvalidInputError, match="shape"):
        GreedyPolicy(QConfig(), np.zeros((3, 5)), 1.0)
