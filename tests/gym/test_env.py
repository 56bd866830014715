"""MsdBench-v0 in-process: Gymnasium's checker, the paper's spaces and reward, truncation, vectors."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import msd_bench.gym  # noqa: F401  (registers MsdBench-v0)
from msd_bench.core.errors import ConfigError, InvalidInputError, MsdBenchError
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import preset
from msd_bench.io.storage.artifacts import load_model

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"

NORMALISE_HINT = "we recommend using a symmetric and normalized space"
"""check_env's advice for Box actions: the bench's action is a force in N on purpose."""


def checked(env: gymnasium.Env[Any, Any], allowed: tuple[str, ...] = ()) -> None:
    """Run Gymnasium's checker on the raw env; fail on any warning it raises but ``allowed`` ones."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    unexpected = [str(w.message) for w in caught if not any(a in str(w.message) for a in allowed)]
    assert unexpected == []


def test_registered_and_checked_in_process() -> None:
    env = gymnasium.make("MsdBench-v0")
    assert isinstance(env.action_space, gymnasium.spaces.Discrete) and env.action_space.n == 5
    assert env.observation_space.shape == (4,)
    checked(env)
    env.close()


def test_continuous_option_with_noise_is_checked() -> None:
    env = gymnasium.make("MsdBench-v0", continuous=True, sensor_noise=0.002, sensor_quant=1e-4)
    space = env.action_space
    assert isinstance(space, gymnasium.spaces.Box)
    assert (float(space.low[0]), float(space.high[0])) == (-10.0, 10.0)
    checked(env, allowed=(NORMALISE_HINT,))
    env.close()


@pytest.mark.parametrize("name", ["plm", "glm", "nlarx-paper"])
def test_model_backend_is_checked(name: str) -> None:
    env = gymnasium.make("MsdBench-v0", model=str(PINNED / f"{name}.json"))
    checked(env)
    env.close()


def test_trajectory_is_the_plant_and_reward_is_eq19() -> None:
    """Positions are the core plant's free run under the chosen forces; rewards are eq. 19."""
    env = gymnasium.make("MsdBench-v0")
    _, info = env.reset(seed=3)
    target = info["target"]
    assert -2.0 <= target <= 2.0
    rng = np.random.default_rng(0)
    actions = rng.integers(0, 5, 400)
    forces = np.array([-10.0, -5.0, 0.0, 5.0, 10.0])[actions]
    cfg = QConfig()
    xs: list[float] = []
    rewards: list[float] = []
    last = 0.0
    for a in actions:
        obs, r, term, trunc, info = env.step(int(a))
        assert not term and not trunc
        assert obs[3] == info["force"] == forces[len(xs)]
        rewards.append(float(r))
        xs.append(info["x"])
        assert obs[0] == info["x"] and obs[2] == target  # ideal sensor: the truth
        assert obs[1] == pytest.approx(info["x"] - last, abs=1e-15)
        last = info["x"]
    expected_x = plant_model(preset("default")).simulate(np.append(forces, 0.0))[1:]
    np.testing.assert_array_equal(xs, expected_x)
    err = np.abs(np.concatenate([[0.0], expected_x]) - target)
    expected_r = cfg.reward_gain * (cfg.g / (1 + err[1:]) - cfg.zeta * np.diff(err) / cfg.e_max)
    np.testing.assert_allclose(rewards, expected_r, rtol=1e-12, atol=1e-12)
    assert np.ptp(xs) > 0.05  # the random forces moved the mass
    env.close()


def test_model_backend_steps_the_artifact() -> None:
    env = gymnasium.make("MsdBench-v0", model=str(PINNED / "plm.json"), target=1.0)
    env.reset(seed=0)
    xs = [env.step(4)[4]["x"] for _ in range(200)]
    expected = load_model(PINNED / "plm.json").simulate(np.full(201, 10.0))[1:]
    np.testing.assert_array_equal(xs, expected)
    env.close()


def test_truncation_at_the_episode_length() -> None:
    env = gymnasium.make("MsdBench-v0")
    env.reset(seed=0)
    flags = [env.step(2)[3] for _ in range(3000)]
    assert flags[-1] is True and not any(flags[:-1])
    with pytest.raises(MsdBenchError, match="call reset"):
        env.step(2)
    short = gymnasium.make("MsdBench-v0", episode_steps=7)
    short.reset(seed=0)
    assert [short.step(0)[3] for _ in range(7)] == [False] * 6 + [True]


def test_targets_fixed_per_env_or_per_episode_and_checked() -> None:
    env = gymnasium.make("MsdBench-v0", target=1.5)
    assert env.reset(seed=1)[0][2] == 1.5
    assert env.reset(options={"target": -0.5})[0][2] == -0.5
    drawn = gymnasium.make("MsdBench-v0")
    targets = {drawn.reset(seed=s)[1]["target"] for s in range(20)}
    assert len(targets) == 20 and all(-2.0 <= t <= 2.0 for t in targets)
    assert drawn.reset(seed=5)[1]["target"] == drawn.reset(seed=5)[1]["target"]
    with pytest.raises(ConfigError, match="within the stroke"):
        gymnasium.make("MsdBench-v0", target=3.0)
    with pytest.raises(ConfigError, match="within the stroke"):
        env.reset(options={"target": float("nan")})


def test_sensor_noise_reaches_the_observation_not_the_reward() -> None:
    env = gymnasium.make("MsdBench-v0", sensor_noise=0.002, target=0.0)
    env.reset(seed=2)
    rows = [env.step(2) for _ in range(500)]  # zero force: the mass stays at rest
    y = np.array([r[0][0] for r in rows])
    assert all(r[4]["x"] == 0.0 for r in rows)
    assert 0.0015 < np.std(y) < 0.0025
    # The reward is paid on the true error: at rest on the target it is g / (1 + 0) = 1 exactly.
    assert all(r[1] == 1.0 for r in rows)


def test_bad_actions_and_arguments_are_one_line_errors() -> None:
    env = gymnasium.make("MsdBench-v0")
    env.reset(seed=0)
    with pytest.raises(InvalidInputError, match=r"integer in 0\.\.4"):
        env.unwrapped.step(5)
    cont = gymnasium.make("MsdBench-v0", continuous=True)
    cont.reset(seed=0)
    with pytest.raises(InvalidInputError, match="finite force"):
        cont.unwrapped.step(np.array([np.nan]))
    assert cont.unwrapped.step(np.array([25.0]))[4]["force"] == 10.0  # clipped to ±F
    with pytest.raises(ConfigError, match="not both"):
        gymnasium.make("MsdBench-v0", model="x.json", ros_namespace="/msd")
    with pytest.raises(MsdBenchError, match="no such artifact"):
        gymnasium.make("MsdBench-v0", model="missing.json")


def test_vector_api() -> None:
    envs = gymnasium.make_vec("MsdBench-v0", num_envs=2, episode_steps=5)
    obs, info = envs.reset(seed=0)
    assert obs.shape == (2, 4) and obs[0, 2] != obs[1, 2]  # each env draws its own set-point
    for k in range(5):
        obs, rew, term, trunc, info = envs.step(np.array([4, 0]))
        assert rew.shape == (2,) and not term.any()
        assert list(trunc) == [k == 4, k == 4]
    assert info["x"][0] > 0 > info["x"][1]  # +F pushed one up, -F the other down
    envs.close()
