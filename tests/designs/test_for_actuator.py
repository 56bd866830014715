"""The robust agent told a rig's drive: the delay its records show reaches the model observer only."""

from __future__ import annotations

from dataclasses import replace

import pytest

from msd_bench.app.config import RunConfig
from msd_bench.app.plan import paper_plan
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.learning.qconfig import MAX_DELAY_SAMPLES
from msd_bench.core.rigs import population
from msd_bench.core.rigs.rig import Rig, RigImperfections
from msd_bench.core.rigs.rig_play import measured_actuator, play_plan
from msd_bench.designs.qlearning import for_actuator, learner_config, robust_config

RUN = RunConfig(samples=600, val_samples=400)


def _played(rig: Rig) -> list:  # type: ignore[type-arg]
    return list(play_plan(rig, paper_plan(RUN.id_first_seed, RUN.samples, RUN.val_samples)))


def test_only_a_model_observer_is_told_the_delay() -> None:
    robust = learner_config("glm+robust", 10, 100, 10.0)
    assert for_actuator(robust, 2) == replace(robust, obs_delay=2, train_delay=robust.train_delay + 2)
    assert for_actuator(robust, 0) == robust  # an ideal plant's records: the agent as chosen, unchanged
    assert for_actuator(robust, 99).obs_delay == for_actuator(robust, 99).train_delay == MAX_DELAY_SAMPLES
    improved = learner_config("glm+improved", 10, 100, 10.0)
    paper = learner_config("glm", 10, 100, 10.0)
    assert for_actuator(improved, 2) == improved and for_actuator(paper, 2) == paper
    assert robust_config().observer == "model" and robust_config().obs_delay == 0


@pytest.mark.parametrize("seed", [46, 47, 1012])
def test_the_delay_is_read_from_the_broad_record_of_a_rig(seed: int) -> None:
    drawn = population.draw(seed)
    rig = Rig(drawn.params, drawn.imperfections, seed=seed)
    drive = measured_actuator(_played(rig), drawn.params.dt)
    assert drive.delay_samples == drawn.imperfections.delay_samples
    assert drive.time_constant_s == pytest.approx(drawn.imperfections.actuator_tau, rel=0.25, abs=0.002)


def test_a_drive_without_delay_or_lag_shows_none() -> None:
    drawn = population.draw(46)
    ideal = RigImperfections(sensor_noise=0.0, sensor_quant=0.0, delay_samples=0, actuator_tau=0.0,
                             friction=0.0, jitter=0.0)
    drive = measured_actuator(_played(Rig(drawn.params, ideal, seed=46)), drawn.params.dt)
    assert drive.delay_samples == 0 and drive.time_constant_s == pytest.approx(0.0, abs=1e-3)


def test_a_plan_without_its_broad_record_is_refused() -> None:
    drawn = population.draw(46)
    played = [p for p in _played(Rig(drawn.params, drawn.imperfections, seed=46)) if p.bias is not None]
    with pytest.raises(InvalidInputError, match="no broad training record"):
        measured_actuator(played, drawn.params.dt)
