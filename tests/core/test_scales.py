"""The method in a rig's scales (docs/decisions.md §Scales): default unchanged, similar rigs alike.

The similarity transform of the plant (lengths × l, forces × f, time × t):
m × f t²/l, c × f t/l, k × f, g / l, h × f/l³, L × l, F × f, dt × t. A rig
scaled in length and force (t = 1) is the default plant in other units, so the
scaled method must do on it what the default method does on the default plant.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench.app.plan import paper_plan
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation import metrics
from msd_bench.core.evaluation.scenarios import STANDARD, Scenario, parse, suite
from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig, StepsConfig
from msd_bench.core.identification.operating_points import PLM_BIASES, plm_biases
from msd_bench.core.learning.qconfig import QConfig, improved_config, packed
from msd_bench.core.learning.qtrain import greedy_rollouts, train
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.scales import Scales

SEEDS = (1, 2, 3, 4)


def similar(p: PlantParams, length: float, force: float, time: float = 1.0) -> PlantParams:
    """``p`` with lengths × length, forces × force and time × time (the module's transform)."""
    return PlantParams(m=p.m * force * time * time / length, c=p.c * force * time / length, k=p.k * force,
                       g=p.g / length, h=p.h * force / length**3, L=p.L * length, F=p.F * force,
                       dt=p.dt * time)


def test_default_scales_are_exactly_one_and_change_nothing() -> None:
    p = PlantParams()
    assert Scales.of(p.L, p.F, p.dt) == Scales.DEFAULT == Scales(1.0, 1.0, 1.0)
    assert Scales.DEFAULT.is_default
    for cfg in (QConfig(), improved_config()):
        assert cfg.scaled(Scales.DEFAULT) is cfg
    assert improved_config(Scales.DEFAULT) == improved_config()
    for sig in (PrbsConfig(), MultilevelConfig(), StepsConfig()):
        assert sig.scaled(Scales.DEFAULT) is sig
    assert plm_biases() is PLM_BIASES and plm_biases(Scales.DEFAULT) is PLM_BIASES
    assert paper_plan(3, scales=Scales.DEFAULT) == paper_plan(3)
    assert suite(scales=Scales.DEFAULT) == suite()
    assert parse("nominal") == Scenario()


@pytest.mark.parametrize("bad", [(0.0, 10.0, 0.01), (5.0, -1.0, 0.01), (5.0, 10.0, float("nan")),
                                 (5.0, float("inf"), 0.01)])
def test_a_bad_rig_is_one_line(bad: tuple[float, float, float]) -> None:
    with pytest.raises(ConfigError) as err:
        Scales.of(*bad)
    assert "\n" not in str(err.value) and "must be a finite number > 0" in str(err.value)


def test_a_kilohertz_stage_in_its_own_units() -> None:
    s = Scales.of(0.25, 350.0, 0.001)  # the linear stage: 0.25 m, 350 N, 1 kHz
    cfg = improved_config(s)
    assert cfg.e_max == pytest.approx(0.25) and cfg.force == pytest.approx(350.0)
    assert cfg.error_edges[0] == pytest.approx(0.0005) and cfg.error_edges[-1] == pytest.approx(0.1)
    assert (cfg.target_low, cfg.target_high) == pytest.approx((-0.1, 0.1))
    assert cfg.steps == 30_000 and cfg.lead_steps == pytest.approx(500.0)  # 30 s and 0.5 s
    assert plm_biases(s) == pytest.approx((-350.0, -175.0, 0.0, 175.0, 350.0))
    assert parse("nominal", s).setpoint == pytest.approx(0.05)  # the unit step on a 5 m stroke
    assert [sc.setpoint for sc in suite(scales=s)][:5] == pytest.approx([0.05, -0.075, -0.025, 0.025, 0.075])
    assert parse("delay=2").scaled(s).delay == 20  # 20 ms of dead time
    with pytest.raises(ConfigError, match=r"within the ±0\.125 m stroke"):
        parse("setpoint=0.2", s)
    prbs = PrbsConfig(bias=5.0).scaled(s)
    assert (prbs.bias, prbs.amplitude, prbs.hold) == pytest.approx((175.0, 35.0, 200))
    assert len(STANDARD) == len(suite(scales=s))


@pytest.fixture(scope="module")
def default_run() -> tuple[np.ndarray, np.ndarray]:
    """The improved agent's tables and greedy unit steps on the default plant."""
    p = PlantParams()
    cfg = improved_config()
    tables = train(plant_model(p), cfg, SEEDS).q
    x, _ = greedy_rollouts(plant_model(p), tables, cfg, 1.0, cfg.steps)
    return tables, x


@pytest.mark.parametrize(("length", "force"), [(0.05, 35.0), (20.0, 0.5), (0.25, 0.125)])
def test_a_similar_rig_trains_and_steps_alike(default_run: tuple[np.ndarray, np.ndarray], length: float,
                                              force: float) -> None:
    """Trained from scratch on a rig similar in length and force: the same loop, in its units."""
    tables0, x0 = default_run
    p = similar(PlantParams(), length, force)
    s = Scales.of(p.L, p.F, p.dt)
    assert s.length == pytest.approx(length) and s.force == pytest.approx(force) and s.time == 1.0
    cfg = improved_config(s)
    tables = train(plant_model(p), cfg, SEEDS).q
    target = s.metres(1.0)
    x, _ = greedy_rollouts(plant_model(p), tables, cfg, target, cfg.steps)
    np.testing.assert_allclose(x / length, x0, rtol=0, atol=1e-9)
    m0 = [metrics.compute(r, 1.0, 0.01) for r in x0]
    m = [metrics.compute(r, target, p.dt) for r in x]
    assert [a.success for a in m] == [b.success for b in m0]
    assert [a.ts5 for a in m] == pytest.approx([b.ts5 for b in m0], nan_ok=True)
    if length == 0.25:  # powers of two: every product exact, so the learning itself is the same
        np.testing.assert_array_equal(tables, tables0)  # the reward is dimensionless


@pytest.mark.parametrize("time", [0.1, 0.4])
def test_the_same_seconds_at_another_rate(default_run: tuple[np.ndarray, np.ndarray], time: float) -> None:
    """The default plant sampled at 1 kHz / 250 Hz: the default tables, with the lead horizon and the
    stillness tolerance converted to the rig's samples, step as they do at 100 Hz (within 0.5 s)."""
    tables0, x0 = default_run
    p = replace(PlantParams(), dt=0.01 * time)
    s = Scales.of(p.L, p.F, p.dt)
    cfg = improved_config(s)
    assert cfg.steps == round(3000 / time)
    x, _ = greedy_rollouts(plant_model(p), tables0, cfg, 1.0, cfg.steps)
    m0 = [metrics.compute(r, 1.0, 0.01) for r in x0]
    m = [metrics.compute(r, 1.0, p.dt, window=s.samples(500)) for r in x]
    assert [a.success for a in m] == [b.success for b in m0]
    assert [a.ts5 for a in m] == pytest.approx([b.ts5 for b in m0], abs=0.5, nan_ok=True)


def test_the_reward_counts_paper_metres() -> None:
    s = Scales(length=0.05)
    lr0, lr = packed(QConfig()), packed(QConfig().scaled(s))
    from msd_bench.core.learning.q_kernels import reward

    assert reward(lr, 0.5 * 0.05, 0.25 * 0.05) == pytest.approx(reward(lr0, 0.5, 0.25))


def test_a_run_config_on_a_rig_keeps_its_seconds_and_fractions() -> None:
    from msd_bench.app.config import RunConfig

    cfg = RunConfig()
    assert cfg.scaled(Scales.DEFAULT) is cfg and cfg.scenario_suite(Scales.DEFAULT) == cfg.scenario_suite()
    rig = cfg.scaled(Scales.of(20.0, 10.0, 0.004))  # 250 Hz, a 20 m stroke
    assert (rig.steps, rig.validation_steps, rig.window, rig.samples) == (7500, 7500, 1250, 30_000)
    assert rig.target == pytest.approx(4.0)
    assert [s.setpoint for s in cfg.scenario_suite(Scales(length=4.0))][:2] == pytest.approx([4.0, -6.0])
