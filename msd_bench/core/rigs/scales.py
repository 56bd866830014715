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

A rig whose *dynamics* are slower or faster than the paper's, not only its
sampling, has its own time unit: ``pace`` (rig time unit / paper time unit,
1.0 unless stated) multiplies every paper duration, so an episode lasts 30 s ×
``pace``. A rig description states none (issue 37: durations in seconds); the
``scaled`` rig family (:mod:`msd_bench.core.rigs.families`) knows how much
slower each member runs than its default-family twin and states it, and with
``pace == time`` every paper sample count is unchanged, exactly.
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

    pace: float = 1.0
    """Rig time unit / paper time unit: multiplies every paper duration (s). 1.0: durations are held
    in seconds (a rig sampled faster is not a faster plant); a rig whose dynamics run ``pace`` times
    slower than the paper's states it, and with ``pace == time`` a paper count is the rig's count."""

    DEFAULT: ClassVar[Scales]
    """The paper's own plant: every factor exactly 1.0."""

    def __post_init__(self) -> None:
        for name in ("length", "force", "time", "pace"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and value > 0):
                raise ConfigError(f"scale {name} must be a finite number > 0, got {value!r:.40}")

    @classmethod
    def of(cls, stroke_m: float, force_limit_n: float, dt_s: float, pace: float = 1.0) -> Scales:
        """The scales of a rig with this stroke (m), force limit (N) and sample time (s), and the
        time unit of its dynamics relative to the paper's (``pace``; 1.0: durations in seconds)."""
        for name, value in (("stroke", stroke_m), ("force limit", force_limit_n), ("sample time", dt_s)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and value > 0):
                raise ConfigError(f"rig {name} must be a finite number > 0, got {value!r:.40}")
        return cls(stroke_m / DEFAULT_STROKE, force_limit_n / DEFAULT_FORCE_LIMIT, dt_s / DEFAULT_DT, pace)

    @property
    def is_default(self) -> bool:
        """Whether every factor is exactly 1 (the paper's plant)."""
        return self.length == 1.0 and self.force == 1.0 and self.time == 1.0 and self.pace == 1.0

    def metres(self, paper_m: float) -> float:
        """A paper length (m) on the rig."""
        return paper_m * self.length

    def newtons(self, paper_n: float) -> float:
        """A paper force (N) on the rig."""
        return paper_n * self.force

    def samples(self, paper_samples: int) -> int:
        """A paper duration of ``paper_samples`` × 0.01 s, in rig samples (the same seconds × ``pace``;
        >= 1).

        Unchanged when ``time`` equals ``pace`` (1 on the default), so neither the default path nor a
        rig of the ``scaled`` family has rounding in it.
        """
        if self.time == self.pace:
            return int(paper_samples)
        return max(1, round(paper_samples * self.pace / self.time))

    def steps(self, paper_steps: float) -> float:
        """A paper horizon of ``paper_steps`` samples (a real number, e.g. a lead) in rig samples,
        unrounded: itself when ``time`` equals ``pace``."""
        if self.time == self.pace:
            return paper_steps
        return paper_steps * self.pace / self.time

    def seconds(self, paper_s: float) -> float:
        """A paper duration (s) on the rig: × ``pace`` (itself when ``pace`` is 1)."""
        return paper_s * self.pace

    def speed(self, paper_m_per_s: float) -> float:
        """A paper speed (m/s) on the rig: lengths per time unit (× ``length`` / ``pace``)."""
        return paper_m_per_s * self.length / self.pace

    def plant(self, paper: PlantParams) -> PlantParams:
        """A plant stated on the paper's scales in the rig's: lengths × ``length``, forces × ``force``,
        durations × ``pace``, the sample time × ``time`` (the similarity transform of docs/decisions.md
        §Scales). Itself on the default, bit for bit."""
        if self.is_default:
            return paper
        ln, f, t = self.length, self.force, self.pace
        return PlantParams(m=paper.m * f * t * t / ln, c=paper.c * f * t / ln, k=paper.k * f, g=paper.g / ln,
                           h=paper.h * f / (ln * ln * ln), L=paper.L * ln, F=paper.F * f,
                           dt=paper.dt * self.time)

    def per_sample(self, paper_per_sample: float) -> float:
        """A paper rate per sample (e.g. a displacement per 0.01 s) as a rate per rig sample."""
        if self.time == self.pace:
            return paper_per_sample
        return paper_per_sample * self.time / self.pace


Scales.DEFAULT = Scales()
