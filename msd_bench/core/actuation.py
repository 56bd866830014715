"""The force a rig applied, rebuilt from its command stream, and how well a measured effort agrees.

Why (docs/ros2-control.md §Force): a ros2_control rig reports in
``joint_states.effort`` what its actuator measures — delayed, lagged, noisy —
not the command it holds over the next sample, which is what identification
needs as its input (the models learn the actuator's dynamics with the rest).
A forward command controller's ``Float64MultiArray`` carries no header, so the
commands are placed by the time the recorder logged them: sample k gets the
last command logged before sample k was. The rig's own rules are replayed:
non-finite commands are rejected (the last accepted one stays), out-of-range
ones saturate at the force limit, and after ``watchdog_s`` without a command
the force is 0 N.

The measured effort is then only a check. A first-order actuator with a pure
delay, ``e[k+1] = a·e[k] + (1-a)·u[k-d]``, is fitted to it by least squares
for each delay ``d`` up to ``max_delay``; the best one is simulated from the
rebuilt commands and scored with the same fit percentage as the models. A
poor score means the commands did not drive this joint (wrong
``controller_joints`` order, another controller) or the log times are
unusable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.fit import fit_percent

FloatArray = NDArray[np.float64]


def held_commands(
    sample_ns: NDArray[np.int64],
    command_ns: NDArray[np.int64],
    command_force: FloatArray,
    *,
    force_limit: float,
    watchdog_s: float = 0.5,
) -> FloatArray:
    """The force held at each sample: the last accepted command logged strictly before it.

    ``sample_ns`` and ``command_ns`` are log times (ns) on one clock; ``command_force``
    may hold NaN or infinities (rejected by the rig, so skipped here). Before the
    first command, and once the newest command is older than ``watchdog_s``
    (0 = no watchdog), the rig applies 0 N.
    """
    sample_ns = np.asarray(sample_ns, dtype=np.int64)
    command_ns = np.asarray(command_ns, dtype=np.int64)
    command_force = np.asarray(command_force, dtype=np.float64)
    if command_ns.shape != command_force.shape or command_ns.ndim != 1:
        raise InvalidInputError("command log times and forces must be 1-D arrays of one length")
    if not (math.isfinite(force_limit) and force_limit > 0):
        raise InvalidInputError(f"force limit must be finite and > 0, got {force_limit}")
    ok = np.isfinite(command_force)
    t, f = command_ns[ok], np.clip(command_force[ok], -force_limit, force_limit)
    order = np.argsort(t, kind="stable")
    t, f = t[order], f[order]
    idx = np.searchsorted(t, sample_ns, side="left") - 1  # last command strictly before the sample
    held = np.where(idx >= 0, f[np.maximum(idx, 0)] if f.size else 0.0, 0.0)
    if watchdog_s > 0 and t.size:
        age = (sample_ns - t[np.maximum(idx, 0)]) / 1e9
        held = np.where((idx >= 0) & (age > watchdog_s), 0.0, held)
    return np.asarray(held, dtype=np.float64)


@dataclass(frozen=True)
class EffortAgreement:
    """How the measured effort follows the rebuilt command: a delayed first-order actuator."""

    delay_samples: int
    """Pure delay d of the best actuator fit, samples: the effort at k+1 moves toward the command
    held at k-d (d = 0: a reading one sample after the command already shows it)."""
    time_constant_s: float
    """Time constant of its first-order lag, s (0: none; inf: the effort does not follow)."""
    fit_percent: float
    """Fit (%) of the simulated actuator output to the measured effort (100 = exact)."""
    rms_n: float
    """RMS of measured effort minus command, same sample, N (the error of taking the effort as input)."""
    samples: int
    """Samples compared (those with a finite measured effort)."""

    def line(self) -> str:
        """One line for logs and reports."""
        return (f"measured effort against the rebuilt command: fit {self.fit_percent:.1f} % "
                f"through a delay of {self.delay_samples} samples and a lag of "
                f"{self.time_constant_s * 1e3:.1f} ms "
                f"(effort - command: rms {self.rms_n:.3f} N over {self.samples} samples)")


def _lag_pole(u: FloatArray, e: FloatArray, d: int) -> float:
    """Least-squares pole a of ``e[k+1] - u[k-d] = a·(e[k] - u[k-d])``, clipped to [0, 1]."""
    x = e[d:-1] - u[: u.size - d - 1]
    y = e[d + 1:] - u[: u.size - d - 1]
    den = float(x @ x)
    a = float(x @ y) / den if den > 0 else 0.0
    return min(max(a, 0.0), 1.0)


def _simulate(u: FloatArray, d: int, a: float, e0: float) -> FloatArray:
    """Output of the delayed first-order actuator driven by ``u``, starting at ``e0``."""
    src = np.concatenate([np.zeros(d), u[: u.size - d]]) if d else u
    out = lfilter([0.0, 1.0 - a], [1.0, -a], src, zi=[e0])[0]
    return np.asarray(out, dtype=np.float64)


def effort_agreement(command: FloatArray, effort: FloatArray, dt: float,
                     max_delay: int = 10) -> EffortAgreement:
    """Fit a delayed first-order actuator from ``command`` to ``effort`` and score it.

    Samples where the effort is not finite (a state without effort) are left out
    of the comparison; with fewer than ``max_delay + 3`` finite ones there is
    nothing to compare (InvalidInputError).
    """
    u = np.asarray(command, dtype=np.float64)
    e = np.asarray(effort, dtype=np.float64)
    if u.shape != e.shape:
        raise InvalidInputError(f"command and effort lengths differ ({u.size} vs {e.size})")
    finite = np.isfinite(e)
    if int(finite.sum()) < max_delay + 3:
        raise InvalidInputError(f"only {int(finite.sum())} samples carry a finite effort")
    e_filled = np.where(finite, e, 0.0)
    best: tuple[float, int, float] | None = None
    for d in range(min(max_delay, u.size - 3) + 1):
        a = _lag_pole(u, e_filled, d)
        sim = _simulate(u, d, a, float(e_filled[0]))
        score = fit_percent(e[finite], sim[finite])
        if best is None or score > best[0]:
            best = (score, d, a)
    assert best is not None
    score, d, a = best
    tau = 0.0 if a <= 0.0 else math.inf if a >= 1.0 else -dt / math.log(a)
    rms = float(np.sqrt(np.mean((e[finite] - u[finite]) ** 2)))
    return EffortAgreement(d, tau, float(score), rms, int(finite.sum()))
