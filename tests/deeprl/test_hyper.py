"""Hyper-parameters: the grid starts at SB3's defaults, and a bad entry is one ConfigError line."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.deeprl import mlp
from msd_bench.core.deeprl.hyper import DEFAULTS, DESIGN_SEEDS, Hyper, from_dict, grid
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import preset
from msd_bench.designs.deeprl_train import train


@pytest.mark.parametrize("algo", ["dqn", "ppo"])
def test_the_grid_starts_at_sb3s_defaults_and_round_trips(algo: str) -> None:
    g = grid(algo)
    assert g[0] == DEFAULTS[algo] and len(set(map(repr, g))) == len(g)
    assert all(from_dict(h.as_dict()) == h for h in g)


@pytest.mark.parametrize(("doc", "message"), [
    ({"algo": "sac", "learning_rate": 1e-3}, "unknown deep-RL algorithm 'sac'"),
    ({"algo": "dqn", "learning_rate": 2.0}, "out of range"),
    ({"algo": "dqn", "learning_rate": 1e-3, "hidden": [64]}, "two positive layer widths"),
    ({"algo": "dqn", "learning_rate": 1e-3, "nosuch": 1}, "bad hyper-parameters"),
    ([1, 2], "must be a JSON object"),
])
def test_a_bad_entry_is_one_line(doc: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        from_dict(doc)


def test_design_seeds_are_not_reported_seeds() -> None:
    assert all(s >= 90_000 for s in DESIGN_SEEDS)


def test_a_budget_that_is_not_a_positive_int_is_refused() -> None:
    with pytest.raises(ConfigError, match="steps must be an int >= 1"):
        train(plant_model(preset("default")), Hyper("dqn", 1e-3), 0, 0)


def test_greedy_takes_the_first_maximum_as_torch_argmax() -> None:
    zeros = [np.zeros((1, 2, 4)), np.zeros((1, 2)), np.zeros((1, 2, 2)), np.zeros((1, 2)),
             np.zeros((1, 5, 2)), np.array([[0.0, 1.0, 1.0, 0.5, 1.0]])]
    assert mlp.greedy(mlp.from_arrays(zeros, mlp.RELU), 0, 0.3, 0.0, 1.0, 0.0) == 1
