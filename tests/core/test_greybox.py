"""Grey-box surrogate: known-truth recovery, noise, evaluation of a plant-structure model."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.excitation import MultilevelConfig
from msd_bench.core.identification.greybox import PARAM_NAMES, GreyboxConfig, equation_error_start, one_step
from msd_bench.core.identification.identify import broad_record, evaluate, free_run, identify_greybox
from msd_bench.core.physics import kernels, plant
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.sensor import SensorModel


@pytest.mark.parametrize("name", ["default", "mild"])
def test_noise_free_record_recovers_the_true_parameters(name):
    """Known truth: the plant is in the model class, so the fit must find it (within 1 %).

    Measured: every parameter within 1e-9 relative on both presets.
    """
    truth = plant.preset(name)
    train = broad_record(truth, 11)
    model = identify_greybox(train, GreyboxConfig(stroke=truth.L, force=truth.F))
    assert model.kind == kernels.KIND_PLANT and model.name == "greybox"
    fitted = model.info["parameters"]
    for p in PARAM_NAMES:
        assert fitted[p] == pytest.approx(getattr(truth, p), rel=0.01), p
    np.testing.assert_array_equal(model.params[5:], truth.as_array()[5:])  # L, F, dt are the known ones
    assert model.info["cost"] < 1e-12 and model.info["n_samples"] == 12_000


def test_equation_error_start_alone_is_close():
    """The start already lands within 2 % on clean data: the refinement only polishes."""
    truth = plant.preset("default")
    e = broad_record(truth, 11).experiments
    start = equation_error_start(e, truth.dt, GreyboxConfig())
    for got, p in zip(start, PARAM_NAMES, strict=True):
        assert got == pytest.approx(getattr(truth, p), rel=0.02), p


def test_two_mm_of_noise_costs_the_grey_box_almost_nothing():
    """2 mm sensor noise: parameters still within 1 %, simulation vs truth >= 99.9 %.

    Measured: worst parameter error 0.06 %, simulation fit vs truth 100.00 %.
    """
    truth = plant.preset("default")
    sensor = SensorModel(noise_std=0.002)
    train = broad_record(truth, 1007, sensor=sensor)
    valid = broad_record(truth, 5007, MultilevelConfig(n_samples=4000), sensor=sensor)
    model = identify_greybox(train)
    for p in PARAM_NAMES:
        assert model.info["parameters"][p] == pytest.approx(getattr(truth, p), rel=0.01), p
    report = evaluate(model, valid)
    assert report.sim_fit_truth is not None and report.sim_fit_truth > 99.9
    # Against the noisy measurement the fit is capped by the noise itself (same as the true plant).
    exact = evaluate(plant_model(truth), valid)
    assert report.sim_fit == pytest.approx(exact.sim_fit, abs=0.05)


def test_estimated_start_beats_the_raw_start_for_the_exact_plant_under_noise():
    """Why evaluation estimates the initial state: two noisy samples give a 0.28 m/s velocity error."""
    truth = plant.preset("default")
    valid = broad_record(truth, 5017, MultilevelConfig(n_samples=4000), SensorModel(noise_std=0.002))
    exact = plant_model(truth)
    e = valid.experiments[0]
    err_est = free_run(exact, e) - e.y_true
    err_raw = free_run(exact, e, "measured") - e.y_true
    assert np.sqrt(np.mean(err_est[:300] ** 2)) < 0.5 * np.sqrt(np.mean(err_raw[:300] ** 2))
    report = evaluate(exact, valid)
    assert report.sim_fit_truth is not None and report.sim_fit_truth > 99.9


def test_plant_one_step_is_exact_away_from_the_stops():
    truth = plant.preset("default")
    e = broad_record(truth, 3, MultilevelConfig(n_samples=3000)).experiments[0]
    yhat = one_step(truth.as_array(), e.y, e.u)
    inside = np.abs(e.y) < truth.x_max - 1e-9
    ok = inside[2:] & inside[1:-1] & inside[:-2]
    np.testing.assert_allclose(yhat[2:][ok], e.y[2:][ok], atol=1e-12)
    np.testing.assert_array_equal(yhat[:2], e.y[:2])


def test_record_at_the_stops_or_constant_is_rejected():
    dt = 0.01
    at_stop = IOData.single(np.full(500, 10.0), np.full(500, 2.5), dt)
    with pytest.raises(IdentificationError, match="hard stops"):
        identify_greybox(at_stop)
    rest = IOData.single(np.zeros(500), np.zeros(500), dt)
    with pytest.raises(IdentificationError, match="no excitation"):
        identify_greybox(rest)


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [("stroke", 0.0, "stroke"), ("force", -1.0, "force"), ("max_nfev", 0, "max_nfev"),
     ("g_range", (2.0, 1.0), "g_range"), ("filter_hz", float("nan"), "filter_hz")],
)
def test_bad_config_is_rejected(field, value, match):
    with pytest.raises(ConfigError, match=match):
        GreyboxConfig(**{field: value})
