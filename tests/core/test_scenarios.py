"""Scenario ids parse into exactly the perturbation they name; bad ids are one-line errors."""

from __future__ import annotations

import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.scenarios import STANDARD, Scenario, noise_seed, parse, suite
from msd_bench.core.physics.plant import PlantParams


def test_nominal_is_the_papers_condition():
    assert parse("nominal") == Scenario()


def test_a_composed_id_sets_every_named_field_and_keeps_its_text():
    s = parse("noise=0.005,delay=1,setpoint=-1.2,disturbance=-2@15,friction=0.2,quant=0.0001,mass=1.2")
    assert (s.noise, s.delay, s.setpoint, s.disturbance, s.disturbance_time) == (0.005, 1, -1.2, -2.0, 15.0)
    assert (s.friction, s.quant, s.mass) == (0.2, 0.0001, 1.2)
    assert s.id == "noise=0.005,delay=1,setpoint=-1.2,disturbance=-2@15,friction=0.2,quant=0.0001,mass=1.2"
    assert s.has_sensor and not parse("delay=2").has_sensor


def test_multipliers_scale_the_plant():
    p = parse("mass=1.2,damping=0.7,hardening=1.3,spring=0.9").plant(PlantParams())
    assert (p.m, p.c, p.h, p.k) == pytest.approx((1.2, 0.7, 1.3, 2.4 * 0.9))
    assert (p.dt, p.L, p.F) == (0.01, 5.0, 10.0)


@pytest.mark.parametrize("bad", ["", "noise", "noise=-1", "noise=x", "delay=1.5", "delay=-1",
                                 "setpoint=0", "setpoint=3", "disturbance=2", "mass=0", "speed=2",
                                 "noise=0.1,noise=0.2", "friction=nan"])
def test_bad_ids_are_one_line_errors(bad):
    with pytest.raises(ConfigError) as err:
        parse(bad)
    assert "\n" not in str(err.value)


def test_standard_suite_has_exactly_the_issue_ids_and_extras_append_once():
    ids = [s.id for s in suite(("noise=0.005,delay=1", "nominal"))]
    assert ids[: len(STANDARD)] == list(STANDARD)
    assert ids[len(STANDARD):] == ["noise=0.005,delay=1"]
    assert len(STANDARD) == 14


def test_noise_seed_depends_on_seed_and_id_only():
    assert noise_seed(3, "noise=0.005") == noise_seed(3, "noise=0.005")
    seeds = {noise_seed(3, "noise=0.005"), noise_seed(4, "noise=0.005"), noise_seed(3, "noise=0.002")}
    assert len(seeds) == 3


def test_lag_parses_and_a_bad_lag_is_one_line():
    assert parse("lag=0.02").lag == 0.02 and parse("lag=0.02,delay=1").delay == 1
    assert "lag=0.02" in STANDARD
    for bad in ("lag=-0.01", "lag=2", "lag=nan", "lag=fast"):
        with pytest.raises(ConfigError) as err:
            parse(bad)
        assert "lag" in str(err.value) and "\n" not in str(err.value)
