"""The numpy/numba forward pass picks SB3's ``predict(deterministic=True)`` action (>= 99.9 %).

Whole episodes of the environment driven by the extracted network; SB3's
``predict`` is asked on every observation of them (one batched call). Both algorithms, briefly trained and
then their weights scattered (so the greedy action changes often and a wrong
layer order, activation or head would show).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import torch

from msd_bench.core.deeprl import mlp
from msd_bench.core.deeprl.hyper import Hyper
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import preset
from msd_bench.designs.deeprl_train import build, extract

HYPERS = {
    "dqn": Hyper("dqn", 1e-3, hidden=(32, 32), extra={"learning_starts": 200, "buffer_size": 5000}),
    "ppo": Hyper("ppo", 3e-4, hidden=(32, 32), extra={"n_steps": 256, "batch_size": 64, "n_epochs": 2}),
}


def _trained(algo: str) -> Any:
    model = build(plant_model(preset("default")), HYPERS[algo], seed=5)
    model.learn(total_timesteps=512)
    with torch.no_grad():  # scatter the weights: a varied greedy action over the episode
        gen = torch.Generator().manual_seed(1)
        for p in model.policy.parameters():
            p.add_(torch.randn(p.shape, generator=gen) * 0.5)
    return model


@pytest.mark.parametrize("algo", ["dqn", "ppo"])
def test_forward_pass_picks_sb3s_greedy_action_over_whole_episodes(algo: str) -> None:
    model = _trained(algo)
    net = extract(model, HYPERS[algo])
    env = model.get_env().envs[0]  # the Features-wrapped MsdBench-v0 SB3 trained on
    raw = env.unwrapped
    feats, mine = [], []
    for episode in range(2):  # driven by the forward pass; SB3 is asked on every observation below
        obs, _ = env.reset(seed=100 + episode, options={"target": (1.0, -1.5)[episode]})
        done = False
        while not done:
            feats.append(obs)
            mine.append(mlp.greedy(net, 0, *raw._observation()))
            obs, _, terminated, truncated, _ = env.step(mine[-1])
            done = terminated or truncated
    sb3, _ = model.predict(np.array(feats), deterministic=True)
    assert len(mine) == 2 * raw.episode_steps
    assert len(set(mine)) >= 2
    assert np.mean(np.asarray(sb3) == np.array(mine)) >= 0.999


def test_extracted_weights_are_the_torch_modules() -> None:
    model = _trained("dqn")
    net = extract(model, HYPERS["dqn"])
    first = model.q_net.q_net[0]
    assert np.array_equal(net.w1[0], first.weight.detach().numpy().astype(np.float64))
    assert net.activation == mlp.RELU
    assert extract(_trained("ppo"), HYPERS["ppo"]).activation == mlp.TANH
