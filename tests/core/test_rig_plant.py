"""The plant the emulator serves for a rig description (docs/rig-description.md §The emulated plant).

A real rig brings its own plant; the emulator's is the paper's plant in the rig's units of length
and force (time unchanged: durations are seconds), sampled at the rig's rate. On the default
description it is the default plant bit for bit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams, preset
from msd_bench.core.rigs.description import default_description, parse_description
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import RigImperfections

STAGE = parse_description({"rate": 1000.0, "stroke": 0.25, "force_limit": 350.0}, "stage.yaml")
LONG = parse_description({"rate": 250.0, "stroke": 20.0, "force_limit": 40.0, "decision_period": 0.004})


def test_the_default_description_serves_the_default_plant_bit_for_bit() -> None:
    rig = default_description()
    for name in ("default", "mild", "rig"):
        assert rig.emulated_plant(preset(name)) == preset(name)
    assert rig.emulated_plant() == PlantParams()
    imp = RigImperfections()
    assert imp.scaled(rig.scales()) is imp
    assert RestConfig().scaled(rig.scales()) == RestConfig()


def test_the_stage_plant_has_the_rigs_stroke_force_and_rate() -> None:
    p = STAGE.emulated_plant()
    assert (p.L, p.F, p.dt) == pytest.approx((0.25, 350.0, 0.001))
    assert p.m == pytest.approx(1.0 * 35 / 0.05) and p.k == pytest.approx(2.4 * 35)
    assert p.g == pytest.approx(20.0) and p.h == pytest.approx(35 / 0.05**3)


@pytest.mark.parametrize("rig", [STAGE, LONG], ids=["stage", "long"])
def test_the_rig_plant_is_the_default_plant_in_rig_units(rig) -> None:  # type: ignore[no-untyped-def]
    """The same force history, as a share of the force limit, moves the rig's plant the same share of
    its stroke at every instant (compared at the paper's 10 ms sampling, where both plants step alike)."""
    p0 = PlantParams()
    p = replace(rig.emulated_plant(), dt=p0.dt)
    s = rig.scales()
    u = np.random.default_rng(3).choice(p0.actions(), size=3000)
    x0 = plant_model(p0).simulate(u)
    x = plant_model(p).simulate(u * s.force)
    np.testing.assert_allclose(x / s.length, x0, rtol=1e-9, atol=1e-9)
    assert np.ptp(x0) > 1.0  # the record goes somewhere: a trivial match would prove nothing


def test_limits_not_centred_are_one_line() -> None:
    rig = parse_description({"rate": 100.0, "position_min": -1.0, "position_max": 3.0, "force_limit": 10.0})
    with pytest.raises(ConfigError) as err:
        rig.emulated_plant()
    assert "\n" not in str(err.value) and "centred on 0" in str(err.value)


def test_the_rigs_imperfections_and_rest_test_are_in_its_scales() -> None:
    imp = RigImperfections().scaled(STAGE.scales())
    assert imp.sensor_noise == pytest.approx(0.002 * 0.05) and imp.friction == pytest.approx(0.2 * 35)
    assert imp.delay_samples == 10 and imp.jitter == pytest.approx(0.0002)  # 10 ms, and under 1 ms
    imp.check_against(STAGE.emulated_plant())
    rest = RestConfig().scaled(LONG.scales())
    assert rest.window == 750 and rest.threshold == pytest.approx(0.02)  # 3 s at 250 Hz; 0.1 % of stroke
