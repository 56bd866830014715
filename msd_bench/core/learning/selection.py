"""Which of a training run's tables an agent keeps: the one that rehearses best on the model it trained on.

Why: tabular Q-learning with a constant step size never settles. Its greedy
policy keeps changing from episode to episode, and the final table is one draw
from that wandering. On design seeds only (docs/decisions.md §Robust, round 5),
the robust agent's final table failed its own greedy run on the training
surrogate for about one seed in ten. Those were almost exactly the seeds
that also failed on the other surrogate standing in for the plant. A table that
cannot hold a set-point on the model it learned on is not going to hold one on
the plant.

So the agent rehearses each candidate table greedily on that same model, from
rest, at a spread of set-points inside the training range
(:data:`REHEARSAL_TARGETS`). It keeps the table with the most successes there,
by the validation's own criterion (SSE over the terminal window below
:data:`msd_bench.core.evaluation.metrics.SUCCESS_SSE`), and ties go to the later table.
Rehearsals run only on the model: they cost no plant sample. Learners that
train on the plant itself therefore keep their final table
(:func:`msd_bench.app.agents.learner_config`).

The selection is a pure function of the snapshots and the model. A batch
trained in-process and the same seeds trained step by step over ROS therefore
keep the same tables, bit for bit.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation.closed_loop import greedy_under, nominal
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.learning.qconfig import QConfig, packed
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

REHEARSAL_TARGETS: tuple[float, ...] = (-1.5, -1.0, -0.5, 0.5, 1.0, 1.5)
"""Set-points (paper m; × the learner's ``length_unit`` on a rig) each candidate table is rehearsed at:
both signs and three sizes inside the ±2 m training range, so no single validation target decides which
table is kept."""


REHEARSAL_WINDOW = 500
"""Terminal window (paper samples; the same duration on a rig) of a rehearsal's SSE: the validation's
default, or the whole episode of a shortened run (``steps`` below it)."""


class Selection(NamedTuple):
    """The tables kept and where they came from."""

    q: FloatArray
    """The kept table of each agent, shape (n_agents, S, 5)."""
    episodes: IntArray
    """The episode count after which each kept table was taken."""
    successes: IntArray
    """Each kept table's successful rehearsals (of ``len(REHEARSAL_TARGETS)``)."""


def rehearsal_successes(model: StepModel, cfg: QConfig, q: FloatArray) -> IntArray:
    """How many of :data:`REHEARSAL_TARGETS` each table in ``q`` (n, S, 5) holds on ``model``, greedily."""
    lr = packed(cfg)
    tables = np.ascontiguousarray(q, dtype=np.float64)
    wins = np.zeros(tables.shape[0], dtype=np.int64)
    if cfg.steps < 2:  # no trajectory to score: every table ties, so the final one is kept
        return wins
    quiet = np.zeros((tables.shape[0], cfg.steps))
    window = min(_rig_samples(REHEARSAL_WINDOW, cfg.sample_unit), cfg.steps)
    for paper_target in REHEARSAL_TARGETS:  # paper metres: the same fractions of a rig's stroke
        target = paper_target * cfg.length_unit
        xs, _ = greedy_under(model.kernel, lr, tables, nominal(target), quiet, model.kernel)
        wins += np.array([compute(x, target, model.dt, window).success for x in xs], dtype=np.int64)
    return wins


def _rig_samples(paper_samples: int, sample_unit: float) -> int:
    """A paper count of samples on a rig of ``sample_unit`` rig samples per paper sample (itself at 1)."""
    return paper_samples if sample_unit == 1.0 else max(1, round(paper_samples * sample_unit))


def select_tables(model: StepModel, cfg: QConfig, snapshots: FloatArray,
                  snapshot_episodes: Sequence[int]) -> Selection:
    """Per agent, the candidate table (``cfg.selection_episodes()``) that rehearses best; ties to the later.

    ``snapshots`` (n_agents, n_snap, S, 5) are taken after ``snapshot_episodes``
    (``cfg.snapshots()``), which must include every candidate episode.
    """
    candidates = cfg.selection_episodes()
    where = {int(e): i for i, e in enumerate(snapshot_episodes)}
    missing = [e for e in candidates if e not in where]
    if not candidates or missing:
        raise InvalidInputError(f"selection needs snapshots after episodes {list(candidates)}; "
                                f"missing {missing or 'all (select_every is 0)'}")
    n = snapshots.shape[0]
    best_q = np.ascontiguousarray(snapshots[:, where[candidates[0]]]).copy()
    best_ep = np.full(n, candidates[0], dtype=np.int64)
    best_wins = rehearsal_successes(model, cfg, best_q)
    for episode in candidates[1:]:  # latest first: a strictly better earlier table replaces it
        q = snapshots[:, where[episode]]
        wins = rehearsal_successes(model, cfg, q)
        better = wins > best_wins
        best_q[better] = q[better]
        best_ep[better] = episode
        best_wins[better] = wins[better]
    return Selection(best_q, best_ep, best_wins)
