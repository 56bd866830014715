"""Return to rest without reset: stillness under sensor noise, the rest position read, never assumed."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PlantParams, simulate
from msd_bench.core.rigs.rest import X0_SAMPLES, RestConfig, RestDetector, is_still


def _measured(x: np.ndarray, noise: float = 0.002, quant: float = 0.0001, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y = x + rng.normal(0.0, noise, x.size)
    return np.round(y / quant) * quant


def test_a_mass_at_rest_behind_a_2mm_sensor_is_still() -> None:
    assert is_still(_measured(np.full(300, 0.3)), RestConfig().threshold)


def test_a_swinging_mass_is_not_still_even_near_the_top_of_its_swing() -> None:
    """A 19 mm swing of the default plant (period about 4 s) seen over the 3 s window."""
    t = np.arange(300) * 0.01
    for phase in np.linspace(0, 2 * np.pi, 16, endpoint=False):
        x = 0.019 * np.cos(1.55 * t + phase)
        assert not is_still(x, RestConfig().threshold), phase


def test_a_slow_creep_is_not_still() -> None:
    assert not is_still(np.linspace(0.0, 0.02, 300), RestConfig().threshold)


def test_non_finite_or_too_short_windows_are_never_still() -> None:
    x = np.zeros(300)
    x[5] = np.nan
    assert not is_still(x, 0.005)
    assert not is_still(np.zeros(3), 0.005)


def test_detector_on_the_plant_released_from_one_metre() -> None:
    """Zero force from x = 1 m on the default plant: not still while it swings, still once settled,
    and x0 is read where the mass rests (within the sensor's averaged noise), not assumed 0."""
    x, _, _ = simulate(np.zeros(6000), PlantParams(), x0=1.0)
    y = _measured(x)
    det = RestDetector()
    k_still = next(k for k, yk in enumerate(y) if det.push(yk))
    assert 300 <= k_still < 6000
    assert np.max(np.abs(x[k_still - 300:k_still + 1])) < 0.02  # really near rest when it says so
    assert abs(det.x0 - float(np.mean(x[k_still + 1 - X0_SAMPLES:k_still + 1]))) < 0.002


def test_x0_is_the_rest_position_off_zero() -> None:
    """Friction can stop a rig off its spring's equilibrium: x0 is measured, e.g. 0.3 m."""
    det = RestDetector()
    for yk in _measured(np.full(400, 0.3), seed=3):
        det.push(yk)
    assert det.still and abs(det.x0 - 0.3) < 0.001


def test_detector_needs_a_full_window_and_stays_still() -> None:
    det = RestDetector(RestConfig(window=10))
    assert not any(det.push(0.0) for _ in range(9))
    assert det.push(0.0) and det.push(0.5)  # once still, a later sample does not undo it


def test_x0_before_any_sample_is_a_one_line_error() -> None:
    with pytest.raises(ConfigError, match="no position measured yet"):
        _ = RestDetector().x0


@pytest.mark.parametrize("kw", [{"window": 3}, {"threshold": 0.0}, {"timeout": -1.0}])
def test_bad_rest_config_is_one_line(kw: dict[str, float]) -> None:
    with pytest.raises(ConfigError):
        RestConfig(**kw)  # type: ignore[arg-type]

