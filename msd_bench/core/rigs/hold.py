"""A low-gain position loop that holds a rig while it is excited: records of a rig with no equilibrium.

Why: the paper's plant has a spring, so with no force the mass returns to rest by
itself and an open-loop excitation stays within the stroke. A positioning stage
has no spring (or a weak one) and may carry an offset force: under a constant
force it has no equilibrium, and an open-loop PRBS walks it into a stop within
a second. A lab records such a stage the way its drive already runs it: under
a stiff-enough position loop, with the identification signal added to the
loop's force (docs/rig-families.md §stage). :class:`HoldLoop` is that loop, as
the rig's owner would state it: a proportional-derivative law on the measured
position and the velocity estimated from it, towards a held position.

What the loop does to identification, and why the records stay usable: the
records are the *applied* force (the drive's effort) and the *measured*
position, so what is identified is still the plant from force to position;
the loop only chooses which forces are applied. Feedback correlates the
applied force with the sensor's noise (the loop reacts to it), which biases an
output-error fit in proportion to the noise the loop feeds back against the
signal that excites the plant. Here the loop is weak (its force is a fraction
of the excitation's; :attr:`HoldLoop.stiffness`), the excitation is an
external signal independent of the noise, and a stage's encoder has no
analogue noise, only its quantisation (a micrometre against centimetres of
motion): the bias is far below what the fits resolve. The same argument as
for the closed-loop records of refinement (docs/rigs.md §Refinement).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError

FloatArray = NDArray[np.float64]
Sample = TypeVar("Sample", float, FloatArray)
"""One sample's value, or an array of them."""

STIFFNESS_PER_FORCE_AND_STROKE = 2.5
"""The loop's stiffness in units of the rig's force limit per stroke (``kp = 2.5 F / L``). Why 2.5:
under it the full force limit holds the mass 0.8 of the way from the centre to a stop, where the
paper plant's own spring holds it (about 2 m of its 2.5 m at 10 N): the paper's excitation, scaled to
the rig's force limit, then moves a stage as broadly as it moves the paper's plant, inside the stops."""
DAMPING_RATIO = 0.7
"""The loop's damping ratio on the owner's nominal mass: no overshoot to speak of, a quick settle."""


@dataclass(frozen=True)
class HoldLoop:
    """``force = -stiffness (y - held) - damping v``: the loop's law (N), added to the excitation."""

    stiffness: float
    """N/m on the measured position's error."""
    damping: float
    """N·s/m on the velocity estimated from the measured positions."""
    held: float = 0.0
    """The position held, m."""

    def __post_init__(self) -> None:
        for name in ("stiffness", "damping"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ConfigError(f"hold loop {name} must be finite and >= 0, got {value}")
        if not math.isfinite(self.held):
            raise ConfigError(f"hold loop position must be finite, got {self.held}")

    @classmethod
    def stated(cls, stroke: float, force_limit: float, nominal_mass: float) -> HoldLoop:
        """The loop a rig's owner states from what they know: the stroke, the force limit and the
        moving mass as they estimate it (never the drawn one): stiffness from
        :data:`STIFFNESS_PER_FORCE_AND_STROKE`, damping for :data:`DAMPING_RATIO` on that mass."""
        stiffness = STIFFNESS_PER_FORCE_AND_STROKE * force_limit / stroke
        return cls(stiffness, 2.0 * DAMPING_RATIO * math.sqrt(stiffness * nominal_mass))

    @classmethod
    def from_gains(cls, stiffness: float, damping: float, held: float = 0.0) -> HoldLoop | None:
        """The loop parameters state (a node's, a job's), or None when both gains are 0: a rig run bare.
        Why here: the rig node's drive and the identifier read the same three numbers the same way."""
        if stiffness == 0.0 and damping == 0.0:
            return None
        return cls(stiffness, damping, held)

    def params(self) -> dict[str, float]:
        """The loop as the three ``hold_*`` parameters :meth:`from_gains` reads (a job's, a rig file's)."""
        return {"hold_stiffness": self.stiffness, "hold_damping": self.damping, "hold_position": self.held}

    def force(self, measured: Sample, velocity: Sample) -> Sample:
        """The loop's force (before the excitation is added and the drive saturates): for one sample, or
        elementwise over arrays of them — the one place the law is written in Python (the compiled
        loop's :func:`~msd_bench.core.rigs.rig.with_hold` writes it again in numba, per sample)."""
        return -self.stiffness * (measured - self.held) - self.damping * velocity


@dataclass(frozen=True)
class Operation:
    """How a rig is operated besides its physics: the hold loop it runs under, the samples per decision.

    Why: a stage (docs/rig-families.md §stage) is recorded and controlled under its owner's stated
    position loop, at the paper's pace rather than its servo rate; the paper's plant and the default
    and scaled families run bare, deciding every sample (:data:`BARE`)."""

    hold: HoldLoop | None = None
    """The loop the rig is rested and run under (None: none)."""
    every: int = 1
    """Rig samples per decision (the command held in between)."""


BARE = Operation()
"""A rig run as the paper's plant is: no hold loop, a decision every sample."""


def beyond_loop(effort: FloatArray, measured: FloatArray, hold: HoldLoop, dt: float) -> FloatArray:
    """The force each sample applied beyond the ``hold`` loop's own: the input of the *held* system.

    Why: the indirect method of closed-loop identification. The held stage (the plant with the
    loop's stiffness and damping around it) is stable, so a simulation of a model of it stays
    bounded and a simulation-error fit is sound, where a free-run simulation of a near-double
    integrator drifts on any force error; and its input is essentially the external signal,
    independent of the sensor's noise. The loop is known exactly (stated, and recomputed here from
    the same measured positions and the same velocity estimate it read), so a model of the plant
    is the held model with the loop's force taken back out."""
    velocity = np.concatenate([[0.0], np.diff(measured) / dt])
    out: FloatArray = effort - hold.force(measured, velocity)
    return out
