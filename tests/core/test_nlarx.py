"""NLARX: torch/kernel agreement, fits on plant data, determinism, bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from msd_bench.core import kernels, plant
from msd_bench.core.data import IOData
from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.excitation import MultilevelConfig
from msd_bench.core.identify import broad_record, evaluate, identify_nlarx
from msd_bench.core.nlarx import NlarxConfig, NlarxNet, fit_nlarx

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


def test_paper_form_one_step_fit_is_excellent(records):
    train, valid = records
    model = identify_nlarx(train, NlarxConfig(form="paper", seed=0))
    report = evaluate(model, valid)
    assert model.name == "nlarx-paper" and model.info["form"] == "paper"
    np.testing.assert_array_equal(model.params[5:9], 0.0)
    assert report.one_step_fit > 99.0
    # The paper form's known weakness (docs/decisions.md §NLARX): free run is far worse than one step.
    assert report.sim_fit < report.one_step_fit - 5.0


def test_improved_form_simulation_fit(records):
    """Measured 97.8-99.3 % over seeds 0-3 on the default plant; floor set below that."""
    train, valid = records
    model = identify_nlarx(train, NlarxConfig(form="improved", seed=0))
    report = evaluate(model, valid)
    assert report.sim_fit > 95.0
    assert report.one_step_fit > 99.9
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
    [("form", "deep", "form must be one of"), ("units", 0, "units must be >= 1"), ("lr", 0.0, "lr > 0")],
)
def test_bad_config_is_rejected(field, value, match):
    with pytest.raises(ConfigError, match=match):
        NlarxConfig(**{field: value})
