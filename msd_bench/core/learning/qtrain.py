"""Train Q-learning agents on a plant-like model and run them greedily (paper §4, §5).

The Python face of :mod:`msd_bench.core.learning.q_kernels`: it checks inputs, packs
the config (:func:`qconfig.packed`) and calls one compiled kernel per slice
of the batch of seeds, one slice per core (:func:`run_batch`). Agents in a
batch never share randomness, so the batch result for seed k equals a single
run of seed k bit for bit, however the batch is sliced.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.learning import q_kernels as qlearning
from msd_bench.core.learning import rng
from msd_bench.core.learning.qconfig import N_ACTIONS, Learner, QConfig, packed
from msd_bench.core.learning.selection import select_tables
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class LearnedTables:
    """What any batch of tabular learners produces (Q-learning and Dyna-Q alike)."""

    q: FloatArray
    """The tables the agents keep, shape (n_agents, n_states, 5): the final ones unless selected."""
    snapshots: FloatArray
    """Q-tables after the episodes in ``snapshot_episodes``, shape (n_agents, n_snap, S, 5)."""
    snapshot_episodes: tuple[int, ...]
    """Episode counts (1-based) of the snapshots."""
    returns: FloatArray
    """Sum of (real) rewards per episode, shape (n_agents, episodes)."""
    seeds: tuple[int, ...]
    """Seed of each agent, in batch order."""


@dataclass(frozen=True)
class TrainResult(LearnedTables):
    """A batch of Q-learning runs on a model."""

    config: QConfig
    """The configuration trained with."""
    model_name: str
    """Name of the model trained on (provenance)."""
    kept_episodes: IntArray | None = None
    """With ``config.select_every``: the episode after which each kept table (``q``) was taken
    (:mod:`msd_bench.core.learning.selection`); None when ``q`` is the final table."""


def train(model: StepModel, cfg: QConfig, seeds: Sequence[int]) -> TrainResult:
    """Train one agent per seed on ``model`` (compiled; the batch spread over the cores).

    ``q`` is each agent's final table, or with ``cfg.select_every`` the table it keeps after
    rehearsing its late snapshots on ``model`` (:func:`selection.select_tables`)."""
    seeds = tuple(int(s) for s in _check_seeds(seeds))
    q, snaps, returns, _ = run_batch(model.kernel, packed(cfg), budget(cfg, 0), rng.seed_states(seeds))
    if cfg.select_every == 0:
        return TrainResult(q, snaps, cfg.snapshots(), returns, seeds, cfg, model.name)
    kept = select_tables(model, cfg, snaps, cfg.snapshots())
    return TrainResult(kept.q, snaps, cfg.snapshots(), returns, seeds, cfg, model.name, kept.episodes)


def run_batch(model: Kernel, lr: Learner, plan: qlearning.Budget, stream: rng.U64Array,
              workers: int | None = None) -> tuple[FloatArray, FloatArray, FloatArray, IntArray]:
    """:func:`qlearning.train_batch` with the agents split over ``workers`` threads (default: one per core).

    Why threads and not ``numba.prange``: agents share nothing (each has its
    own stream word, table and model state), so contiguous slices trained in
    separate calls give exactly the tables of one call; the compiled kernel
    releases the GIL, and threads avoid numba's threading layers, whose
    default (workqueue) aborts when two Python threads launch parallel code at
    once (a ROS node may). Results are reassembled in seed order.
    """
    n = stream.size
    workers = min(n, workers if workers is not None else _cores())
    if workers < 2:
        return qlearning.train_batch(model, lr, plan, stream)
    # A few slices per worker, handed out as workers free up: on a shared machine one thread
    # may lose its core for a while, and the batch should not wait for it with half the work.
    bounds = np.linspace(0, n, min(n, 4 * workers) + 1).astype(np.int64)
    slices = [stream[a:b].copy() for a, b in itertools.pairwise(bounds)]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        parts = list(pool.map(lambda words: qlearning.train_batch(model, lr, plan, words), slices))
    q, snaps, returns, counts = (np.concatenate([part[k] for part in parts]) for k in range(4))
    return q, snaps, returns, counts


def _cores() -> int:
    """CPUs this process may run on (the affinity mask, not the machine's count), or fewer when
    ``OMP_NUM_THREADS`` says so: a sweep's worker is single-threaded (:mod:`msd_bench.app.executor`)."""
    cap = os.environ.get("OMP_NUM_THREADS", "")
    if cap.isdigit() and int(cap) > 0:
        return int(cap)
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def greedy_rollouts(model: StepModel, q_tables: FloatArray, cfg: QConfig, target: float = 1.0,
                    n_steps: int = 3000, observer: StepModel | None = None) -> tuple[FloatArray, FloatArray]:
    """Greedy closed loop of each fixed table from rest: (x, u), each (n_tables, n_steps).

    ``x[j, k]`` is the position before force ``u[j, k]`` acts, so ``x[:, 0] = 0``.
    Equal Q-values resolve to the lowest action index, keeping validation deterministic.
    ``observer`` is the model a ``model`` observer predicts with: the one the
    agent trained on (default: ``model`` itself).
    """
    lr = packed(cfg)
    n_states = lr.enc.n_states
    q = np.ascontiguousarray(q_tables, dtype=np.float64)
    if q.ndim != 3 or q.shape[1:] != (n_states, N_ACTIONS):
        raise InvalidInputError(
            f"Q-tables must have shape (n, {n_states}, {N_ACTIONS}) for state "
            f"{cfg.state!r}, got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise InvalidInputError("Q-tables contain a non-finite value")
    if not np.isfinite(target):
        raise InvalidInputError(f"target must be finite, got {target}")
    if n_steps < 1:
        raise InvalidInputError(f"n_steps must be >= 1, got {n_steps}")
    from msd_bench.core.evaluation.closed_loop import greedy_under, nominal

    # the nominal scenario of the one closed loop (an unobserved learner reads the true position)
    obs = (observer or model).kernel
    return greedy_under(model.kernel, lr, q, nominal(target), np.zeros((q.shape[0], int(n_steps))), obs)


def greedy_rollout(model: StepModel, q: FloatArray, cfg: QConfig, target: float = 1.0,
                   n_steps: int = 3000) -> tuple[FloatArray, FloatArray]:
    """Greedy closed loop of one fixed table from rest: (x, u), the paper's validation run."""
    q = np.asarray(q, dtype=np.float64)
    if q.ndim != 2:
        raise InvalidInputError(f"a single Q-table must be 2-D, got shape {q.shape}")
    xs, us = greedy_rollouts(model, q[None], cfg, target, n_steps)
    return xs[0], us[0]


def budget(cfg: QConfig, planning_steps: int) -> qlearning.Budget:
    """The episode budget of ``cfg`` (with ``planning_steps`` Dyna-Q updates per real step)."""
    return qlearning.Budget(cfg.episodes, cfg.steps, int(planning_steps),
                            np.array(cfg.snapshots(), dtype=np.int64))


def _check_seeds(seeds: Sequence[int]) -> Sequence[int]:
    if len(seeds) == 0:
        raise InvalidInputError("need at least one seed")
    rng.seed_states(seeds)  # raises on a bad seed
    return seeds
