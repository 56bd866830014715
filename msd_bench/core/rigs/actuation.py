"""The force a rig applied, rebuilt from its command stream, and how well a measured effort agrees.

Why (docs/ros2-control.md §Force): a ros2_control rig reports in
``joint_states.effort`` what its actuator measures — noisy, and delayed and
lagged behind the command — while identification needs the force applied over
each sample, free of sensor noise. The commands are exact, but they carry no
header: a forward command controller's ``Float64MultiArray`` carries no header, so the
commands are placed by the time the recorder logged them: sample k gets the
last command logged before sample k was. The rig's own rules are replayed:
non-finite commands are rejected (the last accepted one stays), out-of-range
ones saturate at the force limit, and after ``watchdog_s`` without a command
the force is 0 N.

The measured effort then identifies the actuator between command and force:
a dead time of d samples and a first-order lag, the lag's output averaged
over each sample (the impulse a held sample delivers; :func:`actuator_force`).
For each d up to ``max_delay`` the time constant is fitted by bounded scalar
search on the simulation error; the best pair is reported with its fit (%),
the same percentage the models are scored with. A poor score means the
commands did not drive this joint (wrong ``controller_joints`` order, another
controller) or the log times are unusable. Passing the commands through the
fitted actuator gives the applied force — what the msd face reports as effort —
free of the effort sensor's noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification.fit import fit_percent

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
    """The actuator that best explains the measured effort from the rebuilt command, and how well."""

    delay_samples: int
    """Dead time d: the command held at sample k starts acting at sample k + d (0 = at once)."""
    time_constant_s: float
    """Time constant of the first-order lag after the dead time, s (0 = none)."""
    fit_percent: float
    """Fit (%) of that actuator's simulated force to the measured effort (100 = exact)."""
    rms_n: float
    """RMS of measured effort minus held command, same sample, N (the error of taking either
    for the other without the actuator)."""
    samples: int
    """Samples compared (those with a finite measured effort)."""

    def line(self) -> str:
        """One line for logs and reports."""
        return (f"measured effort against the rebuilt command: fit {self.fit_percent:.1f} % "
                f"through a dead time of {self.delay_samples} samples and a lag of "
                f"{self.time_constant_s * 1e3:.1f} ms "
                f"(effort - command: rms {self.rms_n:.3f} N over {self.samples} samples)")


def actuator_force(command: FloatArray, delay: int, tau: float, dt: float) -> FloatArray:
    """The force a dead time of ``delay`` samples and a first-order lag ``tau`` make of a held ``command``.

    The actuator starts at rest. Its force over sample k is the mean of the
    continuous lag output over [t_k, t_k+1) for the command held at k - delay
    (the impulse a zero-order-hold sample delivers): with the lag state s,
    target r_k, ``a = exp(-dt/tau)`` and ``beta = (tau/dt)(1 - a)``, the force
    is ``r_k + (s_k - r_k)·beta`` and ``s_{k+1} = r_k + (s_k - r_k)·a``.
    ``tau = 0`` gives the delayed command itself.
    """
    u = np.asarray(command, dtype=np.float64)
    if delay < 0 or not (math.isfinite(tau) and tau >= 0) or not dt > 0:
        raise InvalidInputError(f"actuator needs delay >= 0, tau >= 0 and dt > 0, got {delay}, {tau}, {dt}")
    r = np.concatenate([np.zeros(min(delay, u.size)), u[: max(u.size - delay, 0)]])
    if tau == 0:
        return r
    a = math.exp(-dt / tau)
    beta = (tau / dt) * (1.0 - a)
    from scipy.signal import lfilter  # here: SciPy's signal and optimize cost bench.py's start 0.8 s

    state = lfilter([0.0, 1.0 - a], [1.0, -a], r)  # s_k from s_0 = 0
    return np.asarray(r + (state - r) * beta, dtype=np.float64)


def _best_tau(u: FloatArray, e: FloatArray, finite: NDArray[np.bool_], d: int,
              dt: float) -> tuple[float, float]:
    """(fit %, tau) of the lag that best maps the command delayed by ``d`` onto the effort."""
    def loss(log_tau: float) -> float:
        sim = actuator_force(u, d, math.exp(log_tau), dt)
        return float(np.sum((e[finite] - sim[finite]) ** 2))

    from scipy.optimize import minimize_scalar  # here, as lfilter above

    fits = [(fit_percent(e[finite], actuator_force(u, d, 0.0, dt)[finite]), 0.0)]
    res = minimize_scalar(loss, bounds=(math.log(dt / 100), math.log(5.0)), method="bounded",
                          options={"xatol": 1e-4})
    tau = math.exp(float(res.x))
    fits.append((fit_percent(e[finite], actuator_force(u, d, tau, dt)[finite]), tau))
    return max(fits)


def effort_agreement(command: FloatArray, effort: FloatArray, dt: float,
                     max_delay: int = 10) -> EffortAgreement:
    """Fit the actuator (dead time up to ``max_delay`` samples, then a lag) from ``command`` to ``effort``.

    Samples where the effort is not finite (a state without effort) are left out
    of the comparison; with fewer than ``max_delay + 3`` finite ones, or a
    constant effort, there is nothing to compare (InvalidInputError).
    """
    u = np.asarray(command, dtype=np.float64)
    e = np.asarray(effort, dtype=np.float64)
    if u.shape != e.shape:
        raise InvalidInputError(f"command and effort lengths differ ({u.size} vs {e.size})")
    finite = np.isfinite(e)
    if int(finite.sum()) < max_delay + 3:
        raise InvalidInputError(f"only {int(finite.sum())} samples carry a finite effort")
    best: tuple[float, int, float] | None = None
    for d in range(min(max_delay, u.size - 3) + 1):
        score, tau = _best_tau(u, e, finite, d, dt)
        if best is None or score > best[0]:
            best = (score, d, tau)
    assert best is not None
    score, d, tau = best
    rms = float(np.sqrt(np.mean((e[finite] - u[finite]) ** 2)))
    return EffortAgreement(d, tau, float(score), rms, int(finite.sum()))
