"""Return to rest without a ``reset``: zero force, then wait until the position is still.

Why zero force and not a stabilising controller: the bench is a spring-mass-damper,
so with no force the mass returns towards its spring's equilibrium by itself and
stays there — passively stable, whatever its parameters. A controller would need
a model of the rig before the rig is identified (the recording stage comes first)
and a wrong one can drive a real actuator into its end stops. With Coulomb
friction the mass may stop a little off zero; that is fine, because every
recording and episode reads its initial position (``x0``) instead of assuming 0.

"Still" must tolerate sensor noise: over the last ``window`` samples the
position's standard deviation must be below ``threshold`` and the mean of the
window's second half within ``threshold`` of its first half's (a slow drift
toward equilibrium has a small spread but a moving mean). A 2 mm noise sensor
gives a 2 mm standard deviation at rest, so the default 5 mm threshold is met at
rest and missed by a mass still swinging more than about ±8 mm. After
``timeout`` seconds the wait ends anyway (a rig that never looks still — a noisy
sensor above the threshold — must not hang a run); the caller is told.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from msd_bench.core.errors import ConfigError

if TYPE_CHECKING:
    from msd_bench.core.rigs.scales import Scales

X0_SAMPLES = 50
"""Positions averaged into ``x0`` (0.5 s at 100 Hz: 2 mm of noise becomes 0.3 mm)."""


@dataclass(frozen=True)
class RestConfig:
    """When a position record counts as "at rest"."""

    window: int = 300
    """Samples the stillness is judged over (3 s at 100 Hz), also the shortest wait: most of a
    period of the bench's slowest swing (4 s), so a mass slowly turning at the top of a swing is not
    taken for still (over 1 s a 19 mm swing passed as rest)."""
    threshold: float = 0.005
    """Largest standard deviation (and half-window mean shift) of a still position, m."""
    timeout: float = 30.0
    """Seconds after which the wait ends even if the mass never looked still."""
    x0_samples: int = X0_SAMPLES
    """Positions averaged into ``x0`` (:data:`X0_SAMPLES` on the paper's plant)."""

    def __post_init__(self) -> None:
        if self.window < 4:
            raise ConfigError(f"rest window must be at least 4 samples, got {self.window}")
        if not self.threshold > 0.0:
            raise ConfigError(f"rest threshold must be > 0 m, got {self.threshold}")
        if not self.timeout > 0.0:
            raise ConfigError(f"rest timeout must be > 0 s, got {self.timeout}")
        if self.x0_samples < 1:
            raise ConfigError(f"rest x0_samples must be at least 1, got {self.x0_samples}")

    def scaled(self, scales: Scales) -> RestConfig:
        """This rest, stated on the paper's plant, on a rig of ``scales`` (docs/decisions.md §Scales): the
        window and the ``x0`` average the same duration, the threshold the same fraction of the stroke,
        the timeout the same duration. Itself on the paper's plant, bit for bit."""
        if scales.is_default:
            return self
        return replace(self, window=max(4, scales.samples(self.window)),
                       threshold=scales.metres(self.threshold), timeout=scales.seconds(self.timeout),
                       x0_samples=scales.samples(self.x0_samples))


def is_still(positions: np.ndarray, threshold: float) -> bool:
    """Whether ``positions`` (one window) look like a mass at rest seen through a noisy sensor."""
    x = np.asarray(positions, dtype=float)
    if x.size < 4 or not np.all(np.isfinite(x)):
        return False
    half = x.size // 2
    drift = abs(float(np.mean(x[half:])) - float(np.mean(x[:half])))
    return float(np.std(x)) < threshold and drift < threshold


class RestDetector:
    """Feed it every measured position while zero force is applied; it says when the mass is still.

    ``x0`` is the mean of the last :data:`X0_SAMPLES` positions: the initial
    position the next recording or episode starts from (a mean, so 2 mm of
    sensor noise does not become the episode's initial state; a short one, so a
    mass still creeping is read where it is now).
    """

    def __init__(self, config: RestConfig | None = None) -> None:
        self.config = config or RestConfig()
        self._window: deque[float] = deque(maxlen=self.config.window)
        self.samples = 0
        self.still = False

    def push(self, x: float) -> bool:
        """Add one position; True once the last window is still (and stays True)."""
        self._window.append(float(x))
        self.samples += 1
        if not self.still and len(self._window) == self.config.window:
            self.still = is_still(np.fromiter(self._window, float), self.config.threshold)
        return self.still

    @property
    def x0(self) -> float:
        """Best estimate of the rest position so far (mean of the last positions), m."""
        if not self._window:
            raise ConfigError("no position measured yet: the initial position is unknown")
        return float(np.mean(np.fromiter(self._window, float)[-self.config.x0_samples:]))

    def spread(self) -> float:
        """Standard deviation of the last window, m (for the timeout message)."""
        return float(np.std(np.fromiter(self._window, float))) if self._window else float("nan")
