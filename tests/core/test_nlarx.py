"""NLARX: torch/kernel agreement, fits on plant data, determinism, bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.excitation import MultilevelConfig, multilevel
from msd_bench.core.identification.identify import broad_record, evaluate, identify_nlarx, naive_one_step_fits
from msd_bench.core.identification.nlarx import NlarxConfig, NlarxNet, fit_nlarx
from msd_bench.core.physics import kernels, plant
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.sensor import SensorModel

DEFAULT = plant.preset("default")


@pytest.fixture(scope="module")
def records() -> tuple[IOData, IOData]:
    return broad_record(DEFAULT, seed=1), broad_record(DEFAULT, seed=2)


@pytest.mark.parametrize("improved", [False, True])
def test_torch_forward_equals_kernel(improved):
    gen = torch.Generator().manual_seed(7)
    net = NlarxNet(6, improved, delta=0.02, eps=3e-4, gen=gen)
    with torch.no_grad():  # perturb every raw parameter so no weight is trivially zero
        for p in net.parameters():
            p.add_(0.3 * torch.randn(p.shape, generator=gen, dtype=torch.float64))
    xs, us = 1.4, 7.0
    params = net.kernel_params(1e6, xs, us)  # a huge stroke: the kernel's clip never bites
    assert params.size == kernels.NLARX_HEAD + 6 * kernels.NLARX_UNIT
    rng = np.random.default_rng(0)
    for _ in range(200):
        x, xp = rng.uniform(-2.5, 2.5, 2)
        u, up = rng.uniform(-10, 10, 2)
        phi = torch.tensor([[x / xs, xp / xs, u / us, up / us]], dtype=torch.float64)
        with torch.no_grad():
            want = xs * float(net(phi)[0])
        model = kernels.Kernel(kernels.KIND_NLARX, params, 10.0)
        got = kernels.advance(model, np.array([x, xp, up, 0.0]), u)
        assert got == pytest.approx(want, abs=1e-9)
    if not improved:
        np.testing.assert_array_equal(params[5:9], 0.0)  # paper form: no linear term


def test_paper_form_one_step_fit_beats_repeating_the_last_sample_but_says_little(records):
    """The paper form's one-step fit (measured 99.80-99.83 % over seeds 0-2) beats repeating the
    last sample (98.33 %; error ratio about 0.11) but not constant-velocity extrapolation (99.90 %),
    while its free run is poor (-33 to +1 %): a one-step number alone means nothing here."""
    train, valid = records
    model = identify_nlarx(train, NlarxConfig(form="paper", seed=0))
    report = evaluate(model, valid)
    assert model.name == "nlarx-paper" and model.info["form"] == "paper"
    np.testing.assert_array_equal(model.params[5:9], 0.0)
    last_error = 100.0 - naive_one_step_fits(valid)["last_sample"]
    assert 100.0 - report.one_step_fit < 0.3 * last_error
    # The paper form's known weakness (docs/decisions.md §NLARX): free run is far worse than one step.
    assert report.sim_fit < report.one_step_fit - 5.0


def test_improved_form_simulation_fit(records):
    """Measured 97.8-99.3 % over seeds 0-3 on the default plant; floor set below that."""
    train, valid = records
    model = identify_nlarx(train, NlarxConfig(form="improved", seed=0))
    report = evaluate(model, valid)
    assert report.sim_fit > 95.0
    # One-step floor relative to constant-velocity extrapolation on the same record (99.90 %):
    # measured error ratio about 0.03.
    cv_error = 100.0 - naive_one_step_fits(valid)["constant_velocity"]
    assert 100.0 - report.one_step_fit < 0.1 * cv_error
    assert model.info["n_samples"] == 12_000


def _small() -> IOData:
    return broad_record(DEFAULT, seed=3, cfg=MultilevelConfig(n_samples=1500))


def test_same_seed_same_params_different_seed_different_params():
    cfg = NlarxConfig(form="improved", units=4, one_step_iters=20, sim_iters=5, horizon=30, batch=8)
    exps = _small().experiments
    a, _ = fit_nlarx(exps, 5.0, cfg)
    b, _ = fit_nlarx(exps, 5.0, cfg)
    c, _ = fit_nlarx(exps, 5.0, NlarxConfig(**{**cfg.__dict__, "seed": 1}))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_constant_record_is_rejected():
    data = IOData.single(np.zeros(500), np.zeros(500))
    with pytest.raises(IdentificationError, match="both force and position vary"):
        identify_nlarx(data, NlarxConfig(one_step_iters=5))


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [("form", "deep", "form must be one of"), ("units", 0, "units must be >= 1"), ("lr", 0.0, "lr > 0"),
     ("prefilter_hz", -1.0, "prefilter_hz"), ("prefilter_above", float("nan"), "prefilter_above")],
)
def test_bad_config_is_rejected(field, value, match):
    with pytest.raises(ConfigError, match=match):
        NlarxConfig(**{field: value})


# --- known truth: a record made by a system of the NLARX's own structure -------------------------

_DT, _M, _C, _K = 0.01, 1.0, 1.0, 2.0
_SPRING = ((2.0, 2.0, 0.0), (1.5, 3.0, -2.0), (1.0, 1.5, 1.5))
"""(a, b, e) of the spring's sigmoid terms a·sigmoid(b x + e): increasing in x, so restoring."""


def _true_nlarx(stroke: float = 20.0) -> StepModel:
    """``m x'' = u - c x' - K x - Σ a σ(b x + e)`` Euler-discretised: exactly the KIND_NLARX layout.

    x_{k+1} = (2 - dt c/m - dt² K/m) x_k - (1 - dt c/m) x_{k-1} + dt²/m u_k - dt²/m Σ a σ(b x_k + e),
    with x_scale 1 and u_scale 5, three sigmoid units, no u_{k-1} term.
    """
    xs, us = 1.0, 5.0
    w = [2 - _DT * _C / _M - _DT**2 * _K / _M, -(1 - _DT * _C / _M), _DT**2 / _M * us / xs, 0.0]
    units: list[float] = []
    for a, b, e in _SPRING:
        units += [-(_DT**2) / _M * a / xs, b * xs, 0.0, 0.0, 0.0, e]
    return StepModel(kernels.KIND_NLARX, np.array([stroke, len(_SPRING), xs, us, 0.0, *w, *units]))


def _record_of(model: StepModel, seed: int, n: int) -> IOData:
    u = multilevel(MultilevelConfig(n_samples=n), seed)
    return IOData.single(u, model.simulate(u))


def test_nlarx_recovers_a_system_of_its_own_structure():
    """Known truth: trained on 6,000 samples of a 3-unit NLARX system, the improved form with 3 units
    reproduces a fresh validation record to >= 99 % in free run (measured 99.68 %) and its one-step
    error is below 5 % of constant-velocity extrapolation's (measured < 0.2 %). Weights are not
    compared: sigmoid networks are identifiable only up to permutation and sign symmetries."""
    truth = _true_nlarx()
    train, valid = _record_of(truth, 21, 6000), _record_of(truth, 22, 4000)
    assert np.ptp(train.experiments[0].y) > 5.0  # the record spans the sigmoids' curved range
    cfg = NlarxConfig(form="improved", seed=0, units=3, sim_iters=40)
    report = evaluate(identify_nlarx(train, cfg, stroke=20.0), valid)
    cv_error = 100.0 - naive_one_step_fits(valid)["constant_velocity"]
    assert report.sim_fit >= 99.0
    assert 100.0 - report.one_step_fit < 0.05 * cv_error


# --- a 2 mm sensor ----------------------------------------------------------------------------------


def test_improved_nlarx_survives_two_mm_of_sensor_noise():
    """Records of identification seed 0 (excitation seeds as the pipeline's) measured with 2 mm noise;
    scored against the noise-free truth from an estimated initial state. Floor 93 % (issue 11).

    Measured over identification seeds 0, 1, 2: 97.24, 96.80, 99.27 % (clean: 97.45, 97.66, 99.04);
    without the prefilter the same records gave 65.6, 67.9, 68.2 %.
    """
    sensor = SensorModel(noise_std=0.002)
    train = broad_record(DEFAULT, 1007, sensor=sensor)
    valid = broad_record(DEFAULT, 5007, MultilevelConfig(n_samples=4000), sensor=sensor)
    model = identify_nlarx(train, NlarxConfig(form="improved", seed=0))
    assert model.info["prefilter_hz"] > 0 and model.info["noise_ratio"] > 0.5
    report = evaluate(model, valid)
    assert report.sim_fit_truth is not None and report.sim_fit_truth >= 93.0


def test_noise_free_records_are_not_prefiltered(records):
    """The prefilter switches on with noise only, so clean-record fits are those of the raw method."""
    train, _ = records
    model = identify_nlarx(train, NlarxConfig(form="improved", seed=0, one_step_iters=5, sim_iters=0))
    assert model.info["prefilter_hz"] == 0.0 and model.info["noise_ratio"] < 0.02
