"""The compiled batch rollout, the stepwise controller and the environment agree bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.deeprl import mlp
from msd_bench.core.deeprl.rollout import NetworkController, measure
from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.evaluation.closed_loop import quantise
from msd_bench.core.evaluation.robustness import evaluate_policy, policy_rollouts, sensor_noise
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.core.physics.plant import preset
from msd_bench.designs.deeprl import nets_policy
from msd_bench.gym.env import MsdBenchEnv
from tests.deeprl.conftest import random_net

FORCES = QConfig().actions()
PLANT = preset("default")
SCENARIOS = ["nominal", "setpoint=-1.5", "noise=0.005", "quant=0.01,noise=0.002", "delay=2",
             "lag=0.02,delay=1", "disturbance=2@5", "friction=0.5", "mass=1.2,damping=0.7"]


@pytest.mark.parametrize("sid", SCENARIOS)
@pytest.mark.parametrize("activation", [mlp.RELU, mlp.TANH])
def test_compiled_rollout_equals_the_stepwise_controller_bit_for_bit(sid: str, activation: int) -> None:
    sc = parse(sid)
    seeds = [3, 4, 5]
    net = random_net(7, n=3, activation=activation)
    xs, us = policy_rollouts(nets_policy("plant+dqn", net, seeds), PLANT, sc, seeds, 800)
    noise = sensor_noise(sc, seeds, 800)
    assert len({float(u) for u in us.ravel()}) > 1  # the policies do act, so a mismatch would show
    for j in range(3):
        ctl = NetworkController(net, FORCES, j)
        ctl.reset(sc.setpoint)
        got = np.array([ctl.act(measure(xs[j, k], noise[j, k], sc.quant, np.inf)) for k in range(800)])
        assert np.array_equal(got, us[j])


def test_nominal_rollout_is_the_environment_driven_by_the_forward_pass() -> None:
    net = random_net(11, activation=mlp.TANH)
    xs, us = policy_rollouts(nets_policy("plant+ppo", net, [0]), PLANT, parse("nominal"), [0], 600)
    env = MsdBenchEnv(target=1.0, episode_steps=600)
    obs, info = env.reset(seed=0)
    for k in range(600):
        assert info["x"] == xs[0, k]
        a = mlp.greedy(net, 0, *obs)
        assert FORCES[a] == us[0, k]
        obs, _, _, _, info = env.step(a)
    env.close()


def test_measure_is_noise_then_quantisation_then_the_adc_clip() -> None:
    assert measure(1.234, 0.01, 0.1, 3.0) == quantise(1.244, 0.1)
    assert measure(2.5, 1.0, 0.0, 2.6) == 2.6
    assert measure(-2.5, -1.0, 0.0, 2.6) == -2.6


def test_one_policy_stack_scores_like_the_suite_expects() -> None:
    policy = nets_policy("greybox+dqn", random_net(1, n=2), [0, 1])
    cells = evaluate_policy(policy, PLANT, [0, 1], [parse("nominal"), parse("noise=0.001")], steps=600,
                            window=100)
    assert set(cells) == {"nominal", "noise=0.001"}
    assert cells["nominal"]["n"] == 2 and len(cells["nominal"]["sse"]) == 2
    assert len(cells["noise=0.001"]["risks"]) == 2  # one evaluator: risk recorded per run, as every kind


def test_a_controller_refuses_what_it_cannot_run() -> None:
    net = random_net(0)
    with pytest.raises(InvalidInputError, match="policy index 1"):
        NetworkController(net, FORCES, 1)
    with pytest.raises(InvalidInputError, match="one force per network output"):
        NetworkController(net, FORCES[:4])
    ctl = NetworkController(net, FORCES)
    with pytest.raises(InvalidInputError, match="target must be finite"):
        ctl.reset(float("nan"))
    ctl.reset(1.0)
    with pytest.raises(InvalidInputError, match="measurement must be finite"):
        ctl.act(float("inf"))


def test_a_policy_needs_one_seed_per_network_and_a_deep_rl_kind() -> None:
    with pytest.raises(InvalidInputError, match="one learning seed per policy"):
        nets_policy("plant+dqn", random_net(0, n=2), [0])
    with pytest.raises(ConfigError, match="not a deep-RL kind"):
        nets_policy("greybox+robust", random_net(0), [0])
    with pytest.raises(ConfigError, match="unknown agent kind"):
        nets_policy("greybox+dqm", random_net(0), [0])


def test_nets_of_other_shapes_do_not_stack() -> None:
    with pytest.raises(InvalidInputError, match="different sizes"):
        mlp.stack([random_net(0), random_net(1, hidden=(8, 8))])
    with pytest.raises(InvalidInputError, match="do not chain"):
        mlp.from_arrays([np.zeros((1, 3, 5)), np.zeros((1, 3)), np.zeros((1, 3, 3)), np.zeros((1, 3)),
                         np.zeros((1, 5, 3)), np.zeros((1, 5))], mlp.RELU)
    bad = list(random_net(0)[:6])
    bad[2] = bad[2].copy()
    bad[2][0, 0, 0] = np.nan
    with pytest.raises(InvalidInputError, match="finite"):
        mlp.from_arrays(bad, mlp.RELU)
