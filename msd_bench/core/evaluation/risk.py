"""Risk of one run, from its arrays: what a table reports beside success (issue 23 item 2).

A validation run that reaches its set-point may still have driven the mass into
a hard stop at full force; these numbers say so. They are computed from the
*true* trajectory where the emulator has one (scoring, not control), and from
the supervisor's per-sample reasons and its abort code.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.safety.supervisor import ABORTS, NONE, REASONS, Limits, SupervisorOptions


@dataclass(frozen=True)
class RunRisk:
    """Risk of one run (fields in the order a table shows them)."""

    contacts: int
    """Hard-stop contacts: how many times the mass arrived at a stop (|x| = L/2)."""
    time_at_stop: float
    """Time spent at a stop, s."""
    peak_x: float
    """Largest |x|, m."""
    peak_v: float
    """Largest |v|, m/s."""
    time_outside: float
    """Time with |x| beyond the envelope, s."""
    exits_beyond_margin: int
    """How many times |x| went past envelope + margin (the supervisor claims 0)."""
    override_share: float
    """Share of the run's samples whose force the supervisor chose (0 without one)."""
    overrides: dict[str, int]
    """Overridden samples by reason (``supervisor.REASONS``)."""
    aborted: str | None
    """The reason the run was aborted (stale, time_limit, divergence, estop), or None."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (the overrides as their own object)."""
        return asdict(self)


def _entries(flag: np.ndarray) -> int:
    """How many times ``flag`` turned true (a run that starts true counts once)."""
    if flag.size == 0:
        return 0
    return int(flag[0]) + int(np.count_nonzero(flag[1:] & ~flag[:-1]))


def run_risk(x: ArrayLike, v: ArrayLike, *, dt: float, half_stroke: float, envelope: float,
             margin: float, reasons: ArrayLike | None = None, abort: int = NONE) -> RunRisk:
    """The risk metrics of one run.

    ``x`` and ``v`` are the run's positions and velocities (1-D, one per sample, the true ones
    where known), ``reasons`` the supervisor's reason code per sample (omit for an unsupervised
    run) and ``abort`` its abort code at the end. A contact is a sample at the stop (the plant
    projects on ±L/2 exactly; ``half_stroke`` less 1 µm catches a rig that reports it rounded).
    """
    xs = np.asarray(x, dtype=np.float64)
    vs = np.asarray(v, dtype=np.float64)
    if xs.ndim != 1 or xs.shape != vs.shape or xs.size == 0:
        raise InvalidInputError(
            f"x and v must be non-empty 1-D arrays of one length, got {xs.shape}, {vs.shape}")
    if not (np.all(np.isfinite(xs)) and np.all(np.isfinite(vs))):
        raise InvalidInputError("x and v must be finite")
    if not (dt > 0 and envelope > 0 and envelope + margin < half_stroke):
        raise InvalidInputError(f"need dt > 0 and 0 < envelope + margin < half_stroke, got dt={dt}, "
                                f"envelope={envelope}, margin={margin}, half_stroke={half_stroke}")
    codes = np.zeros(xs.size, dtype=np.int64) if reasons is None else np.asarray(reasons, dtype=np.int64)
    if codes.shape != xs.shape or np.any((codes < 0) | (codes >= len(REASONS))):
        raise InvalidInputError(f"reasons must be one code in [0, {len(REASONS)}) per sample")
    if abort != NONE and abort not in ABORTS:
        raise InvalidInputError(f"abort must be 0 or one of {ABORTS}, got {abort}")
    ax = np.abs(xs)
    at_stop = ax >= half_stroke - 1e-6
    counts = np.bincount(codes, minlength=len(REASONS))
    return RunRisk(
        contacts=_entries(at_stop),
        time_at_stop=float(np.count_nonzero(at_stop) * dt),
        peak_x=float(ax.max()),
        peak_v=float(np.abs(vs).max()),
        time_outside=float(np.count_nonzero(ax > envelope) * dt),
        exits_beyond_margin=_entries(ax > envelope + margin),
        override_share=float(np.count_nonzero(codes) / codes.size),
        overrides={REASONS[c]: int(counts[c]) for c in range(1, len(REASONS)) if counts[c]},
        aborted=None if abort == NONE else REASONS[abort],
    )


def velocity_of(x: ArrayLike, dt: float) -> np.ndarray:
    """The backward difference of true positions, m/s (0 at the first sample).

    Why not the plant's own velocity: the compiled validation loops return positions only,
    and for the semi-implicit Euler step (velocity first, then ``x += dt·v``) the backward
    difference *is* the plant's velocity, except at a stop, where the projection zeroes the
    state's velocity and the difference keeps the speed the mass arrived with (the number
    that matters there).
    """
    xs = np.asarray(x, dtype=np.float64)
    v = np.zeros_like(xs)
    v[1:] = np.diff(xs) / dt
    return v


def trace_risk(x: ArrayLike, plant: PlantParams, limits: Limits | None = None,
               reasons: ArrayLike | None = None, abort: int = NONE) -> RunRisk:
    """The risk of one validation run from its true positions (:func:`run_risk`).

    ``limits`` is the supervisor's, when it guarded the run; without one the envelope is the
    default supervisor's on ``plant`` (so an unsupervised row says how long a supervised run
    would have been outside it).
    """
    lim = limits if limits is not None else SupervisorOptions().limits(plant)
    return run_risk(x, velocity_of(x, plant.dt), dt=plant.dt, half_stroke=plant.x_max,
                    envelope=lim.envelope, margin=lim.margin, reasons=reasons, abort=abort)
