"""DQN or PPO trained over a plant-like node's topics: SB3 pulls steps, the agent node pushes them.

Why a thread: SB3's ``learn()`` owns its loop and calls ``env.step``; the agent
node's episode client owns the plant's lock-step exchange and calls a
learner's ``start_episode`` / ``act`` / ``learn`` from its callbacks
(:class:`msd_bench.designs.protocol.StepwiseLearner`). :class:`DeepLearner`
runs ``learn()`` on a thread of its own whose environment is
``MsdBench-v0`` over :class:`Pushed`, a backend that hands every force to the
node's side and waits for the position the node answered. The two sides take
turns through two queues, so the exchange is as deterministic as the node: on
a lock-step plant with the same seed the network is the in-process one
(:func:`msd_bench.designs.deeprl_train.train`) bit for bit.

The budget is the episode client's: it runs ``episodes x steps`` steps per
learner, and :class:`msd_bench.designs.deeprl_train.Budget` stops SB3 at exactly
that many, so the steps the node saw, the steps SB3 took and the real
interactions charged are one number (``real_steps``, checked at
:meth:`DeepStepwise.finish`). No rclpy here: the node side is whatever calls
the learner.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from msd_bench.core.deeprl.hyper import Hyper
from msd_bench.core.errors import MsdBenchError
from msd_bench.designs.deeprl_train import TrainResult

ANSWER_TIMEOUT_S = 600.0
"""Longest wait for SB3's next force (its first one waits for torch and SB3 to load on a busy machine)."""


class DeepStepwiseError(MsdBenchError):
    """Training over the node broke its turn-taking or ended without a network."""


class Pushed:
    """A ``MsdBench-v0`` backend whose answers come from the node's side of a :class:`DeepLearner`."""

    def __init__(self, learner: DeepLearner, dt: float, x_max: float) -> None:
        self.learner = learner
        self.dt = dt
        self.x_max = x_max

    def reset(self) -> float:
        return self.learner.env_wait("reset")

    def step(self, u: float) -> float:
        self.learner.to_node.put(("u", float(u)))
        return self.learner.env_wait("x")

    def close(self) -> None:
        pass


class DeepLearner:
    """One learning seed: SB3 on its own thread, driven by the episode client's calls."""

    def __init__(self, hyper: Hyper, seed: int, budget: int, dt: float, x_max: float,
                 episode_steps: int) -> None:
        self.hyper = hyper
        self.seed = int(seed)
        self.budget = int(budget)
        self.episode_steps = int(episode_steps)
        """SB3's episode length: the episode client's, so both sides reset together."""
        self.dt, self.x_max = float(dt), float(x_max)
        self.to_env: queue.Queue[tuple[str, float]] = queue.Queue()
        self.to_node: queue.Queue[tuple[str, float]] = queue.Queue()
        self.real_steps = 0
        """Positions the node answered and this learner handed to SB3: the real interactions."""
        self.result: TrainResult | None = None
        self.error: MsdBenchError | None = None
        self._thread: threading.Thread | None = None
        self._ended = False

    # the node's side (the episode client's callbacks)
    def start_episode(self, x0: float = 0.0) -> float:
        """The node is at rest at ``x0``: SB3's pending reset returns it."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._work, name=f"sb3-seed-{self.seed}", daemon=True)
            self._thread.start()
        self.to_env.put(("reset", float(x0)))
        return float(x0)

    def act(self) -> float:
        """SB3's next force (0 N once its training ended: the budget's remaining steps stay real)."""
        if self._ended:
            return 0.0
        try:
            kind, value = self.to_node.get(timeout=ANSWER_TIMEOUT_S)
        except queue.Empty:
            raise DeepStepwiseError(f"seed {self.seed}: SB3 sent no force within "
                                    f"{ANSWER_TIMEOUT_S:g} s") from None
        if kind == "u":
            return value
        self._ended = True
        if self.result is None:
            raise DeepStepwiseError(f"training ended without a network: {self.error}" if self.error else
                                    f"seed {self.seed}: training ended without a network (its thread failed)")
        return 0.0

    def learn(self, x_new: float) -> None:
        """The node's answer to the last force."""
        self.real_steps += 1
        if not self._ended:
            self.to_env.put(("x", float(x_new)))

    # SB3's side (its thread)
    def env_wait(self, expect: str) -> float:
        """The node's next hand-over, which must be ``expect`` (a reset, or the answer to a force)."""
        kind, value = self.to_env.get()
        if kind != expect:
            raise DeepStepwiseError(f"seed {self.seed}: SB3 waited for a {expect} and the node sent a {kind}")
        return value

    def _work(self) -> None:
        from msd_bench.designs.deeprl_train import train_on

        try:
            env = _pushed_env(Pushed(self, self.dt, self.x_max), self.episode_steps)
            self.result = train_on(env, self.hyper, self.seed, self.budget)
        except MsdBenchError as exc:  # e.g. SB3 missing: the node's side raises it as one line
            self.error = exc
        finally:
            self.to_node.put(("end", 0.0))

    def join(self, timeout: float = ANSWER_TIMEOUT_S) -> TrainResult:
        """The trained network once SB3's thread ended (it ends by itself once the budget is spent)."""
        if self._thread is None:
            raise DeepStepwiseError(f"seed {self.seed}: never trained (no episode ran)")
        self._thread.join(timeout)
        if self._thread.is_alive() or self.result is None:
            raise DeepStepwiseError(f"seed {self.seed}: training did not end with a network"
                                    + (f": {self.error}" if self.error else ""))
        if self.result.steps != self.real_steps:
            raise DeepStepwiseError(f"seed {self.seed}: SB3 took {self.result.steps} steps but the node "
                                    f"answered {self.real_steps}")
        return self.result


def _pushed_env(backend: Pushed, episode_steps: int) -> Any:
    """``MsdBench-v0`` over ``backend`` (its observation bounds from the backend, as for any other)."""
    from msd_bench.gym.env import MsdBenchEnv

    class _OverNode(MsdBenchEnv):
        def _backend(self, *args: Any, **kwargs: Any) -> Any:
            return backend

    return _OverNode(episode_steps=episode_steps)


@dataclass
class DeepStepwise:
    """The :class:`msd_bench.designs.protocol.Stepwise` of an on-plant deep-RL kind."""

    on_plant: bool
    episodes: int
    steps: int
    learners: Sequence[DeepLearner]
    make_policy: Callable[[list[TrainResult], int], Any]
    """The policy from every seed's result and the real interactions they spent."""

    def finish(self) -> Any:
        results = [lr.join() for lr in self.learners]
        return self.make_policy(results, sum(lr.real_steps for lr in self.learners))
