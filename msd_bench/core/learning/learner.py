"""The Q-learning agent one step at a time, for models that live elsewhere (ROS topics).

:func:`msd_bench.core.learning.qtrain.train` runs whole episodes inside one compiled
call, stepping the model itself. When the model is a ROS node (a surrogate in
lock-step, or the plant), the agent must instead *act*, wait for the next
position, then *learn*. :class:`StepwiseLearner` exposes exactly that, built
from the same compiled pieces (:func:`qlearning.choose`, ``encode``,
``reward``, ``td_update``, ``draw_target``) called in the same order with the
same random stream, so for the same seed and the same positions it produces a
bit-identical Q-table — a test checks it against :func:`qtrain.train`. With
``planning_steps > 0`` it is the Dyna-Q agent of :mod:`msd_bench.core.learning.dyna`
(its real interactions then go wherever the caller sends the force).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.learning import q_kernels as qlearning
from msd_bench.core.learning import rng
from msd_bench.core.learning.qconfig import N_ACTIONS, QConfig, packed
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams

FloatArray = NDArray[np.float64]


class StepwiseLearner:
    """One agent: ``start_episode`` → (``act`` → model step → ``learn``) × steps."""

    def __init__(self, cfg: QConfig, seed: int, planning_steps: int = 0,
                 observer: StepModel | None = None) -> None:
        if planning_steps < 0:
            raise InvalidInputError(f"planning_steps must be >= 0, got {planning_steps}")
        self.cfg = cfg
        self.planning_steps = int(planning_steps)
        self.real_steps = 0
        self._lr = packed(cfg)
        n_states = self._lr.enc.n_states
        self._memory = qlearning.new_memory(n_states * N_ACTIONS if planning_steps else 0)
        self._stream = rng.seed_states([seed])
        self.q = np.zeros((n_states, N_ACTIONS))
        self.returns: list[float] = []
        self.snapshots: dict[int, FloatArray] = {}
        self._snap_at = set(cfg.snapshots())
        self._target = 0.0
        self._x = 0.0
        self._err = 0.0
        self._s = 0
        self._a = -1
        self._total = 0.0
        self._steps_left = 0
        # Observed learners (our robust agent): per-episode noise and delay, the observer's estimate.
        self._sigma = 0.0
        self._queue = np.zeros(self._lr.train_delay + 1)
        self._delay = 0
        self._k = 0
        self._xh = 0.0
        self._dh = 0.0
        self._u = 0.0
        self._ost = qlearning.observer_state(self._lr)
        self._obs = _observer_kernel(cfg, observer)

    @property
    def target(self) -> float:
        """Set-point of the current episode, m."""
        return self._target

    @property
    def episode_over(self) -> bool:
        """True once the episode's ``steps`` updates are done."""
        return self._steps_left == 0

    def start_episode(self, x0: float = 0.0) -> float:
        """Draw the episode's target from the agent's stream; the model must be at rest at ``x0``."""
        self._target = float(qlearning.draw_target(self._lr, self._stream, 0))
        self._x = float(x0)
        self._err = abs(self._x - self._target)
        if self._lr.observed:
            self._start_observed()
        else:
            self._s = self._encode(self._x - self._target, 0.0)
        self._total = 0.0
        self._steps_left = self.cfg.steps
        return self._target

    def act(self) -> float:
        """ε-greedy force for the current state (N); call :meth:`learn` with the next position."""
        if self._steps_left <= 0:
            raise InvalidInputError("episode is over: call start_episode first")
        self._a = int(qlearning.choose(self.q, self._s, self._lr.epsilon, self._stream, 0))
        u = float(qlearning.commanded(self._lr, self._ost, self._lr.actions[self._a], self._target))
        self._u = u  # what the observer believes acts (the agent cannot know the delay)
        if self._lr.observed and self._delay > 0:  # the actuator acts `delay` samples late
            self._queue[self._k % (self._delay + 1)] = u
            u = float(self._queue[(self._k + 1) % (self._delay + 1)])
        self._k += 1
        return u

    def learn(self, x_new: float) -> None:
        """Reward and temporal-difference update for the transition to ``x_new``."""
        if self._a < 0:
            raise InvalidInputError("learn() needs a preceding act()")
        if not np.isfinite(x_new):
            raise InvalidInputError(f"position must be finite, got {x_new}")
        e_new = x_new - self._target
        s2 = self._observed_state(x_new) if self._lr.observed else self._encode(e_new, x_new - self._x)
        r = float(qlearning.reward(self._lr, abs(e_new), self._err))
        qlearning.td_update(self.q, self._s, self._a, r, s2, self._lr)
        if self.planning_steps:
            qlearning.remember(self._memory, self._s * N_ACTIONS + self._a, r, s2)
            qlearning.plan(self.q, self.planning_steps, self._memory, self._lr, self._stream, 0)
        self.real_steps += 1
        self._total += r
        self._x, self._err, self._s, self._a = x_new, abs(e_new), s2, -1
        self._steps_left -= 1
        if self._steps_left == 0:
            self._end_episode()

    def _start_observed(self) -> None:
        """Draw the episode's noise and delay (in :func:`qlearning.learn_observed`'s order) and observe x0."""
        lr, st = self._lr, self._stream
        self._sigma = lr.train_noise * rng.uniform(st, 0) if lr.train_noise > 0.0 else 0.0
        self._delay = int(rng.below(st, 0, lr.train_delay + 1)) if lr.train_delay > 0 else 0
        self._queue[:] = 0.0
        self._k = 0
        self._xh, self._dh = qlearning.observe(lr, self._obs, self._ost, 0.0, self._measure(self._x), 0.0,
                                               0.0, True)
        self._s = self._encode(self._xh - self._target, self._dh)

    def _measure(self, x: float) -> float:
        return x + self._sigma * float(qlearning.normal(self._stream, 0)) if self._sigma > 0.0 else x

    def _observed_state(self, x_new: float) -> int:
        self._xh, self._dh = qlearning.observe(self._lr, self._obs, self._ost, self._u, self._measure(x_new),
                                               self._xh, self._dh, False)
        return self._encode(self._xh - self._target, self._dh)

    def _end_episode(self) -> None:
        self.returns.append(self._total)
        if len(self.returns) in self._snap_at:
            self.snapshots[len(self.returns)] = self.q.copy()

    def _encode(self, e: float, dx: float) -> int:
        return int(qlearning.encode(self._lr.enc, e, dx, self._target))


def stacked_snapshots(learners: list[StepwiseLearner]) -> tuple[FloatArray, tuple[int, ...]]:
    """The learners' snapshots as one (n_agents, n_snap, S, 5) array and their episode counts, the layout
    :func:`msd_bench.core.learning.qtrain.train` returns (so
    :func:`~msd_bench.core.learning.selection.select_tables` takes either)."""
    episodes = tuple(sorted(learners[0].snapshots))
    return np.stack([np.stack([lr.snapshots[e] for e in episodes]) for lr in learners]), episodes


class GreedyPolicy:
    """A trained table held fixed (paper §5): deterministic greedy force per position."""

    def __init__(self, cfg: QConfig, q: FloatArray, target: float,
                 observer: StepModel | None = None) -> None:
        self._lr = packed(cfg)
        self._obs = _observer_kernel(cfg, observer)
        self._ost = qlearning.observer_state(self._lr)
        self._u = 0.0
        self.q = np.ascontiguousarray(q, dtype=np.float64)
        n_states = self._lr.enc.n_states
        if self.q.shape != (n_states, N_ACTIONS):
            raise InvalidInputError(
                f"Q-table shape {self.q.shape} does not fit state {cfg.state!r} "
                f"({n_states} x {N_ACTIONS})")
        self.target = float(target)
        self._x: float | None = None
        self._dh = 0.0

    def force(self, x: float) -> float:
        """Greedy force for measured position ``x`` (the direction term uses the previous call's x).

        Observed learners (our robust agent) see ``x`` through their observer,
        exactly as :func:`msd_bench.core.evaluation.closed_loop.greedy_under` does.
        """
        if self._lr.observed:
            xh, self._dh = qlearning.observe(self._lr, self._obs, self._ost, self._u, x, self._x or 0.0,
                                             self._dh, self._x is None)
            self._x = xh
            s = qlearning.encode(self._lr.enc, xh - self.target, self._dh, self.target)
        else:
            dx = 0.0 if self._x is None else x - self._x
            self._x = x
            s = qlearning.encode(self._lr.enc, x - self.target, dx, self.target)
        chosen = self._lr.actions[qlearning.greedy(self.q, s)]
        self._u = float(qlearning.commanded(self._lr, self._ost, chosen, self.target))
        return self._u


def _observer_kernel(cfg: QConfig, observer: StepModel | None) -> Kernel:
    """The model a ``model`` observer predicts with; other observers never read it."""
    if observer is None:
        if cfg.observer == "model":
            raise InvalidInputError("a model observer needs the model the agent trains on")
        return plant_model(PlantParams()).kernel
    return observer.kernel
