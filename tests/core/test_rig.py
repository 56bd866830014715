"""The rig emulator's physics (core/rigs/rig.py): each imperfection alone, and none at all = the plant."""

from __future__ import annotations

import math
from dataclasses import asdict, replace

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.physics.plant import PRESETS, PlantParams, preset, simulate, step
from msd_bench.core.rigs.rig import Actuator, Rig, RigImperfections

NONE = RigImperfections.none()
DT = PlantParams().dt


def run(rig: Rig, commands: list[float] | np.ndarray) -> list:
    return [rig.step(float(u)) for u in commands]


@pytest.mark.parametrize("name", ["default", "rig"])
def test_all_imperfections_off_is_the_ideal_plant_bit_for_bit(name):
    params = preset(name)
    rng = np.random.default_rng(4)
    u = np.concatenate([rng.uniform(-14, 14, 300), np.full(100, 10.0), np.full(100, -10.0)])
    rows = run(Rig(params, NONE, seed=3), u)
    x, v, u_applied = simulate(u, params)
    assert np.array_equal([r.x for r in rows], x) and np.array_equal([r.v for r in rows], v)
    assert np.array_equal([r.measured for r in rows], x)  # ideal sensor: the true position
    assert np.array_equal([r.effort for r in rows], u_applied)
    xs, vs = 0.0, 0.0
    for r, uk in zip(rows, u, strict=True):
        xs, vs = step(xs, vs, uk, params)
        assert r.measured_next == xs
    assert np.max(np.abs(x)) > 1.0  # the run went somewhere: the comparison is not trivial


@pytest.mark.parametrize("delay", [0, 1, 3])
def test_actuator_delay_is_exactly_n_samples(delay):
    rig = Rig(PlantParams(), replace(NONE, delay_samples=delay))
    efforts = [r.effort for r in run(rig, [0.0] * 5 + [3.0] * 10)]
    assert efforts == [0.0] * (5 + delay) + [3.0] * (10 - delay)


def test_lag_time_constant_is_recovered_from_a_step_and_matches_the_continuous_lag():
    tau, u_step = 0.03, 4.0
    rig = Rig(PlantParams(), replace(NONE, actuator_tau=tau))
    e = np.array([r.effort for r in run(rig, [u_step] * 40)])
    gaps = u_step - e
    tau_hat = -DT / np.log(gaps[1:20] / gaps[:19])
    assert np.allclose(tau_hat, tau, rtol=1e-9)
    assert np.all(np.diff(e) > 0) and e[-1] < u_step  # rises monotonically, never overshoots
    # each sample's force is the mean of the continuous lag U(1 - e^{-t/tau}) over that sample
    for j in (0, 1, 5):
        t = np.linspace(j * DT, (j + 1) * DT, 200_001)
        assert abs(e[j] - np.mean(u_step * (1 - np.exp(-t / tau)))) < 1e-6


def test_lag_and_delay_compose_and_cut_empties_the_drive():
    act = Actuator(delay=2, tau=0.02, dt=DT)
    out = [act.apply(5.0) for _ in range(6)]
    assert out[:2] == [0.0, 0.0] and 0.0 < out[2] < out[3] < 5.0
    act.cut()
    assert [act.apply(5.0) for _ in range(2)] == [0.0, 0.0]  # nothing in flight, lag state 0


def test_friction_holds_the_mass_at_rest_below_fc_and_not_above():
    fc = 0.2
    held = run(Rig(PlantParams(), replace(NONE, friction=fc)), [0.19] * 200)
    assert all(r.x == 0.0 and r.v == 0.0 for r in held)
    moved = run(Rig(PlantParams(), replace(NONE, friction=fc)), [0.21] * 200)
    assert moved[-1].x > 1e-4
    free = run(Rig(PlantParams(), NONE), [0.21] * 200)
    assert moved[-1].x < free[-1].x  # friction takes 0.2 N of the 0.21 N


def test_friction_stops_a_moving_mass_without_reversing_it():
    rig = Rig(PlantParams(), replace(NONE, friction=3.0))
    rig.reset(x0=0.0, v0=0.5)
    rows = run(rig, [0.0] * 100)
    v = np.array([r.v for r in rows])
    assert np.all(v >= 0.0) and v[-1] == 0.0 and rows[-1].x > 0.0
    assert rows[-1].x == rows[-50].x  # held where it stopped (spring 2.4·sin x < 3 N there)


def test_saturation_to_the_force_limit_and_non_finite_refused():
    rig = Rig(PlantParams(), replace(NONE, actuator_tau=0.02))
    efforts = [r.effort for r in run(rig, [50.0] * 60 + [-50.0] * 60)]
    assert max(efforts) <= 10.0 and min(efforts) >= -10.0
    assert abs(efforts[59] - 10.0) < 1e-6 and abs(efforts[-1] + 10.0) < 1e-6
    with pytest.raises(InvalidInputError):
        rig.step(math.nan)


def test_measured_positions_lie_on_the_encoder_grid():
    q = 1e-4
    rig = Rig(PlantParams(), replace(NONE, sensor_noise=0.002, sensor_quant=q), seed=1)
    y = np.array([r.measured for r in run(rig, [6.0] * 300)])
    steps = y / q
    assert np.allclose(steps, np.round(steps), atol=1e-6) and len(set(np.round(steps))) > 50


def test_noise_standard_deviation_within_statistical_bounds():
    sigma, n = 0.002, 20_000
    rows = run(Rig(PlantParams(), replace(NONE, sensor_noise=sigma), seed=7), [0.0] * n)
    err = np.array([r.measured - r.x for r in rows])
    # std of a sample std is sigma/sqrt(2n) = 0.5 %: 3 % is six of those
    assert abs(err.std() / sigma - 1) < 0.03 and abs(err.mean()) < 5 * sigma / math.sqrt(n)


def test_velocity_is_estimated_from_measured_positions_never_the_truth():
    rig = Rig(PlantParams(), RigImperfections(), seed=2)
    rows = run(rig, [5.0] * 100)
    y = [r.measured for r in rows]
    assert rows[0].velocity == 0.0
    assert all(rows[k].velocity == (y[k] - y[k - 1]) / DT for k in range(1, 100))
    assert any(r.velocity != r.v for r in rows)


def test_seed_reproduces_noise_and_jitter_and_streams_differ():
    def trace(seed: int) -> tuple[list[float], list[float]]:
        rig = Rig(PlantParams(), RigImperfections(), seed=seed)
        ys = [r.measured for r in run(rig, [2.0] * 50)]
        return ys, [rig.publish_delay() for _ in range(50)]

    assert trace(5) == trace(5) and trace(5) != trace(6)
    delays = trace(5)[1]
    assert all(0.0 <= d < RigImperfections().jitter for d in delays) and len(set(delays)) == 50
    assert Rig(PlantParams(), NONE).publish_delay() == 0.0


def test_bad_imperfections_are_one_line_config_errors():
    with pytest.raises(ConfigError, match="jitter"):
        Rig(PlantParams(), replace(NONE, jitter=0.01))
    with pytest.raises(ConfigError, match="sensor noise_std"):
        replace(NONE, sensor_noise=-1.0)
    with pytest.raises(ConfigError, match="friction"):
        replace(NONE, friction=math.inf)
    with pytest.raises(ConfigError, match="delay_samples"):
        replace(NONE, delay_samples=-1)


def test_rig_preset_is_10_to_20_percent_off_the_default_in_m_c_k_h_only():
    default, rig = asdict(PRESETS["default"]), asdict(PRESETS["rig"])
    for name in ("m", "c", "k", "h"):
        assert 0.10 <= abs(rig[name] / default[name] - 1) <= 0.20, name
    assert all(rig[n] == default[n] for n in ("g", "L", "F", "dt"))  # the contract's F and dt
