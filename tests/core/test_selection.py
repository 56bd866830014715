"""Rehearsal selection: which snapshot an agent keeps, the same in-process and step by step."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench.app import agents
from msd_bench.app.agents import learner_config, robust_config
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.learning.learner import StepwiseLearner, stacked_snapshots
from msd_bench.core.learning.qconfig import improved_config
from msd_bench.core.learning.qtrain import train
from msd_bench.core.learning.selection import REHEARSAL_TARGETS, rehearsal_successes, select_tables
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams

PLANT = plant_model(PlantParams())
SMALL = improved_config(episodes=12, steps=600, observer="model", obs_gain=0.1, obs_velocity_share=0.3,
                        obs_bias_gain=8.0, train_delay=1, select_every=2)
"""A short robust-style run with six candidate tables (episodes 12, 10, 8, 6)."""


def test_candidates_are_counted_back_over_the_second_half() -> None:
    assert replace(robust_config(), select_every=10).selection_episodes() == tuple(range(300, 149, -10))
    assert SMALL.selection_episodes() == (12, 10, 8, 6)
    assert replace(SMALL, select_every=0).selection_episodes() == ()
    assert set(SMALL.selection_episodes()) <= set(SMALL.snapshots())  # every candidate is snapshotted


def test_kept_tables_are_snapshots_that_rehearse_at_least_as_well_as_the_final() -> None:
    cfg = replace(SMALL, episodes=40, steps=3000, select_every=4)  # long enough for some tables to hold
    seeds = list(range(20, 36))
    got = train(PLANT, cfg, seeds)
    final = train(PLANT, replace(cfg, select_every=0), seeds)
    assert np.array_equal(got.snapshots[:, -1], final.q)  # selection changes nothing upstream
    assert np.array_equal(got.returns, final.returns)
    assert got.kept_episodes is not None and set(got.kept_episodes) <= set(cfg.selection_episodes())
    where = {e: i for i, e in enumerate(got.snapshot_episodes)}
    for j, episode in enumerate(got.kept_episodes):
        assert np.array_equal(got.q[j], got.snapshots[j, where[int(episode)]])
    kept, last = rehearsal_successes(PLANT, cfg, got.q), rehearsal_successes(PLANT, cfg, final.q)
    earlier = got.kept_episodes < cfg.episodes
    assert earlier.any()  # seeds 20-35 include tables the selection replaces
    assert np.all(kept[earlier] > last[earlier]) and np.array_equal(kept[~earlier], last[~earlier])
    assert np.all(kept <= len(REHEARSAL_TARGETS))
    assert final.kept_episodes is None and np.array_equal(final.q, final.snapshots[:, -1])  # off: final


def test_ties_keep_the_later_table() -> None:
    table = train(PLANT, replace(SMALL, select_every=0), [3]).q[0]
    episodes = SMALL.snapshots()
    same = np.broadcast_to(table, (1, len(episodes), *table.shape)).copy()
    kept = select_tables(PLANT, SMALL, same, episodes)
    assert kept.episodes.tolist() == [SMALL.episodes]


@pytest.mark.parametrize("steps", [1, 120])
def test_short_episodes_rehearse_over_what_they_have(steps: int) -> None:
    """A shortened run (fewer steps than the validation's 500-sample window) still selects."""
    cfg = replace(SMALL, steps=steps)
    got = train(PLANT, cfg, [1, 2])
    assert got.kept_episodes is not None and set(got.kept_episodes) <= set(cfg.selection_episodes())


def test_a_missing_candidate_snapshot_is_refused() -> None:
    snaps = np.zeros((1, 2, *train(PLANT, replace(SMALL, select_every=0), [1]).q.shape[1:]))
    with pytest.raises(InvalidInputError, match="missing"):
        select_tables(PLANT, SMALL, snaps, (1, SMALL.episodes))


def test_step_by_step_training_keeps_the_same_tables_as_the_batch() -> None:
    """The agent node's ``--via-ros`` path stacks its learners' snapshots and selects the same way."""
    seeds = [5, 6, 7]
    batch = train(PLANT, SMALL, seeds)
    learners = []
    for seed in seeds:
        agent = StepwiseLearner(SMALL, seed, observer=PLANT)
        for _ in range(SMALL.episodes):
            state = PLANT.initial_state()
            agent.start_episode(0.0)
            while not agent.episode_over:
                agent.learn(PLANT.step(state, agent.act()))
        learners.append(agent)
    snaps, episodes = stacked_snapshots(learners)
    assert np.array_equal(select_tables(PLANT, SMALL, snaps, episodes).q, batch.q)


def test_only_learners_on_a_model_select(monkeypatch: pytest.MonkeyPatch) -> None:
    """A rehearsal on the true plant would cost real samples: on-plant kinds keep their final table."""
    monkeypatch.setitem(agents.LEARNERS, "robust", lambda: replace(robust_config(), select_every=10))
    assert learner_config("plm+robust", 300, 3000, 10.0).select_every == 10
    assert learner_config("plant+robust", 300, 3000, 10.0).select_every == 0
    assert learner_config("plm+improved", 300, 3000, 10.0).select_every == 0
