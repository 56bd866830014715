"""Dyna-Q baseline (paper §3.4.2): Q-learning on the true plant plus model-based planning.

Each real step on the model passed in (the *true plant* in the paper's
baseline) is followed by ``planning_steps`` simulated updates replayed from a
tabular deterministic model that remembers the last observed ``(r, s')`` of
every visited ``(s, a)``; planning draws pairs uniformly among those visited
so far (Sutton & Barto, Tabular Dyna-Q). State, reward, exploration, episodes
and the update rule (shaping penalty included, in real and planned updates
alike) are those of the paper agent, so the two differ only by planning.

Why compiled: 300 × 3,000 real steps with 100 planning updates each is 90 M
updates; plain Python manages ~2,000 real steps/s (7.5 min per agent). The
counts of real interactions and planning updates are returned because the
paper's point is that Dyna-Q spends real plant interactions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.learning import rng
from msd_bench.core.learning.qconfig import QConfig, packed
from msd_bench.core.learning.qtrain import LearnedTables, budget, run_batch
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class DynaConfig:
    """Dyna-Q = the paper's learner plus planning."""

    learner: QConfig = field(default_factory=QConfig)
    """State, reward, α, γ, ε, episodes and steps (reduce ``episodes`` for a cheaper run)."""
    planning_steps: int = 100
    """Simulated updates after each real step (paper: 100); 0 makes it plain Q-learning."""

    def __post_init__(self) -> None:
        if self.planning_steps < 0:
            raise ConfigError(f"planning_steps must be >= 0, got {self.planning_steps}")


@dataclass(frozen=True)
class DynaResult(LearnedTables):
    """A batch of Dyna-Q runs, with what they cost on the plant."""

    real_steps: IntArray
    """Interactions with the model passed in (the plant), per agent."""
    planning_updates: IntArray
    """Simulated Q-updates from the learned table model, per agent."""
    config: DynaConfig
    """The configuration trained with."""


def train_dyna(plant: StepModel, cfg: DynaConfig, seeds: Sequence[int]) -> DynaResult:
    """Run one Dyna-Q agent per seed on ``plant`` (compiled; the batch spread over the cores)."""
    if len(seeds) == 0:
        raise InvalidInputError("need at least one seed")
    stream = rng.seed_states(seeds)
    qc = cfg.learner
    q, snaps, returns, counts = run_batch(plant.kernel, packed(qc), budget(qc, cfg.planning_steps),
                                         stream)
    return DynaResult(q, snaps, qc.snapshots(), returns, tuple(int(s) for s in seeds),
                      counts[:, 0].copy(), counts[:, 1].copy(), cfg)
