"""Input/output records for identification: a small ``iddata``.

Like MATLAB's ``iddata``, an :class:`IOData` holds the force ``u`` and the
measured position ``y`` sampled at ``dt``, possibly as several experiments
(``merge``) that are fitted jointly but never concatenated across their
boundaries (a regressor never spans two experiments).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.plant import DT

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Experiment:
    """One contiguous record: ``y[k]`` measured before ``u[k]`` acts."""

    u: FloatArray
    """Applied force per sample, N."""
    y: FloatArray
    """Measured position per sample, m."""
    name: str = ""
    """Label (e.g. the bag it came from, or ``bias=+5``)."""

    def __post_init__(self) -> None:
        u = np.ascontiguousarray(self.u, dtype=np.float64)
        y = np.ascontiguousarray(self.y, dtype=np.float64)
        if u.ndim != 1 or y.ndim != 1:
            raise InvalidInputError(f"experiment {self.name!r}: u and y must be 1-D")
        if u.size != y.size:
            raise InvalidInputError(
                f"experiment {self.name!r}: u and y lengths differ ({u.size} vs {y.size})"
            )
        if u.size < 3:
            raise InvalidInputError(f"experiment {self.name!r}: needs at least 3 samples, got {u.size}")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
            raise InvalidInputError(f"experiment {self.name!r}: contains non-finite samples")
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "y", y)

    def __len__(self) -> int:
        return int(self.u.size)

    def segment(self, start: int, stop: int | None = None) -> Experiment:
        """Samples ``[start, stop)`` as a new experiment (e.g. to drop a settling phase)."""
        return Experiment(self.u[start:stop], self.y[start:stop], self.name)


@dataclass(frozen=True)
class IOData:
    """One or several experiments at a common sample time."""

    experiments: tuple[Experiment, ...]
    """The records, fitted jointly."""
    dt: float = DT
    """Sample time in s."""
    meta: dict[str, object] = field(default_factory=dict)
    """Provenance (bag paths, hashes, excitation parameters)."""

    def __post_init__(self) -> None:
        if not self.experiments:
            raise InvalidInputError("identification data is empty: no experiment given")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise InvalidInputError(f"sample time must be finite and > 0, got {self.dt}")

    @classmethod
    def single(cls, u: FloatArray, y: FloatArray, dt: float = DT, name: str = "") -> IOData:
        """Wrap one record."""
        return cls((Experiment(np.asarray(u), np.asarray(y), name),), dt)

    @property
    def n_samples(self) -> int:
        """Total samples over all experiments."""
        return sum(len(e) for e in self.experiments)

    def merge(self, other: IOData) -> IOData:
        """Both sets of experiments (MATLAB ``merge``); sample times must agree."""
        if not np.isclose(self.dt, other.dt):
            raise InvalidInputError(f"cannot merge records at dt={self.dt} and dt={other.dt}")
        return IOData(self.experiments + other.experiments, self.dt, {**self.meta, **other.meta})
