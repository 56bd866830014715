"""Playing the plan through a rig: the ideal rig gives the ideal plant's records; rest without reset."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.app.pipeline import records_from_plan
from msd_bench.app.plan import paper_plan
from msd_bench.core.identification import identify
from msd_bench.core.identification.excitation import PrbsConfig
from msd_bench.core.physics.plant import preset
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import Rig, RigImperfections
from msd_bench.core.rigs.rig_play import PlayedExperiment, play_experiment, play_plan, records_of, rest

Played = list[PlayedExperiment]
P = preset("default")
PLAN = paper_plan(0, 600, 400, settle=200)


@pytest.fixture(scope="module")
def ideal() -> Played:
    return play_plan(Rig(P, RigImperfections.none()), PLAN)


def test_the_first_experiment_of_an_ideal_rig_is_the_ideal_plants_bit_for_bit(ideal: Played) -> None:
    first, exp = ideal[0], PLAN[0]
    assert exp.bias is not None and isinstance(exp.signal, PrbsConfig)
    ref = identify.bias_record(P, exp.bias, exp.seed, exp.signal).experiments[0]
    got = first.experiment()
    assert first.rest.samples == RestConfig().window  # at rest at the origin: the shortest wait
    assert np.array_equal(got.u, ref.u) and np.array_equal(got.y, ref.y)
    assert np.array_equal(first.measured, first.truth)
    assert np.array_equal(first.effort, np.clip(first.command, -P.F, P.F))  # the ±1 N PRBS at -10 N saturates


def test_each_experiment_from_a_reset_ideal_rig_is_records_from_plan() -> None:
    ref = records_from_plan(P, PLAN)
    played = [play_experiment(Rig(P, RigImperfections.none()), e) for e in PLAN]
    rec = records_of(played, P.dt)
    for bias, data in rec.bias_train.items():
        assert np.array_equal(data.experiments[0].y, ref.bias_train[bias].experiments[0].y)
    assert np.array_equal(rec.broad_val.experiments[0].u, ref.broad_val.experiments[0].u)
    assert np.array_equal(rec.broad_val.experiments[0].y, ref.broad_val.experiments[0].y)


def test_without_reset_later_experiments_start_where_the_rig_came_to_rest(ideal: Played) -> None:
    """Why the numbers differ from records_from_plan's: the start state. The rest leaves the mass within
    the stillness threshold of the origin, not at it; a PRBS record's settle segment forgets most of it,
    the broad record (no settle) keeps it."""
    ref = records_from_plan(P, PLAN)
    for p in ideal[1:]:
        assert p.rest.still and abs(p.rest.x0) < RestConfig().threshold
        assert p.truth[0] != 0.0  # never a reset
    rec = records_of(ideal, P.dt)
    broad = np.max(np.abs(rec.broad_train.experiments[0].y - ref.broad_train.experiments[0].y))
    assert 0 < broad < 0.05
    for bias, data in rec.bias_train.items():
        assert np.max(np.abs(data.experiments[0].y - ref.bias_train[bias].experiments[0].y)) < 1e-3


def test_a_rigs_records_hold_the_applied_force_and_the_measured_position() -> None:
    imp = RigImperfections(sensor_noise=0.002, sensor_quant=0.0001, delay_samples=2, actuator_tau=0.0,
                           friction=0.3, jitter=0.0)
    played = play_plan(Rig(P, imp, seed=3), PLAN[:2])
    for p in played:
        assert np.array_equal(p.effort[2:], np.clip(p.command[:-2], -P.F, P.F))  # two samples late
        assert np.array_equal(p.effort[:2], [0.0, 0.0])  # nothing of the rest in flight
        assert 0.001 < np.std(p.measured - p.truth) < 0.003
        assert np.allclose(p.velocity[1:], np.diff(p.measured) / P.dt)
        got = p.experiment()
        assert np.array_equal(got.u, p.effort[p.settle:]) and np.array_equal(got.y, p.measured[p.settle:])


def test_rest_holds_zero_force_until_still_and_says_when_it_timed_out() -> None:
    rig = Rig(P, RigImperfections(sensor_noise=0.02, sensor_quant=0.0, delay_samples=0, actuator_tau=0.0,
                                  friction=0.0, jitter=0.0))
    out = rest(rig, RestConfig(timeout=5.0))  # 20 mm of noise never looks still at 5 mm
    assert not out.still and out.samples == 500
