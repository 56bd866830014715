"""Known-truth tests of the second-order output-error fit (msd_bench.core.identification.linear)."""

from __future__ import annotations

import control
import numpy as np
import pytest
from scipy.signal import lfilter, lfiltic

from msd_bench.core.errors import IdentificationError, InvalidInputError
from msd_bench.core.identification.data import Experiment
from msd_bench.core.identification.excitation import PrbsConfig, prbs
from msd_bench.core.identification.linear import LinearFit, arx_fit, oe_fit, simulate_deviation
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel

DT = 0.01
# Poles 0.985 ± 0.06j (|z| = 0.987): lightly damped, close to 1 like the plant's.
TRUE = (1.0e-4, 0.5e-4, -1.97, 0.9737)


def _record(theta, u0=0.0, y0=0.0, seed=3, noise=0.0, hold=20, y_init=(0.0, 0.0)):
    n1, n2, d1, d2 = theta
    u = prbs(PrbsConfig(bias=u0, settle=0, hold=hold), seed)
    du = u - u0
    zi = lfiltic([0.0, n1, n2], [1.0, d1, d2], y=[y_init[1], y_init[0]], x=[0.0, 0.0])
    y = y0 + lfilter([0.0, n1, n2], [1.0, d1, d2], du, zi=zi)[0]
    rng = np.random.default_rng(seed + 100)
    y_meas = y + noise * np.std(y) * rng.standard_normal(y.size)
    return Experiment(u, y_meas), y


def test_noiseless_recovery_is_exact():
    exp, _ = _record(TRUE)
    fit = oe_fit([exp], 0.0, 0.0, DT)
    np.testing.assert_allclose(fit.coefficients, TRUE, rtol=1e-7, atol=1e-12)
    assert fit.method == "oe" and fit.is_stable


def test_small_output_noise_recovery():
    exp, _ = _record(TRUE, noise=1e-3)
    fit = oe_fit([exp], 0.0, 0.0, DT)
    np.testing.assert_allclose([fit.d1, fit.d2], TRUE[2:], atol=2e-5)
    np.testing.assert_allclose([fit.n1, fit.n2], TRUE[:2], rtol=0.03)
    true_gain = (TRUE[0] + TRUE[1]) / (1 + TRUE[2] + TRUE[3])
    assert fit.dc_gain == pytest.approx(true_gain, rel=5e-3)


def test_output_error_beats_arx_under_noise():
    """Why the refinement exists: with poles near 1 ARX is biased by output noise."""
    exp, _ = _record(TRUE, noise=0.01)
    oe = oe_fit([exp], 0.0, 0.0, DT)
    arx = arx_fit([exp], 0.0, 0.0, DT)
    err = lambda f: abs(f.d1 - TRUE[2]) + abs(f.d2 - TRUE[3])  # noqa: E731
    assert err(oe) < 1e-4
    assert err(arx) > 10 * err(oe)


def test_operating_point_and_joint_experiments_with_own_initial_conditions():
    """Two experiments, not starting at rest, around (u0, y0) = (5, 1.3): fitted jointly."""
    a, _ = _record(TRUE, u0=5.0, y0=1.3, seed=1, y_init=(0.02, 0.018))
    b, _ = _record(TRUE, u0=5.0, y0=1.3, seed=2, y_init=(-0.03, -0.029))
    fit = oe_fit([a, b], 5.0, 1.3, DT)
    np.testing.assert_allclose(fit.coefficients, TRUE, rtol=1e-7, atol=1e-12)
    assert (fit.u0, fit.y0) == (5.0, 1.3)


def test_offset_is_estimated_from_a_wrong_guess():
    exp, _ = _record(TRUE, u0=5.0, y0=1.3)
    fit = oe_fit([exp], 5.0, 1.0, DT, fit_offset=True)
    assert fit.y0 == pytest.approx(1.3, abs=1e-9)
    np.testing.assert_allclose(fit.coefficients, TRUE, rtol=1e-6, atol=1e-12)


def test_kernel_free_run_matches_lfilter_simulation():
    exp, _ = _record(TRUE, u0=2.0, y0=0.7)
    fit = LinearFit(*TRUE, 2.0, 0.7, DT)
    model = StepModel(kernels.KIND_LINEAR, fit.to_params(100.0))
    state = np.array([exp.y[1], exp.y[0], exp.u[0], 0.0])
    kernel = np.concatenate([exp.y[:1], model.simulate(exp.u[1:], state)])
    np.testing.assert_allclose(kernel, simulate_deviation(np.array(TRUE), exp, 2.0, 0.7), atol=1e-12)


def test_discrete_transfer_function():
    tf = LinearFit(*TRUE, 0.0, 0.0, DT).to_transfer_function()
    assert tf.dt == DT
    np.testing.assert_allclose(np.ravel(tf.num[0][0]), TRUE[:2])
    np.testing.assert_allclose(np.ravel(tf.den[0][0]), [1.0, *TRUE[2:]])


def test_continuous_equivalent_inverts_zoh():
    """2/(s^2 + 0.5 s + 4) -> ZOH at 0.01 s -> back: the original coefficients."""
    ct = control.tf([2.0], [1.0, 0.5, 4.0])
    dt_tf = control.c2d(ct, DT, "zoh")
    num, den = np.ravel(dt_tf.num[0][0]), np.ravel(dt_tf.den[0][0])
    fit = LinearFit(num[0] / den[0], num[1] / den[0], den[1] / den[0], den[2] / den[0], 0.0, 0.0, DT)
    back = fit.to_continuous()
    np.testing.assert_allclose(np.ravel(back.den[0][0]), [1.0, 0.5, 4.0], rtol=1e-8)
    np.testing.assert_allclose(np.ravel(back.num[0][0]), [0.0, 2.0], atol=1e-7)
    again = control.c2d(back, DT, "zoh")
    np.testing.assert_allclose(np.ravel(again.den[0][0]), den / den[0], rtol=1e-10)


def test_negative_real_pole_has_no_continuous_equivalent():
    fit = LinearFit(1.0, 0.0, 0.5, 0.06, 0.0, 0.0, DT)  # poles -0.2 and -0.3
    with pytest.raises(IdentificationError, match="continuous-time"):
        fit.to_continuous()


def test_constant_input_is_rejected():
    exp = Experiment(np.zeros(200), np.zeros(200))
    with pytest.raises(IdentificationError, match="no excitation"):
        oe_fit([exp], 0.0, 0.0, DT)


def test_too_short_and_empty_inputs_are_rejected():
    with pytest.raises(InvalidInputError, match="at least one"):
        oe_fit([], 0.0, 0.0, DT)
    with pytest.raises(InvalidInputError, match="too short"):
        oe_fit([Experiment(np.arange(5.0), np.arange(5.0))], 0.0, 0.0, DT)


def test_never_returns_an_unstable_model():
    """Data from an unstable system: the refinement ends unstable, the stabilised ARX start is kept."""
    theta = (1e-3, 0.0, -(1.01 + 0.95), 1.01 * 0.95)  # poles 1.01 and 0.95
    exp, _ = _record(theta, hold=5)
    exp = Experiment(exp.u[:400], exp.y[:400])
    assert not arx_fit([exp], 0.0, 0.0, DT).is_stable
    fit = oe_fit([exp], 0.0, 0.0, DT)
    assert fit.is_stable and fit.method == "arx"
