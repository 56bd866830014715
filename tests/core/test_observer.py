"""The robust agent's model observer, by hand: assumed actuator delay, velocity share, drift correction,
force bias."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.learning import q_kernels as qlearning
from msd_bench.core.learning.qconfig import improved_config, packed
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams

PLANT = plant_model(PlantParams())
# A damped ARX double integrator in deviation form [L, n1, n2, d1, d2, u0, y0].
ARX = StepModel(kernels.KIND_LINEAR, np.array([5.0, 5e-5, 5e-5, -1.975, 0.9802, 0.0, 0.0]), "arx")
STATIC = StepModel(kernels.KIND_LINEAR, np.array([5.0, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0]), "static")


def _observe_run(model: StepModel, ys: list[float], us: list[float],
                 **cfg: object) -> list[tuple[float, float]]:
    """The observer's estimates over measurements ``ys`` under commanded forces ``us``."""
    lr = packed(improved_config(observer="model", **cfg))  # type: ignore[arg-type]
    ost = qlearning.observer_state(lr)
    xh, dh = qlearning.observe(lr, model.kernel, ost, 0.0, ys[0], 0.0, 0.0, True)
    out = [(xh, dh)]
    for u, y in zip(us, ys[1:], strict=True):
        xh, dh = qlearning.observe(lr, model.kernel, ost, u, y, xh, dh, False)
        out.append((xh, dh))
    return out


@pytest.mark.parametrize("model", [PLANT, ARX], ids=["plant", "arx"])
@pytest.mark.parametrize("delay", [1, 2])
def test_an_observer_assuming_the_actuators_delay_tracks_it_exactly(model: StepModel, delay: int) -> None:
    us = list(np.random.default_rng(4).choice([-10.0, -5.0, 0.0, 5.0, 10.0], size=300))
    applied = [0.0] * delay + us[:-delay]
    state = model.initial_state()
    ys = [0.0] + [model.step(state, u) for u in applied]
    exact = _observe_run(model, ys, us, obs_gain=0.3, obs_delay=delay)
    assert [x for x, _ in exact] == ys
    unaware = _observe_run(model, ys, us, obs_gain=0.3)
    assert max(abs(x - y) for (x, _), y in zip(unaware, ys, strict=True)) > 1e-4


@pytest.mark.parametrize("model", [PLANT, ARX], ids=["plant", "arx"])
@pytest.mark.parametrize("share", [1.0, 0.2, 0.0])
def test_velocity_share_is_the_part_of_the_correction_the_velocity_takes(model: StepModel,
                                                                          share: float) -> None:
    gain, r = 0.1, 0.004  # from rest under no force the prediction is 0, so the innovation is r
    (_, _), (xh, dh) = _observe_run(model, [0.0, r], [0.0], obs_gain=gain, obs_velocity_share=share)
    assert xh == pytest.approx(gain * r, abs=1e-15)
    assert dh == pytest.approx(share * gain * r, abs=1e-15)


def test_drift_correction_removes_a_steady_model_bias() -> None:
    # STATIC predicts 0 under no force, the sensor says 0.2 m for ever: a fixed-gain observer stays
    # at L·0.2; the drift estimate integrates the innovation until the bias is gone.
    ys, us = [0.0] + [0.2] * 3000, [0.0] * 3000
    plain = _observe_run(STATIC, ys, us, obs_gain=0.05)
    assert plain[-1][0] == pytest.approx(0.05 * 0.2, abs=1e-12)
    drift = _observe_run(STATIC, ys, us, obs_gain=0.05, obs_drift_gain=0.01)
    assert drift[-1][0] == pytest.approx(0.2, abs=1e-9)


@pytest.mark.parametrize("model", [PLANT, ARX], ids=["plant", "arx"])
def test_force_bias_state_learns_an_unmodelled_load_and_removes_the_bias(model: StepModel) -> None:
    # The measured system is the observer's own model plus a constant -2 N load from rest, under a
    # steady +3 N: without a bias state the estimate stays off; with one, the bias estimate converges
    # to the load and the position estimate to the measurement.
    load, u = -2.0, 3.0
    state = model.initial_state()
    ys = [0.0] + [kernels.advance_loaded(model.kernel, state, u, load) for _ in range(6000)]
    us = [u] * 6000
    plain = _observe_run(model, ys, us, obs_gain=0.05, obs_velocity_share=0.5)
    assert abs(plain[-1][0] - ys[-1]) > 1e-3
    lr = packed(improved_config(observer="model", obs_gain=0.05, obs_velocity_share=0.5, obs_bias_gain=4.0))
    ost = qlearning.observer_state(lr)
    xh, dh = qlearning.observe(lr, model.kernel, ost, 0.0, ys[0], 0.0, 0.0, True)
    for y in ys[1:]:
        xh, dh = qlearning.observe(lr, model.kernel, ost, u, y, xh, dh, False)
    assert ost[-1] == pytest.approx(load, abs=1e-6)
    assert xh == pytest.approx(ys[-1], abs=1e-9) and abs(dh) < 1e-9


def test_force_bias_estimate_is_held_within_the_actuators_limit() -> None:
    # A measurement stuck far from anything the model can reach would wind an unbounded integrator up.
    ys, us = [0.0] + [2.0] * 3000, [0.0] * 3000
    lr = packed(improved_config(observer="model", obs_gain=0.05, obs_bias_gain=50.0))
    ost = qlearning.observer_state(lr)
    xh, dh = qlearning.observe(lr, STATIC.kernel, ost, 0.0, ys[0], 0.0, 0.0, True)
    for u, y in zip(us, ys[1:], strict=True):
        xh, dh = qlearning.observe(lr, STATIC.kernel, ost, u, y, xh, dh, False)
    assert ost[-1] == lr.actions[-1]


def test_a_zero_bias_gain_is_the_observer_without_a_bias_state() -> None:
    us = list(np.random.default_rng(5).choice([-10.0, 0.0, 10.0], size=400))
    state = ARX.initial_state()
    ys = [0.0] + [kernels.advance_loaded(ARX.kernel, state, u, 1.5) for u in us]
    base = _observe_run(ARX, ys, us, obs_gain=0.05, obs_velocity_share=0.5)
    biased = _observe_run(ARX, ys, us, obs_gain=0.05, obs_velocity_share=0.5, obs_bias_gain=4.0)
    assert base == _observe_run(ARX, ys, us, obs_gain=0.05, obs_velocity_share=0.5, obs_bias_gain=0.0)
    assert base != biased


@pytest.mark.parametrize("kwargs", [{"obs_bias_gain": 1.0}, {"observer": "model", "obs_gain": 0.1,
                                                             "obs_bias_gain": -1.0},
                                    {"observer": "model", "obs_gain": 0.1, "obs_bias_gain": float("nan")},
                                    {"obs_delay": 1}, {"obs_drift_gain": 0.01}, {"obs_velocity_share": 0.5},
                                    {"observer": "model", "obs_gain": 0.1, "obs_velocity_share": 1.5},
                                    {"observer": "model", "obs_gain": 0.1, "obs_delay": 11},
                                    {"observer": "alpha-beta", "obs_gain": 0.1, "obs_delay": 1}])
def test_observer_options_need_a_model_observer_and_sane_values(kwargs: dict[str, object]) -> None:
    with pytest.raises(ConfigError):
        improved_config(**kwargs)
