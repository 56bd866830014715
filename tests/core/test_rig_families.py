"""Rig families (core/rigs/families.py): one registry, the default family as it was, the scaled family
as its default-family twins in other units, and the method's scales on them (docs/rig-families.md)."""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.scenarios import Scenario
from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig
from msd_bench.core.learning.qconfig import improved_config
from msd_bench.core.physics.plant import PRESETS, PlantParams
from msd_bench.core.rigs import families, population, scaled_family
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.scales import Scales
from msd_bench.core.rigs.units import RigUnits
from msd_bench.core.safety.supervisor import SupervisorOptions

SEEDS = range(1, 301)


def test_the_default_family_is_the_population_bit_for_bit() -> None:
    fam = families.family("default")
    assert fam.design == population.DESIGN_RIGS and fam.held_out == population.HELD_OUT_RIGS
    for seed in (0, 1, 999, 1000, 1001, 123456):
        spec = families.draw("default", seed)
        assert spec == population.draw(seed) and spec.family == "default" and spec.units.is_identity
        assert spec.scales() is not None and spec.scales().is_default


@pytest.mark.parametrize(("name", "hint"), [("scaeld", "did you mean 'scaled'"),
                                           ("defualt", "did you mean 'default'"),
                                           ("gantry", "families: default, scaled, stage")])
def test_an_unknown_family_is_one_line_naming_the_nearest(name: str, hint: str) -> None:
    with pytest.raises(ConfigError) as err:
        families.family(name)
    assert "\n" not in str(err.value) and f"unknown rig family {name!r}" in str(err.value)
    assert hint in str(err.value)


def test_what_a_held_family_cannot_do_yet_is_one_line_saying_why() -> None:
    assert families.in_process("scaled", ceiling=True, refine=2, supervisor=True, curve=True).name == "scaled"
    assert families.in_process("stage").held
    with pytest.raises(ConfigError) as err:
        families.in_process("stage", ceiling=True, supervisor=True)
    line = str(err.value)
    assert "\n" not in line and "rig family 'stage' runs under its hold loop" in line
    assert "--ceiling, --supervisor on are not built for held rigs yet" in line
    with pytest.raises(ConfigError, match="the efficiency curve is not built"):
        families.in_process("stage", curve=True)


def test_each_family_keeps_design_and_held_out_seeds_apart() -> None:
    for fam in families.FAMILIES.values():
        assert fam.design.stop <= fam.held_out.start and len(fam.design) > 0 and len(fam.held_out) > 0


def test_a_scaled_rig_is_its_twin_in_other_units() -> None:
    for seed in (1, 42, 1000, 1001):
        twin, rig = population.draw(seed), families.draw("scaled", seed)
        u = rig.units
        f = u.mass * u.length / u.time**2
        p, q = twin.params, rig.params
        want = {"m": p.m * u.mass, "c": p.c * u.mass / u.time, "k": p.k * f, "g": p.g / u.length,
                "h": p.h * u.mass / (u.length**2 * u.time**2), "L": p.L * u.length, "F": p.F * f,
                "dt": p.dt * u.time}
        for name, value in want.items():
            assert getattr(q, name) == pytest.approx(value, rel=1e-14), name
        i, j = twin.imperfections, rig.imperfections
        assert j.delay_samples == i.delay_samples  # samples: unchanged
        assert j.friction == pytest.approx(i.friction * f, rel=1e-14)
        assert (j.sensor_noise, j.sensor_quant) == pytest.approx((i.sensor_noise * u.length,
                                                                  i.sensor_quant * u.length))
        assert (j.actuator_tau, j.jitter) == pytest.approx((i.actuator_tau * u.time, i.jitter * u.time))
        assert rig.multipliers() == pytest.approx(twin.multipliers(), rel=1e-12)  # the twin's draw, reported
        assert rig.seed == seed and rig.family == "scaled" and f"time x{u.time:.4g}" in rig.line()


def test_the_units_are_drawn_log_uniformly_in_the_stated_range_from_their_own_stream() -> None:
    drawn = [scaled_family.draw_units(s) for s in SEEDS]
    units = np.log([[u.length, u.mass, u.time] for u in drawn])
    lo, hi = math.log(0.05), math.log(20.0)
    assert units.min() >= lo and units.max() <= hi
    assert units.min() < lo + 0.1 and units.max() > hi - 0.1  # the ends are reached
    assert abs(float(np.mean(units))) < 0.35  # centred on x1 in log
    corr = np.corrcoef(units.T)
    assert np.max(np.abs(corr - np.eye(3))) < 0.2  # drawn independently
    assert scaled_family.draw_units(7) == scaled_family.draw_units(7) != scaled_family.draw_units(8)


def test_a_scaled_rig_runs_in_scales_whose_time_unit_is_its_sample_time() -> None:
    rig = families.draw("scaled", 1000)
    sc = rig.scales()
    assert sc.pace == sc.time  # exactly: so every paper sample count is the rig's own
    assert sc.samples(3000) == 3000 and sc.samples(1) == 1 and sc.steps(50.0) == 50.0
    assert sc.length == pytest.approx(rig.units.length) and sc.force == pytest.approx(rig.units.force)
    assert sc.per_sample(1e-5) == 1e-5  # a displacement per sample: per the same share of the motion


def test_the_paper_plant_in_a_scaled_rigs_scales_is_its_nominal_twin() -> None:
    rig = families.draw("scaled", 1001)
    nominal = rig.scales().plant(PlantParams())
    want = rig.units.plant(PRESETS["default"])
    for f in fields(PlantParams):
        assert getattr(nominal, f.name) == pytest.approx(getattr(want, f.name), rel=1e-12), f.name


def test_every_scaled_step_is_the_identity_on_the_default() -> None:
    d = Scales.DEFAULT
    assert Scales.of(5.0, 10.0, 0.01) == d and Scales.of(5.0, 10.0, 0.01, 1.0).is_default
    assert not Scales(pace=2.0).is_default
    assert RestConfig().scaled(d) == RestConfig() and SupervisorOptions().scaled(d) == SupervisorOptions()
    assert d.plant(PRESETS["rig"]) is PRESETS["rig"]
    assert Scenario(disturbance=2.0, disturbance_time=15.0).scaled(d) == Scenario(disturbance=2.0,
                                                                                    disturbance_time=15.0)


def test_durations_follow_the_time_unit_when_the_rig_states_one() -> None:
    slow = Scales(length=2.0, force=3.0, time=4.0, pace=4.0)  # a rig four times slower, sampled likewise
    assert PrbsConfig().scaled(slow).n_samples == PrbsConfig().n_samples
    assert MultilevelConfig().scaled(slow).min_dwell == MultilevelConfig().min_dwell
    sc = Scenario(disturbance=2.0, disturbance_time=15.0, lag=0.02).scaled(slow)
    assert (sc.disturbance, sc.disturbance_time, sc.lag) == (6.0, 60.0, 0.08)
    rest = RestConfig().scaled(slow)
    assert (rest.window, rest.x0_samples, rest.threshold, rest.timeout) == (300, 50, 0.01, 120.0)
    sup = SupervisorOptions().scaled(slow)
    assert (sup.latency, sup.div_tol, sup.v_margin) == (0.16, 0.5, 0.25)
    q = improved_config(slow)
    assert (q.steps, q.lead_steps, q.sample_unit) == (3000, 50.0, 1.0)
    assert (q.force_unit, q.length_unit, q.e_max) == (3.0, 2.0, 10.0)
    held = Scales(length=1.0, force=1.0, time=0.1)  # issue 37: a faster sampling, durations in seconds
    assert held.samples(3000) == 30000 and improved_config(held).sample_unit == pytest.approx(10.0)


def test_a_bounded_learner_setting_is_checked_in_paper_units() -> None:
    """The robust agent's observer gain (8 N/m) on a rig with 1000 times the force per metre is 8000 N/m,
    beyond the paper's bound of 1000 but the same gain in the paper's units."""
    big = Scales(length=0.1, force=100.0)
    q = improved_config(big, observer="model", obs_gain=0.1, obs_bias_gain=8.0)
    assert q.obs_bias_gain == pytest.approx(8000.0)
    with pytest.raises(ConfigError):
        improved_config(big, observer="model", obs_gain=0.1, obs_bias_gain=2000.0)


def test_a_scaled_rig_records_what_its_twin_records_in_its_units() -> None:
    """The rig itself is scale-free: the twin's command, scaled, gives the twin's positions, scaled
    (to rounding), sensor noise and quantisation included."""
    twin, rig = population.draw(1003), families.draw("scaled", 1003)
    u = np.random.default_rng(3).uniform(-10.0, 10.0, 1500)
    a, b = Rig(twin.params, twin.imperfections, seed=5), Rig(rig.params, rig.imperfections, seed=5)
    xa = np.array([a.step(float(v)).measured for v in u])
    xb = np.array([b.step(float(v) * rig.units.force).measured for v in u]) / rig.units.length
    assert np.max(np.abs(xa - xb)) <= 1e-9 * np.max(np.abs(xa))


def test_units_reject_a_bad_factor_in_one_line() -> None:
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ConfigError) as err:
            RigUnits(length=bad)
        assert "\n" not in str(err.value) and "length unit" in str(err.value)
