"""Input/output records for identification: a small ``iddata``.

Like MATLAB's ``iddata``, an :class:`IOData` holds the force ``u`` and the
measured position ``y`` sampled at ``dt``, possibly as several experiments
(``merge``) that are fitted jointly but never concatenated across their
boundaries (a regressor never spans two experiments).

A record made in process through a sensor model (:mod:`msd_bench.core.physics.sensor`)
also keeps the noise-free position as ``Experiment.truth``. Identification
never reads it; evaluation uses it to score a model against the truth
(``fit_sim_truth_percent``) beside the fit against the measurement. Recorded
bags have no truth unless an emulator published it separately.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.physics.plant import DT

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
    truth: FloatArray | None = None
    """Noise-free position per sample when known (emulated records), else None; for scoring only."""

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
        if self.truth is not None:
            truth = np.ascontiguousarray(self.truth, dtype=np.float64)
            if truth.shape != y.shape or not np.all(np.isfinite(truth)):
                raise InvalidInputError(f"experiment {self.name!r}: truth must be finite and as long as y")
            object.__setattr__(self, "truth", truth)

    def __len__(self) -> int:
        return int(self.u.size)

    def segment(self, start: int, stop: int | None = None) -> Experiment:
        """Samples ``[start, stop)`` as a new experiment (e.g. to drop a settling phase)."""
        truth = None if self.truth is None else self.truth[start:stop]
        return Experiment(self.u[start:stop], self.y[start:stop], self.name, truth)

    @property
    def y_true(self) -> FloatArray:
        """The noise-free position; raises when the record does not carry it."""
        if self.truth is None:
            raise InvalidInputError(f"experiment {self.name!r} carries no noise-free truth")
        return self.truth


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

    @property
    def has_truth(self) -> bool:
        """Every experiment carries its noise-free position."""
        return all(e.truth is not None for e in self.experiments)

    def noise_free(self) -> IOData:
        """The same record with the noise-free truth as the measured output (e.g. for references)."""
        exps = tuple(Experiment(e.u, e.y_true, e.name, e.y_true) for e in self.experiments)
        return IOData(exps, self.dt, dict(self.meta))

    def merge(self, other: IOData) -> IOData:
        """Both sets of experiments (MATLAB ``merge``); sample times must agree."""
        if not np.isclose(self.dt, other.dt):
            raise InvalidInputError(f"cannot merge records at dt={self.dt} and dt={other.dt}")
        return IOData(self.experiments + other.experiments, self.dt, {**self.meta, **other.meta})
