"""The population of rigs: a stated distribution, one rig per seed, and one transition everywhere."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.closed_loop import greedy_under, nominal
from msd_bench.core.learning.qconfig import improved_config, packed
from msd_bench.core.learning.qtrain import train
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PRESETS
from msd_bench.core.rigs import population
from msd_bench.core.rigs.population import DESIGN_RIGS, DISTRIBUTION, EMULATOR_SEED, HELD_OUT_RIGS, draw
from msd_bench.core.rigs.rig import Rig, RigImperfections

SPECS = [draw(s) for s in range(1, 401)]
CFG = improved_config(episodes=20, steps=3000)


def test_the_emulators_defaults_are_the_reserved_member():
    spec = draw(EMULATOR_SEED)
    assert spec.params == PRESETS["rig"] and spec.imperfections == RigImperfections()


def test_a_seed_names_one_rig_and_seeds_differ():
    assert draw(17) == draw(17)
    assert draw(17) != draw(18)
    assert len({s.params for s in SPECS}) == len(SPECS)


def test_every_draw_lies_in_the_stated_ranges_and_covers_them():
    lo, hi = DISTRIBUTION.multiplier
    mult = np.array([list(s.multipliers().values()) for s in SPECS])
    assert mult.min() >= lo and mult.max() <= hi
    assert mult.min() < 0.82 and mult.max() > 1.22  # the ends are reached
    imp = [s.imperfections for s in SPECS]
    fric = np.array([i.friction for i in imp])
    lag = np.array([i.actuator_tau for i in imp])
    noise = np.array([i.sensor_noise for i in imp])
    assert 0.0 <= fric.min() < 0.05 and 0.45 < fric.max() <= 0.5
    assert 0.0 <= lag.min() < 0.004 and 0.036 < lag.max() <= 0.04
    assert 0.0 <= noise.min() < 3e-4 and 2.7e-3 < noise.max() <= 3e-3
    assert {i.delay_samples for i in imp} == {0, 1, 2}
    assert {i.sensor_quant for i in imp} == {0.0, 1e-4, 5e-4}
    assert {i.jitter for i in imp} == {0.002}
    for s in SPECS:  # g, the stroke, the force limit and dt are the owner's contract
        d = PRESETS["default"]
        assert (s.params.g, s.params.L, s.params.F, s.params.dt) == (d.g, d.L, d.F, d.dt)


def test_multipliers_are_drawn_independently_so_directions_mix():
    mult = np.array([list(s.multipliers().values()) for s in SPECS])
    up = mult > 1.0
    mixed = np.mean(up.any(axis=1) & (~up).any(axis=1))
    assert mixed > 0.8  # all-up or all-down would be 1/8 of rigs each if independent
    corr = np.corrcoef(np.log(mult).T)
    assert np.all(np.abs(corr[np.triu_indices(4, 1)]) < 0.2)


def test_design_and_held_out_ranges_are_disjoint_and_exclude_the_reserved_seed():
    assert not set(DESIGN_RIGS) & set(HELD_OUT_RIGS)
    assert EMULATOR_SEED not in DESIGN_RIGS and EMULATOR_SEED not in HELD_OUT_RIGS


@pytest.mark.parametrize("bad", [-1, 2**31, 1.5, "3", True, None])
def test_a_bad_seed_is_one_line(bad):
    with pytest.raises(ConfigError) as err:
        draw(bad)
    assert "rig seed" in str(err.value) and "\n" not in str(err.value)


def test_the_line_prints_every_parameter():
    spec = draw(1234)
    line = spec.line()
    p, i = spec.params, spec.imperfections
    assert "\n" not in line and line.startswith("rig 1234: ")
    for text in (f"m={p.m:.4g}", f"c={p.c:.4g}", f"k={p.k:.4g}", f"h={p.h:.4g}", f"g={p.g:g}",
                 f"L={p.L:g}", f"F={p.F:g}", f"dt={p.dt:g}", f"friction {i.friction:.3f} N",
                 f"delay {i.delay_samples} samples", f"lag {i.actuator_tau * 1e3:.1f} ms",
                 f"noise {i.sensor_noise * 1e3:.2f} mm", "quantisation", "jitter 2 ms"):
        assert text in line


@pytest.fixture(scope="module")
def table():
    """A briefly trained greedy table: its commands change with the state, so a run is not trivial."""
    return train(plant_model(PRESETS["default"]), CFG, [3]).q


@pytest.mark.parametrize(("seed", "offset"), [(EMULATOR_SEED, 0.0), (3, 0.0), (3, -0.8), (1001, 0.0)])
def test_the_node_rig_and_the_compiled_loop_are_one_transition_bit_for_bit(seed, offset, table):
    spec = draw(seed)
    if seed == 3:  # make sure one case has every imperfection on at once (and one an offset force too)
        spec = replace(spec, imperfections=replace(spec.imperfections, delay_samples=2, sensor_quant=1e-4,
                                                   sensor_noise=0.002, actuator_tau=0.03, friction=0.3,
                                                   offset=offset))
    steps, noise_seed = 600, 7
    lr = packed(CFG)
    kernel = plant_model(spec.params).kernel
    xs, us = greedy_under(kernel, lr, table, population.conditions(spec, 1.0),
                          population.measurement_noise(spec, [noise_seed], steps), kernel)
    rig = Rig(spec.params, spec.imperfections, seed=noise_seed)
    rows = [rig.step(u) for u in us[0]]
    assert np.array_equal([r.x for r in rows], xs[0])
    assert len(set(us[0].tolist())) >= 3 and np.ptp(xs[0]) > 0.05  # not a trivial run


def test_an_offset_force_moves_a_resting_rig_only_past_its_friction():
    """The offset acts at every sample whatever the drive does: held by friction when it is smaller,
    pushing the mass towards the stop when it is larger (a stage's unbalanced axis)."""
    spec = draw(3)
    held = Rig(spec.params, replace(spec.imperfections, friction=0.5, offset=0.4, sensor_noise=0.0))
    pushed = Rig(spec.params, replace(spec.imperfections, friction=0.5, offset=-3.0, sensor_noise=0.0))
    for _ in range(300):
        held.step(0.0), pushed.step(0.0)
    assert held.x == 0.0 and pushed.x < -0.5
    assert population.conditions(replace(spec, imperfections=pushed.imperfections), 1.0).offset == -3.0


def test_a_rig_without_imperfections_validates_as_the_nominal_loop():
    spec = replace(draw(5), imperfections=RigImperfections.none())
    assert population.conditions(spec, 1.0) == nominal(1.0)
    assert not population.measurement_noise(spec, [1, 2], 10).any()


def test_a_baselines_rollout_runs_the_rig_transition_too() -> None:
    """The one closed loop with a PID's decision is the rig node's run of the PID, sample for sample."""
    from pathlib import Path

    from msd_bench.core.baselines import designs
    from msd_bench.io.storage.artifacts import load_model

    spec = draw(1002)
    imp = replace(spec.imperfections, delay_samples=2, actuator_tau=0.03, friction=0.25,
                  sensor_noise=0.0, sensor_quant=0.0)
    spec = replace(spec, imperfections=imp)
    glm = load_model(Path(__file__).resolve().parents[1] / "data" / "pinned" / "glm.json")
    d = designs.make("pid", glm, 1.0, spec.params.F, spec.params.dt)
    cond = population.conditions(spec, 1.0)
    xs, us = designs.entry("pid").rollout(plant_model(spec.params).kernel, d, cond, np.zeros((1, 400)))
    rig, ctl = Rig(spec.params, imp), designs.entry("pid").controller(d)
    ctl.reset()
    y, seen = 0.0, []
    for _ in range(400):
        u = ctl.act(y)
        row = rig.step(u)
        seen.append((row.x, u))
        y = row.measured_next
    assert np.array_equal(xs[0], [x for x, _ in seen]) and np.array_equal(us[0], [u for _, u in seen])
    assert np.ptp(xs) > 0.05
