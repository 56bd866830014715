"""MsdBench-v0 with Stable-Baselines3, the most common client: its checker and its documented loop.

SB3's ``model.predict(obs, deterministic=True)`` returns a 0-d integer array for one observation;
Gymnasium's ``Discrete.contains`` accepts it, so the environment must too (it once refused it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import pytest

import msd_bench.gym  # noqa: F401  (registers MsdBench-v0)
from msd_bench.core.errors import InvalidInputError

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"


def _env(**kwargs: Any) -> gymnasium.Env[Any, Any]:
    return gymnasium.make("MsdBench-v0", episode_steps=60, **kwargs)


@pytest.mark.parametrize("action", [4, np.int64(4), np.int8(4), np.array(4), np.array(4, dtype=np.int32)])
def test_every_action_discrete_accepts_is_an_action(action: Any) -> None:
    env = _env()
    env.reset(seed=0)
    assert env.action_space.contains(action)
    assert env.step(action)[4]["force"] == 10.0
    env.close()


@pytest.mark.parametrize("action", [5, -1, 4.0, np.array([4]), np.array(4.0), "4", None])
def test_what_discrete_refuses_is_a_one_line_error(action: Any) -> None:
    env = _env()
    env.reset(seed=0)
    assert not env.action_space.contains(action)
    with pytest.raises(InvalidInputError, match=r"discrete action must be an integer in 0\.\.4"):
        env.unwrapped.step(action)
    env.close()


@pytest.mark.parametrize("action", ["abc", None, [1.0, 2.0]])
def test_a_continuous_action_that_is_no_number_is_a_one_line_error(action: Any) -> None:
    env = _env(continuous=True)
    env.reset(seed=0)
    with pytest.raises(InvalidInputError, match="one finite force"):
        env.unwrapped.step(action)
    env.close()


@pytest.mark.parametrize("model", [None, "plm", "nlarx-paper"], ids=["plant", "plm", "nlarx"])
def test_sb3_check_env_and_documented_predict_loop(model: str | None) -> None:
    from stable_baselines3 import DQN
    from stable_baselines3.common.env_checker import check_env

    kwargs = {} if model is None else {"model": str(PINNED / f"{model}.json")}
    check_env(_env(**kwargs).unwrapped, warn=True)
    env = _env(**kwargs)
    agent = DQN("MlpPolicy", env, learning_starts=20, train_freq=4, buffer_size=500, seed=0,
                device="cpu")
    agent.learn(total_timesteps=80)
    obs, _ = env.reset(seed=1)
    forces = set()
    for _ in range(120):  # the loop of SB3's documentation, across an episode end
        action, _ = agent.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        assert np.isfinite(reward) and env.observation_space.contains(obs)
        forces.add(info["force"])
        if terminated or truncated:
            obs, _ = env.reset()
    assert forces and forces <= {-10.0, -5.0, 0.0, 5.0, 10.0}  # the five forces, nothing else
    env.close()
