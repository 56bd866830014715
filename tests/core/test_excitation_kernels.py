"""Excitation signals and the shared kernels (memberships, linear recursion)."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.identification import excitation as ex
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel


def test_prbs_is_seeded_binary_around_the_bias() -> None:
    cfg = ex.PrbsConfig(bias=5.0, amplitude=1.0, n_samples=2000, hold=10, settle=100)
    u = ex.prbs(cfg, seed=3)
    assert u.size == 2100
    assert np.all(u[:100] == 5.0)
    assert set(np.unique(u[100:])) == {4.0, 6.0}
    assert np.array_equal(u, ex.prbs(cfg, seed=3))
    assert not np.array_equal(u, ex.prbs(cfg, seed=4))
    # Each bit is held `hold` samples: changes only on multiples of hold.
    changes = np.flatnonzero(np.diff(u[100:])) + 1
    assert np.all(changes % 10 == 0)


def test_prbs_is_maximum_length() -> None:
    bits = ex.prbs_bits(2 * 1023, register_bits=10, seed=0)
    assert np.array_equal(bits[:1023], bits[1023:])
    assert all(not np.array_equal(bits[:1023], np.roll(bits[:1023], s)) for s in range(1, 50))
    # A maximum-length sequence has 512 ones and 511 zeros per period.
    assert int(np.sum(bits[:1023] == 1)) == 512


def test_multilevel_respects_levels_and_dwell_limits() -> None:
    cfg = ex.MultilevelConfig(n_samples=20_000, min_dwell=30, max_dwell=300)
    u = ex.multilevel(cfg, seed=1)
    assert u.size == 20_000
    assert set(np.unique(u)) == {-10.0, -5.0, 0.0, 5.0, 10.0}
    edges = np.flatnonzero(np.diff(u)) + 1
    dwells = np.diff(np.concatenate([[0], edges]))
    assert dwells.min() >= 30 and dwells.max() <= 300
    assert np.array_equal(u, ex.multilevel(cfg, seed=1))


def test_steps_and_config_errors() -> None:
    assert np.array_equal(ex.steps(ex.StepsConfig(levels=(1.0, 2.0), dwell=2)), [1, 1, 2, 2])
    with pytest.raises(ConfigError, match="min_dwell"):
        ex.MultilevelConfig(min_dwell=10, max_dwell=5)
    with pytest.raises(ConfigError, match="amplitude"):
        ex.PrbsConfig(amplitude=0.0)


@pytest.mark.parametrize(
    ("x", "expected"),
    [
        (-2.5, [1, 0, 0, 0, 0]),
        (-1.0, [0, 1, 0, 0, 0]),
        (0.0, [0, 0, 1, 0, 0]),
        (1.0, [0, 0, 0, 1, 0]),
        (2.0, [0, 0, 0, 0, 1]),
        (-1.25, [0.25, 0.5, 0, 0, 0]),
        (0.75, [0, 0, 0.25, 0.5, 0]),
        (1.25, [0, 0, 0, 0.5, 0.5]),
    ],
)
def test_memberships_as_printed(x: float, expected: list[float]) -> None:
    got = [kernels.membership(i, x) for i in range(5)]
    assert got == pytest.approx(expected, abs=1e-12)


def test_memberships_never_all_zero_on_the_stroke() -> None:
    xs = np.linspace(-2.5, 2.5, 5001)
    sums = np.array([sum(kernels.membership(i, x) for i in range(5)) for x in xs])
    assert sums.min() > 0.0


def test_linear_kernel_is_the_printed_recursion() -> None:
    n1, n2, d1, d2 = 0.02, 0.01, -1.5, 0.6
    model = StepModel(kernels.KIND_LINEAR, np.array([5.0, n1, n2, d1, d2, 0.0, 0.0]))
    u = np.random.default_rng(0).uniform(-1, 1, 200)
    y = model.simulate(u)
    ref = np.zeros(201)
    uu = np.concatenate([[0.0], u])
    for k in range(1, 201):
        ref[k] = n1 * uu[k] + n2 * uu[k - 1] - d1 * ref[k - 1] - d2 * (ref[k - 2] if k > 1 else 0.0)
    assert y == pytest.approx(ref[:200], abs=1e-12)
    assert model.predict_one_step(y, u)[2:] == pytest.approx(y[2:], abs=1e-12)


def test_model_outputs_are_projected_on_the_stroke() -> None:
    unstable = StepModel(kernels.KIND_LINEAR, np.array([5.0, 1.0, 0.0, -2.0, 1.1, 0.0, 0.0]))
    x = unstable.simulate(np.ones(500))
    assert np.all(np.abs(x) <= 2.5)
