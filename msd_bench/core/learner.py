"""The Q-learning agent one step at a time, for models that live elsewhere (ROS topics).

:func:`msd_bench.core.qtrain.train` runs whole episodes inside one compiled
call, stepping the model itself. When the model is a ROS node (a surrogate in
lock-step, or the plant), the agent must instead *act*, wait for the next
position, then *learn*. :class:`StepwiseLearner` exposes exactly that, built
from the same compiled pieces (:func:`qlearning.choose`, ``encode``,
``reward``, ``td_update``, ``draw_target``) called in the same order with the
same random stream, so for the same seed and the same positions it produces a
bit-identical Q-table — a test checks it against :func:`qtrain.train`. With
``planning_steps > 0`` it is the Dyna-Q agent of :mod:`msd_bench.core.dyna`
(its real interactions then go wherever the caller sends the force).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from msd_bench.core import qlearning, rng
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.qconfig import HP_EPS, N_ACTIONS, QConfig, encoding

FloatArray = NDArray[np.float64]


class StepwiseLearner:
    """One agent: ``start_episode`` → (``act`` → model step → ``learn``) × steps."""

    def __init__(self, cfg: QConfig, seed: int, planning_steps: int = 0) -> None:
        if planning_steps < 0:
            raise InvalidInputError(f"planning_steps must be >= 0, got {planning_steps}")
        self.cfg = cfg
        self.planning_steps = int(planning_steps)
        self.real_steps = 0
        self._enc = encoding(cfg)
        n_pairs = self._enc.n_states * N_ACTIONS
        self._model_r = np.zeros(n_pairs)
        self._model_s = np.zeros(n_pairs, dtype=np.int64)
        self._visited = np.zeros(n_pairs, dtype=np.int64)
        self._seen = np.zeros(n_pairs, dtype=bool)
        self._n_visited = 0
        self._stream = rng.seed_states([seed])
        self.q = np.zeros((self._enc.n_states, N_ACTIONS))
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
        e = self._enc
        self._target = float(qlearning.draw_target(e.hp, self._stream, 0))
        self._x = float(x0)
        self._err = abs(self._x - self._target)
        self._s = self._encode(self._x - self._target, 0.0)
        self._total = 0.0
        self._steps_left = self.cfg.steps
        return self._target

    def act(self) -> float:
        """ε-greedy force for the current state (N); call :meth:`learn` with the next position."""
        if self._steps_left <= 0:
            raise InvalidInputError("episode is over: call start_episode first")
        self._a = int(qlearning.choose(self.q, self._s, self._enc.hp[HP_EPS], self._stream, 0))
        return float(self._enc.actions[self._a])

    def learn(self, x_new: float) -> None:
        """Reward and temporal-difference update for the transition to ``x_new``."""
        if self._a < 0:
            raise InvalidInputError("learn() needs a preceding act()")
        if not np.isfinite(x_new):
            raise InvalidInputError(f"position must be finite, got {x_new}")
        e_new = x_new - self._target
        s2 = self._encode(e_new, x_new - self._x)
        r = float(qlearning.reward(self._enc.hp, abs(e_new), self._err))
        qlearning.td_update(self.q, self._s, self._a, r, s2, self._enc.hp, self._enc.phi)
        if self.planning_steps:
            self._plan(r, s2)
        self.real_steps += 1
        self._total += r
        self._x, self._err, self._s, self._a = x_new, abs(e_new), s2, -1
        self._steps_left -= 1
        if self._steps_left == 0:
            self._end_episode()

    def _plan(self, r: float, s2: int) -> None:
        """Dyna-Q: remember (r, s') of this pair, then replay remembered pairs."""
        j = self._s * N_ACTIONS + self._a
        if not self._seen[j]:
            self._seen[j] = True
            self._visited[self._n_visited] = j
            self._n_visited += 1
        self._model_r[j] = r
        self._model_s[j] = s2
        qlearning.plan(self.q, self.planning_steps, self._visited, self._n_visited, self._model_r,
                  self._model_s, self._enc.hp, self._enc.phi, self._stream, 0)

    def _end_episode(self) -> None:
        self.returns.append(self._total)
        if len(self.returns) in self._snap_at:
            self.snapshots[len(self.returns)] = self.q.copy()

    def _encode(self, e: float, dx: float) -> int:
        enc = self._enc
        return int(qlearning.encode(enc.mode, enc.n_states, enc.hp, enc.err_edges, enc.ref_edges,
                                    e, dx, self._target))


class GreedyPolicy:
    """A trained table held fixed (paper §5): deterministic greedy force per position."""

    def __init__(self, cfg: QConfig, q: FloatArray, target: float) -> None:
        self._enc = encoding(cfg)
        self.q = np.ascontiguousarray(q, dtype=np.float64)
        if self.q.shape != (self._enc.n_states, N_ACTIONS):
            raise InvalidInputError(
                f"Q-table shape {self.q.shape} does not fit state {cfg.state!r} "
                f"({self._enc.n_states} x {N_ACTIONS})")
        self.target = float(target)
        self._x: float | None = None

    def force(self, x: float) -> float:
        """Greedy force for position ``x`` (the direction term uses the previous call's x)."""
        enc = self._enc
        dx = 0.0 if self._x is None else x - self._x
        self._x = x
        s = qlearning.encode(enc.mode, enc.n_states, enc.hp, enc.err_edges, enc.ref_edges,
                             x - self.target, dx, self.target)
        return float(enc.actions[qlearning.greedy(self.q, s)])
