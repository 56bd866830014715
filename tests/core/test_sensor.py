"""The sensor model (noise then quantisation), velocity estimates and noise-aware helpers."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.identification.excitation import MultilevelConfig
from msd_bench.core.identification.identify import bias_record, broad_record
from msd_bench.core.physics import plant
from msd_bench.core.physics.sensor import (
    SensorModel,
    VelocityEstimator,
    clear_of_stops,
    lowpass,
    noise_level,
    sensor_rng,
    velocity_estimate,
)

DEFAULT = plant.preset("default")


def test_ideal_sensor_is_the_identity_and_draws_nothing():
    x = np.linspace(-2.0, 2.0, 101)
    rng = np.random.default_rng(3)
    before = rng.bit_generator.state
    y = SensorModel().measure(x, rng)
    np.testing.assert_array_equal(y, x)
    assert y is not x  # a new array: the caller's truth is never aliased
    assert rng.bit_generator.state == before
    assert SensorModel().is_ideal and not SensorModel(noise_std=1e-3).is_ideal


def test_noise_has_the_requested_spread_and_no_bias():
    x = np.zeros(40_000)
    y = SensorModel(noise_std=0.002).measure(x, np.random.default_rng(0))
    # Sample sd of 40,000 normals is within 1.5 % of sigma with probability > 0.999.
    assert np.std(y) == pytest.approx(0.002, rel=0.015)
    assert abs(np.mean(y)) < 4 * 0.002 / np.sqrt(y.size)


def test_quantisation_rounds_to_the_grid_after_the_noise():
    x = np.random.default_rng(1).uniform(-2.0, 2.0, 5000)
    q = 0.001
    y = SensorModel(quant=q).measure(x, np.random.default_rng(2))
    np.testing.assert_allclose(y / q, np.round(y / q), atol=1e-9)
    assert np.max(np.abs(y - x)) <= q / 2 + 1e-12
    # Noise first, then the grid: outputs are still on the grid and within noise + q/2.
    yn = SensorModel(noise_std=0.002, quant=q).measure(x, np.random.default_rng(2))
    np.testing.assert_allclose(yn / q, np.round(yn / q), atol=1e-9)
    noise_only = SensorModel(noise_std=0.002).measure(x, np.random.default_rng(2))
    assert np.max(np.abs(yn - noise_only)) <= q / 2 + 1e-12


def test_per_sample_form_reproduces_the_array_form_bit_for_bit():
    """A node measuring sample by sample makes the same record as the in-process path."""
    x = np.sin(np.linspace(0, 10, 500))
    sensor = SensorModel(noise_std=0.002, quant=0.0005)
    whole = sensor.measure(x, sensor_rng(42))
    rng = sensor_rng(42)
    one_by_one = np.array([sensor.measure_one(float(v), rng) for v in x])
    np.testing.assert_array_equal(one_by_one, whole)


def test_sensor_stream_differs_from_the_excitation_stream():
    """The multilevel draws use default_rng(seed); the noise must not reuse that stream."""
    a = np.random.default_rng(7).standard_normal(100)
    b = sensor_rng(7).standard_normal(100)
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.4
    assert not np.allclose(a, b)


@pytest.mark.parametrize(
    ("noise", "quant"), [(-1e-3, 0.0), (0.0, -1.0), (float("nan"), 0.0), (0.0, float("inf"))]
)
def test_bad_sensor_settings_are_config_errors(noise, quant):
    with pytest.raises(ConfigError, match="sensor"):
        SensorModel(noise_std=noise, quant=quant)


def test_velocity_estimate_is_the_backward_difference():
    dt = 0.01
    x = 0.3 + 1.5 * dt * np.arange(50)  # constant velocity 1.5 m/s
    v = velocity_estimate(x, dt)
    assert v[0] == 0.0
    np.testing.assert_allclose(v[1:], 1.5, rtol=1e-9)
    est = VelocityEstimator(dt)
    np.testing.assert_array_equal([est.update(float(xi)) for xi in x], v)
    est.reset()
    assert est.update(5.0) == 0.0
    with pytest.raises(InvalidInputError, match="dt"):
        velocity_estimate(x, 0.0)
    with pytest.raises(InvalidInputError, match="dt"):
        VelocityEstimator(-1.0)


def test_velocity_estimate_under_noise_is_far_from_the_truth():
    """Why a node must say it estimates: 2 mm at 10 ms is 0.28 m/s of velocity noise."""
    rec = broad_record(DEFAULT, 3, MultilevelConfig(n_samples=4000), SensorModel(noise_std=0.002))
    e = rec.experiments[0]
    _, v_true, _ = plant.simulate(e.u, DEFAULT)
    err = velocity_estimate(e.y, DEFAULT.dt)[1:] - v_true[1:]
    assert np.std(err) == pytest.approx(np.sqrt(2) * 0.002 / DEFAULT.dt, rel=0.1)


def test_noisy_records_keep_the_truth_and_are_seeded():
    sensor = SensorModel(noise_std=0.002)
    clean = bias_record(DEFAULT, 5.0, seed=4)
    noisy = bias_record(DEFAULT, 5.0, seed=4, sensor=sensor)
    again = bias_record(DEFAULT, 5.0, seed=4, sensor=sensor)
    other = bias_record(DEFAULT, 5.0, seed=4, sensor=sensor, sensor_seed=5)
    c, n = clean.experiments[0], noisy.experiments[0]
    np.testing.assert_array_equal(n.y_true, c.y)  # truth = the noise-free record
    np.testing.assert_array_equal(c.y_true, c.y)  # a clean emulated record carries its truth too
    np.testing.assert_array_equal(n.u, c.u)
    assert np.std(n.y - c.y) == pytest.approx(0.002, rel=0.05)
    np.testing.assert_array_equal(again.experiments[0].y, n.y)
    assert not np.array_equal(other.experiments[0].y, n.y)
    assert noisy.meta["sensor"] == {"noise_std": 0.002, "quant": 0.0, "seed": 4}
    assert "sensor" not in clean.meta
    assert noisy.has_truth
    np.testing.assert_array_equal(noisy.noise_free().experiments[0].y, c.y)


def test_noise_level_estimate():
    x = broad_record(DEFAULT, 3, MultilevelConfig(n_samples=6000)).experiments[0].y
    assert noise_level(x) < 1e-5  # a noise-free plant record
    for sigma in (1e-4, 2e-3):
        y = SensorModel(noise_std=sigma).measure(x, np.random.default_rng(9))
        assert noise_level(y) == pytest.approx(sigma, rel=0.1)


def test_clear_of_stops_masks_contacts_and_their_neighbourhood():
    y = np.zeros(200)
    y[100:110] = 2.5  # at the upper stop of a 5 m stroke
    assert not clear_of_stops(y, 5.0)[100:110].any() and clear_of_stops(y, 5.0)[:100].all()
    wide = clear_of_stops(y, 5.0, reach=20)
    assert not wide[80:130].any() and wide[:80].all() and wide[130:].all()


def test_lowpass_has_no_lag_and_removes_noise():
    dt = 0.01
    t = np.arange(3000) * dt
    x = np.sin(2 * np.pi * 0.3 * t)
    y = x + 0.002 * np.random.default_rng(4).standard_normal(t.size)
    f = lowpass(y, dt, 4.0)
    inner = slice(200, -200)
    assert np.std((f - x)[inner]) < 0.35 * 0.002  # about sqrt(4/50) of the noise is left
    np.testing.assert_array_equal(lowpass(y, dt, 60.0), y)  # cut-off above Nyquist: unchanged
