"""Real-time recordings are cut back to the played samples; bag parameters rebuild the signal."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.identification import excitation as exc
from msd_bench.core.identification.data import Experiment
from msd_bench.io.bags.bag_records import align_to_played


def _params(cfg: exc.PrbsConfig, seed: int) -> dict:
    return {"signal": "prbs", "seed": seed, "prbs": asdict(cfg), "role": "train"}


@pytest.mark.parametrize("bias", [0.0, 5.0])
def test_padding_before_and_after_is_cut_exactly(bias: float) -> None:
    cfg = exc.PrbsConfig(bias=bias, n_samples=400, settle=50)
    played = exc.prbs(cfg, 2)
    lead, tail = np.zeros(37), np.concatenate([np.full(20, played[-1]), np.zeros(30)])
    u = np.concatenate([lead, played, tail])
    y = np.arange(u.size, dtype=float)
    cut = align_to_played(Experiment(u, y), _params(cfg, 2))
    assert np.array_equal(cut.u, played) and cut.y[0] == 37.0


def test_exact_and_foreign_bags_are_left_alone() -> None:
    cfg = exc.PrbsConfig(bias=5.0, n_samples=100, settle=10)
    played = exc.prbs(cfg, 1)
    exp = Experiment(played, np.zeros(played.size))
    assert align_to_played(exp, _params(cfg, 1)) is exp
    assert align_to_played(exp, {"role": "train"}) is exp


def test_signal_rebuilt_from_stored_parameters() -> None:
    cfg = exc.MultilevelConfig(n_samples=500)
    params = {"signal": "multilevel", "seed": 4, "multilevel": {**asdict(cfg), "levels": list(cfg.levels)}}
    assert np.array_equal(exc.signal_from_params(params), exc.multilevel(cfg, 4))
    with pytest.raises(ConfigError, match="prbs has no field colour"):
        exc.signal_from_params({"signal": "prbs", "prbs": {"colour": "red"}})
