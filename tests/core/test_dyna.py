"""Dyna-Q baseline (paper §3.4.2): counts, one planning update by hand, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.learning.dyna import DynaConfig, train_dyna
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.core.learning.qtrain import train
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams

SHORT = QConfig(episodes=2, steps=200)


def test_counts_real_steps_and_planning_updates() -> None:
    res = train_dyna(plant_model(PlantParams()), DynaConfig(SHORT, planning_steps=7), [0, 1])
    assert list(res.real_steps) == [400, 400]
    assert list(res.planning_updates) == [2800, 2800]
    assert res.q.shape == (2, 100, 5) and res.returns.shape == (2, 2)


def test_deterministic_and_batch_equals_single() -> None:
    cfg = DynaConfig(SHORT, planning_steps=5)
    m = plant_model(PlantParams())
    batch = train_dyna(m, cfg, [4, 9])
    single = train_dyna(m, cfg, [9])
    assert np.array_equal(batch.q[1], single.q[0])
    assert np.array_equal(batch.returns[1], single.returns[0])
    assert np.array_equal(single.q, train_dyna(m, cfg, [9]).q)


def test_zero_planning_is_plain_q_learning_and_planning_changes_q() -> None:
    m = plant_model(PlantParams())
    dyna0 = train_dyna(m, DynaConfig(SHORT, planning_steps=0), [3])
    assert np.array_equal(dyna0.q, train(m, SHORT, [3]).q)
    dyna5 = train_dyna(m, DynaConfig(SHORT, planning_steps=5), [3])
    assert not np.array_equal(dyna5.q, dyna0.q)


def test_one_planning_update_by_hand() -> None:
    # x_{k+1} = 0.01 u_k, target fixed at 1, one real step then one planned replay of it
    lin = StepModel(kernels.KIND_LINEAR, np.array([5.0, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0]))
    qc = QConfig(episodes=1, steps=1, epsilon=0.0, target_low=1.0, target_high=1.0)
    res = train_dyna(lin, DynaConfig(qc, planning_steps=1), [0])
    (s, a), = zip(*np.nonzero(res.q[0]), strict=True)
    e1 = 0.01 * qc.actions()[a] - 1.0
    r = 1 / (1 + abs(e1)) - 10 * (abs(e1) - 1.0) / 5
    phi = 1.0 if a < 2 else 0.0
    s2 = int(np.floor(99 * (e1 + 5) / 10 + 0.5))
    q1 = 0.5 * r - 0.05 * phi
    next_max = q1 if s2 == s else 0.0
    q2 = q1 + 0.5 * (r + 0.9 * next_max - q1) - 0.05 * phi
    assert res.q[0][s, a] == pytest.approx(q2)


def test_bad_inputs() -> None:
    with pytest.raises(ConfigError):
        DynaConfig(planning_steps=-1)
    with pytest.raises(InvalidInputError):
        train_dyna(plant_model(PlantParams()), DynaConfig(SHORT), [])
