"""Validation through a rig: the compiled loop is the rig's own physics, from where the rig rests."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.app.config import RunConfig
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.core.learning.qtrain import greedy_rollouts, train
from msd_bench.core.physics.model import plant_model
from msd_bench.core.rigs.rig import Rig, RigImperfections
from msd_bench.core.rigs.rig_loop import drain_samples, run_on_rig
from msd_bench.designs.qlearning import learner_config

RUN = RunConfig(episodes=4, steps=300)
P = RUN.plant
PM = plant_model(P)
FRICTIONAL = RigImperfections(sensor_noise=0.0, sensor_quant=0.0, delay_samples=2, actuator_tau=0.03,
                              friction=0.3, jitter=0.0)


def _qconfig(kind: str) -> QConfig:
    """The kind's Q-learner at RUN's budget (as msd-bench rigs trains it)."""
    return learner_config(kind, RUN.episodes, RUN.steps, RUN.plant.F, RUN.shaping)


@pytest.fixture(scope="module", params=["plm", "plm+robust"])
def tables(request: pytest.FixtureRequest) -> tuple[str, np.ndarray]:
    """Two trained tables and two random ones (a tiny budget may leave a table that only ever rests)."""
    qc = _qconfig(request.param)
    trained = train(PM, qc, [0, 1]).q
    rand = np.random.default_rng(5).normal(size=trained.shape)
    return request.param, np.concatenate([trained, rand])


def test_an_ideal_rig_from_the_origin_is_the_plants_validation(tables: tuple[str, np.ndarray]) -> None:
    kind, q = tables
    qc = _qconfig(kind)
    x, u = greedy_rollouts(PM, q, qc, 1.0, 400, observer=PM)
    for j in range(4):
        got = run_on_rig(Rig(P, RigImperfections.none()), q[j], qc, PM, 1.0, 400, np.random.default_rng(0))
        assert np.array_equal(got.x, x[j]) and np.array_equal(got.u, u[j])
        assert np.array_equal(got.y, got.x) and np.array_equal(got.effort, got.u)


def test_the_compiled_loop_steps_like_the_rig(tables: tuple[str, np.ndarray]) -> None:
    """The same commands fed to :class:`Rig` one sample at a time give the same forces and positions:
    dead time, lag and friction are the rig's."""
    kind, q = tables
    rig = Rig(P, FRICTIONAL)
    run = run_on_rig(rig, q[2], _qconfig(kind), PM, 1.0, 400, np.random.default_rng(0))
    twin = Rig(P, FRICTIONAL)
    rows = [twin.step(c) for c in run.u]
    assert np.allclose([r.effort for r in rows], run.effort, rtol=0, atol=1e-12)
    assert np.allclose([r.x for r in rows], run.x, rtol=0, atol=1e-12)
    assert not np.array_equal(run.effort, run.u)  # the actuator did act


def test_runs_start_where_the_rig_rests_and_leave_it_where_they_end(tables: tuple[str, np.ndarray]) -> None:
    kind, q = tables
    rig = Rig(P, FRICTIONAL)
    first = run_on_rig(rig, q[2], _qconfig(kind), PM, 1.0, 400, np.random.default_rng(0))
    after_first = (rig.x, rig.v)
    second = run_on_rig(rig, q[3], _qconfig(kind), PM, -0.5, 400, np.random.default_rng(1))
    assert after_first != (0.0, 0.0)
    assert second.x[0] != 0.0  # friction holds the mass off the origin: no reset between runs
    assert second.rest.still and abs(second.x[0] - second.rest.x0) < 1e-9  # noise-free: the rest's reading
    assert first.rest.samples == 300


def test_the_drain_covers_the_dead_time_and_the_lag() -> None:
    assert drain_samples(Rig(P, RigImperfections.none())) == 0
    rig = Rig(P, FRICTIONAL)
    assert drain_samples(rig) == 2 + int(np.ceil(3.0 * np.log(P.F / 1e-9)))
