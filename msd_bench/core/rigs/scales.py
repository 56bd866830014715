"""The rig's own scales: how the paper's metres, newtons and samples become a rig's.

The paper states its method on one plant: a 5 m stroke, a 10 N force limit,
0.01 s samples. A rig that moves 0.25 m with 350 N at 1 kHz needs the same
method in its own units, so every paper constant (an error clip of 5 m, bias
forces of ±5 and ±10 N, a 1 m step, 30 s episodes) is kept as the paper wrote
it and multiplied by a :class:`Scales` factor here (docs/decisions.md §Scales).

Why factors and not new constants: on the default plant every factor is
exactly 1.0 and ``x * 1.0 == x`` in IEEE arithmetic, so the default reproduces
bit for bit; a sample count is converted only when the time factor is not 1,
so no rounding enters the default path either.

Lengths scale with the stroke, forces with the force limit. Durations are
stated in seconds and converted to samples with the rig's ``dt``
(:meth:`Scales.samples`): a paper count of N samples is N × 0.01 s, i.e.
N / ``time`` samples of the rig.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import DT, PlantParams

DEFAULT_STROKE = PlantParams().L
"""Stroke of the paper's plant, m: the length every paper metre is relative to."""
DEFAULT_FORCE_LIMIT = PlantParams().F
"""Force limit of the paper's plant, N: the force every paper newton is relative to."""
DEFAULT_DT = DT
"""Sample time of the paper's plant, s: a paper sample count is counted in these."""


@dataclass(frozen=True)
class Scales:
    """Factors from the paper's plant to a rig: length, force and sample time (each > 0)."""

    length: float = 1.0
    """Rig stroke / paper stroke: multiplies every paper length (m)."""
    force: float = 1.0
    """Rig force limit / paper force limit: multiplies every paper force (N)."""
    time: float = 1.0
    """Rig sample time / paper sample time: a paper count of N samples is N / time rig samples."""

    DEFAULT: ClassVar[Scales]
    """The paper's own plant: every factor exactly 1.0."""

    def __post_init__(self) -> None:
        for name in ("length", "force", "time"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and value > 0):
                raise ConfigError(f"scale {name} must be a finite number > 0, got {value!r:.40}")

    @classmethod
    def of(cls, stroke_m: float, force_limit_n: float, dt_s: float) -> Scales:
        """The scales of a rig with this stroke (m), force limit (N) and sample time (s)."""
        for name, value in (("stroke", stroke_m), ("force limit", force_limit_n), ("sample time", dt_s)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and value > 0):
                raise ConfigError(f"rig {name} must be a finite number > 0, got {value!r:.40}")
        return cls(stroke_m / DEFAULT_STROKE, force_limit_n / DEFAULT_FORCE_LIMIT, dt_s / DEFAULT_DT)

    @property
    def is_default(self) -> bool:
        """Whether every factor is exactly 1 (the paper's plant)."""
        return self.length == 1.0 and self.force == 1.0 and self.time == 1.0

    def metres(self, paper_m: float) -> float:
        """A paper length (m) on the rig."""
        return paper_m * self.length

    def newtons(self, paper_n: float) -> float:
        """A paper force (N) on the rig."""
        return paper_n * self.force

    def samples(self, paper_samples: int) -> int:
        """A paper duration of ``paper_samples`` × 0.01 s, in rig samples (the same seconds; >= 1).

        Unchanged when ``time`` is 1, so the default path has no rounding in it.
        """
        if self.time == 1.0:
            return int(paper_samples)
        return max(1, round(paper_samples / self.time))

    def per_sample(self, paper_per_sample: float) -> float:
        """A paper rate per sample (e.g. a displacement per 0.01 s) as a rate per rig sample."""
        return paper_per_sample * self.time


Scales.DEFAULT = Scales()
