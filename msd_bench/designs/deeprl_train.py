"""Train DQN or PPO (Stable-Baselines3) through ``MsdBench-v0`` on a surrogate or the plant.

Model-based when the environment steps a surrogate (zero real samples);
model-free when it steps the plant (every environment step a real sample).
One process, one thread (``torch.set_num_threads(1)``): the machine is shared
and the result must not depend on a thread count. The returned weights are
plain numpy (:class:`msd_bench.core.deeprl.mlp.Net`); SB3 and torch are
imported here only.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from msd_bench.core.deeprl.hyper import PAPER_STEPS, Hyper
from msd_bench.core.deeprl.mlp import ACTIVATIONS, DY_SCALE, FORCE_SCALE, POS_SCALE, Net, from_arrays
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.model import StepModel

EPISODE_STEPS = 3000
"""The paper's episode: 3,000 samples of 10 ms (``MsdBench-v0``'s default)."""
FloatArray = NDArray[np.float64]


class Features(gymnasium.ObservationWrapper[FloatArray, Any, FloatArray]):
    """The network's input as the environment's observation: :func:`mlp.features`, vectorised."""

    def __init__(self, env: gymnasium.Env[FloatArray, Any]) -> None:
        super().__init__(env)
        box = env.observation_space
        assert isinstance(box, spaces.Box)
        yb, xm, f = float(box.high[0]), float(box.high[2]), float(box.high[3])
        hi = np.array([(yb + xm) / POS_SCALE, 2 * yb / DY_SCALE, xm / POS_SCALE, f / FORCE_SCALE])
        self.observation_space = spaces.Box(-hi, hi, dtype=np.float64)

    def observation(self, observation: FloatArray) -> FloatArray:
        y, dy, target, u = (float(v) for v in observation)
        return np.array([(y - target) / POS_SCALE, dy / DY_SCALE, target / POS_SCALE, u / FORCE_SCALE])


class BudgetSpent(Exception):
    """SB3 asked for a step beyond the budget: training ends with the network it has."""


class Budget(gymnasium.Wrapper[FloatArray, Any, FloatArray, Any]):
    """At most ``limit`` environment steps, exactly as many as the budget states.

    Why: SB3 collects whole rollouts (PPO 2,048 steps, DQN ``train_freq``), so
    ``learn(total_timesteps=n)`` takes up to a rollout more than ``n`` steps, and
    on the plant every one is a real sample. Past the budget a step raises
    :class:`BudgetSpent` (caught by :func:`train_on`), and a reset returns the last
    observation without touching the environment (SB3 resets after the last
    step of an episode; on the plant node that reset would be a real exchange
    nobody answers).
    """

    def __init__(self, env: gymnasium.Env[FloatArray, Any], limit: int) -> None:
        super().__init__(env)
        self.limit = limit
        self.taken = 0
        self._last: FloatArray | None = None

    def reset(self, **kwargs: Any) -> tuple[FloatArray, dict[str, Any]]:
        if self.taken >= self.limit and self._last is not None:
            return self._last, {}
        obs, info = self.env.reset(**kwargs)
        self._last = obs
        return obs, info

    def step(self, action: Any) -> tuple[FloatArray, float, bool, bool, dict[str, Any]]:
        if self.taken >= self.limit:
            raise BudgetSpent
        obs, r, term, trunc, info = self.env.step(action)
        self.taken += 1
        self._last = obs
        return obs, float(r), term, trunc, info


def wrap(env: gymnasium.Env[FloatArray, Any]) -> gymnasium.Env[FloatArray, Any]:
    """An ``MsdBench-v0`` environment as the network sees it: the paper's episode length, the features.

    Not reset here: SB3 seeds it on its first reset (``seed=`` of the algorithm), and an environment
    over the plant node must not be stepped before training starts.
    """
    from msd_bench.gym.env import MsdBenchEnv

    assert isinstance(env, MsdBenchEnv)
    return Features(gymnasium.wrappers.TimeLimit(env, env.episode_steps))


def make_env(model: StepModel, seed: int) -> gymnasium.Env[FloatArray, Any]:
    """``MsdBench-v0`` on ``model`` (the plant or a surrogate), seeded, its input the features."""
    from msd_bench.gym.env import MsdBenchEnv

    env = MsdBenchEnv(model)
    env.reset(seed=seed)
    return Features(gymnasium.wrappers.TimeLimit(env, env.episode_steps))


@dataclass(frozen=True)
class TrainResult:
    """One seed's trained network and what produced it."""

    net: Net
    """The greedy policy as a stack of one."""
    hyper: Hyper
    seed: int
    steps: int
    """Environment steps trained: the budget, exactly (:class:`Budget`)."""
    sb3_version: str
    torch_version: str


def _sb3() -> Any:
    """The SB3 module, or one line saying how to install it (training only; running needs neither)."""
    try:
        import stable_baselines3
    except ImportError:
        raise ConfigError("deep-RL training needs stable-baselines3==2.9.0: "
                          "pip install -e '.[deeprl]'") from None
    return stable_baselines3


def build(model: StepModel, hyper: Hyper, seed: int) -> Any:
    """The untrained SB3 algorithm on ``model``'s environment (single-threaded, CPU)."""
    return build_on(make_env(model, seed), hyper, seed)


def build_on(env: gymnasium.Env[FloatArray, Any], hyper: Hyper, seed: int) -> Any:
    """The untrained SB3 algorithm on ``env`` (single-threaded, CPU, seeded)."""
    import torch

    sb3 = _sb3()
    DQN, PPO = sb3.DQN, sb3.PPO

    torch.set_num_threads(1)
    common: dict[str, Any] = {"learning_rate": hyper.learning_rate, "gamma": hyper.gamma, "seed": seed,
                              "device": "cpu", "verbose": 0}
    if hyper.algo == "dqn":
        return DQN("MlpPolicy", env, policy_kwargs={"net_arch": list(hyper.hidden)},
                   exploration_fraction=hyper.explore, exploration_final_eps=hyper.explore_final,
                   **common, **hyper.extra)
    return PPO("MlpPolicy", env, ent_coef=hyper.explore,
               policy_kwargs={"net_arch": {"pi": list(hyper.hidden), "vf": list(hyper.hidden)}},
               **common, **hyper.extra)


def train(model: StepModel, hyper: Hyper, seed: int, steps: int = PAPER_STEPS,
          episode_steps: int = EPISODE_STEPS) -> TrainResult:
    """Train one seed for ``steps`` environment steps on ``model``, in episodes of ``episode_steps``
    (the paper's 3,000; a run's ``--steps``), and return its greedy network."""
    from msd_bench.gym.env import MsdBenchEnv

    return train_on(MsdBenchEnv(model, episode_steps=episode_steps), hyper, seed, steps)


def train_on(env: gymnasium.Env[FloatArray, Any], hyper: Hyper, seed: int,
             steps: int = PAPER_STEPS) -> TrainResult:
    """Train one seed on the ``MsdBench-v0`` environment ``env`` for exactly ``steps`` steps
    (:class:`Budget`); the same network whatever ``env`` steps, if it answers the same."""
    if not (isinstance(steps, int) and steps >= 1):
        raise ConfigError(f"steps must be an int >= 1, got {steps!r}")
    import torch

    budget = Budget(wrap(env), steps)
    algo = build_on(budget, hyper, seed)
    # SB3 may want the rest of a rollout past the budget: the budget ends it, the last update stands
    with contextlib.suppress(BudgetSpent):
        algo.learn(total_timesteps=steps)
    return TrainResult(extract(algo, hyper), hyper, int(seed), budget.taken, _sb3().__version__,
                       torch.__version__)


def extract(algo: Any, hyper: Hyper) -> Net:
    """The greedy network's weights out of a trained SB3 DQN (Q-network) or PPO (actor)."""
    import torch

    if hyper.algo == "dqn":
        layers = [m for m in algo.q_net.q_net if isinstance(m, torch.nn.Linear)]
    else:
        pol = algo.policy
        layers = [m for m in pol.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
        layers.append(pol.action_net)
    if len(layers) != 3:
        raise ConfigError(f"expected two hidden layers and a head, found {len(layers)} linear layers")
    arrays: list[FloatArray] = []
    for lin in layers:
        arrays.append(lin.weight.detach().cpu().numpy().astype(np.float64)[None])
        arrays.append(lin.bias.detach().cpu().numpy().astype(np.float64)[None])
    return from_arrays(arrays, ACTIVATIONS[hyper.activation])
