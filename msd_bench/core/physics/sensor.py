"""The position sensor: what an encoder or ADC does to the true position.

One model for every place that measures the plant (noisy identification
records, the scenario suite, the rig emulator), so they all mean the same
thing by "2 mm of noise":

* additive Gaussian noise of standard deviation ``noise_std`` (m), then
* quantisation to the nearest multiple of ``quant`` (m): a converter rounds
  the already noisy analogue value, so noise comes first.

With both at 0 the sensor is the identity and draws nothing from the random
generator. The generator is always the caller's (seeded), so a record is a
pure function of its seeds. :meth:`SensorModel.measure` (a whole array) and
:meth:`SensorModel.measure_one` (one sample, for a stateful node) consume the
generator identically, so a node that measures sample by sample reproduces an
in-process record bit for bit when given the same generator.

With a sensor the velocity a node reports is an *estimate* from measured
positions (:func:`velocity_estimate`, :class:`VelocityEstimator`), never the
plant's true velocity: a real rig has no velocity sensor.

The identification side of the same fact: :func:`noise_level` estimates the
noise of a measured record, :func:`lowpass` smooths it without lag, and
:func:`clear_of_stops` masks the samples where the hard stops act (a noisy
sample at the stop is not exactly at ±L/2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError, InvalidInputError

FloatArray = NDArray[np.float64]

SENSOR_STREAM = 0x5E45
"""Mixed into a record seed to seed its sensor noise (see :func:`sensor_rng`)."""


@dataclass(frozen=True)
class SensorModel:
    """Gaussian noise then quantisation on a measured position."""

    noise_std: float = 0.0
    """Standard deviation of the additive white Gaussian noise, m (0 = none)."""
    quant: float = 0.0
    """Quantisation step, m (0 = none); values are rounded to the nearest multiple."""

    def __post_init__(self) -> None:
        for name in ("noise_std", "quant"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"sensor {name} must be finite and >= 0, got {value!r}")

    @property
    def is_ideal(self) -> bool:
        """True when the sensor returns the true position unchanged."""
        return self.noise_std == 0.0 and self.quant == 0.0

    def measure(self, x: FloatArray, rng: np.random.Generator) -> FloatArray:
        """Measured positions of the true positions ``x`` (a new array)."""
        arr = np.array(x, dtype=np.float64)
        if arr.ndim != 1:
            raise InvalidInputError(f"positions to measure must be 1-D, got shape {arr.shape}")
        if self.noise_std > 0.0:
            arr = arr + self.noise_std * rng.standard_normal(arr.size)
        if self.quant > 0.0:
            arr = self.quant * np.round(arr / self.quant)
        return arr

    def measure_one(self, x: float, rng: np.random.Generator) -> float:
        """One measured position; same generator use as :meth:`measure` per sample."""
        y = float(x)
        if self.noise_std > 0.0:
            y = y + self.noise_std * float(rng.standard_normal())
        if self.quant > 0.0:
            y = self.quant * float(np.round(y / self.quant))
        return y


def sensor_rng(seed: int) -> np.random.Generator:
    """The noise generator of a record excited with ``seed``.

    Seeded from ``(SENSOR_STREAM, seed)`` rather than ``seed`` alone: the
    multilevel excitation draws from ``default_rng(seed)``, and noise from the
    same stream would be correlated with the force levels.
    """
    return np.random.default_rng((SENSOR_STREAM, int(seed)))


def velocity_estimate(x: FloatArray, dt: float) -> FloatArray:
    """Backward-difference velocity ``(x[k] - x[k-1]) / dt`` of measured positions; ``v[0] = 0``.

    What a node without a velocity sensor can report causally. Under noise of
    standard deviation σ its error has standard deviation ``sqrt(2) σ / dt``
    (0.28 m/s for 2 mm at 10 ms): an estimate, never the truth.
    """
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise InvalidInputError("positions must be a non-empty 1-D array")
    if not (math.isfinite(dt) and dt > 0):
        raise InvalidInputError(f"dt must be finite and > 0, got {dt}")
    v = np.zeros_like(arr)
    v[1:] = np.diff(arr) / dt
    return v


class VelocityEstimator:
    """Per-sample form of :func:`velocity_estimate`, for a node that measures one sample at a time."""

    def __init__(self, dt: float) -> None:
        if not (math.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be finite and > 0, got {dt}")
        self.dt = float(dt)
        self._last: float | None = None

    def reset(self) -> None:
        """Forget the previous sample (a new episode starts at rest: next estimate is 0)."""
        self._last = None

    def update(self, x: float) -> float:
        """Velocity estimate at the measured position ``x`` (0 for the first sample)."""
        v = 0.0 if self._last is None else (float(x) - self._last) / self.dt
        self._last = float(x)
        return v


def noise_level(y: FloatArray) -> float:
    """Robust estimate of white measurement noise: MAD of third differences / sqrt(20).

    A third difference of white noise has variance 20 σ²; that of a smooth
    trajectory sampled at 10 ms is tiny (jerk × dt³), except at the rare force
    switches, which the median ignores. About 3e-6 m on a noise-free record of
    the default plant.
    """
    d3 = np.diff(np.asarray(y, dtype=np.float64), 3)
    if d3.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d3 - np.median(d3))))
    return 1.4826 * mad / math.sqrt(20.0)


def lowpass(s: FloatArray, dt: float, cutoff_hz: float) -> FloatArray:
    """Zero-phase 4th-order Butterworth low-pass (no lag, so filtered signals stay aligned).

    Returns the signal unchanged when the cut-off is at or above Nyquist or the
    signal is too short for the forward-backward pass.
    """
    arr = np.asarray(s, dtype=np.float64)
    nyquist = 0.5 / dt
    if cutoff_hz >= nyquist or arr.size < 30:
        return arr.copy()
    from scipy.signal import butter, sosfiltfilt  # here: scipy.signal costs every plant's start 1 s

    sos = butter(4, cutoff_hz / nyquist, output="sos")
    return np.asarray(sosfiltfilt(sos, arr), dtype=np.float64)


def lowpass_reach(dt: float, cutoff_hz: float) -> int:
    """Samples over which :func:`lowpass` smears an impulse (about 1.5 periods of the cut-off)."""
    if cutoff_hz >= 0.5 / dt:
        return 0
    return math.ceil(1.5 / (cutoff_hz * dt))


def clear_of_stops(y: FloatArray, stroke: float, reach: int = 0) -> NDArray[np.bool_]:
    """Samples a noise margin inside the stroke and ``reach`` samples away from any stop contact.

    An impact zeroes the velocity in one step (an impulse in the
    acceleration); a low-pass spreads it over its impulse response, so with
    filtered data the samples ``reach`` around a contact are masked too.
    """
    arr = np.asarray(y, dtype=np.float64)
    margin = 1e-9 + 5.0 * noise_level(arr)
    at_stop = np.abs(arr) >= 0.5 * stroke - margin
    if reach > 0 and at_stop.any():
        at_stop = np.convolve(at_stop.astype(float), np.ones(2 * reach + 1), mode="same") > 0
    return np.asarray(~at_stop)
