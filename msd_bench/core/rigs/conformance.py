"""Conformance clauses of a plant-like node: pure functions over what a checker recorded.

``msd-bench check-rig NS`` (docs/check-rig.md) drives a node through a short
script and records arrays — ``joint_states`` stamps, arrival times,
positions and efforts, the ``position`` topic, the commands it sent and when.
Each function here turns such arrays into one :class:`Clause`: PASS or FAIL
with the measured figure. No rclpy: the same functions are tested on
synthetic arrays, and a rig owner can run them on their own recordings.

Why judge the effort rather than the motion: identification reads the
effort column of ``joint_states`` as the force that acted (docs/design.md
§Contract); a driver whose effort is the *command* instead of the applied
force, or one that never saturates, poisons every model fitted from its bags,
while the motion itself is whatever the rig's physics is.

Timing clauses (rate, stamp gaps, inter-arrival p99, watchdog latency) scale
their limits by ``Limits.timing_tolerance`` (1 = the contract's figures); a
test on a loaded machine uses a lenient factor. Every other clause is exact
or scaled only by the noise a clause has to see through.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.physics.plant import DT

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Clause:
    """One line of the conformance report."""

    name: str
    """Short clause name (``rate``, ``watchdog`` ...)."""
    passed: bool
    """Whether the node met the clause."""
    figure: str
    """What was measured, or why it failed: one line."""

    def line(self) -> str:
        """``PASS rate           100.02 Hz ...``: the report line."""
        return f"{'PASS' if self.passed else 'FAIL'}  {self.name:<13} {self.figure}"


@dataclass(frozen=True)
class Limits:
    """Every limit a clause compares against (docs/check-rig.md lists them)."""

    dt: float = DT
    """Sample period the node must keep, s."""
    rate_tolerance: float = 0.005
    """Allowed relative error of the mean publish rate (0.5 %)."""
    p99_limit: float = 0.025
    """Largest allowed 99th percentile of the inter-arrival gap, s."""
    gap_fraction: float = 0.01
    """Largest allowed fraction of stamp periods longer than 1.5 dt (lost or skipped samples)."""
    timing_tolerance: float = 1.0
    """Factor on the timing limits above and on the watchdog's slack (tests on loaded machines: > 1)."""
    force_limit: float = 10.0
    """The node's saturation limit F, N."""
    reach_within: float = 0.5
    """The effort must reach a commanded step within this long, s."""
    reach_fraction: float = 0.02
    """"Reached": within this fraction of the step size of the command."""
    watchdog_timeout: float = 0.5
    """Declared watchdog timeout, s."""
    position_tolerance: float = 1e-9
    """Largest allowed |position - joint_states.position| for the same sample, m."""
    rest_tolerance: float = 0.01
    """How close to the origin a reset must bring the measured position, m (covers sensor noise)."""
    reset_within: float = 0.5
    """A real-time reset must show within this long, s."""

    @property
    def force_tolerance(self) -> float:
        """Slack on "at most F": float rounding of a clamp, never a physical overshoot."""
        return 1e-9 * max(1.0, self.force_limit)


# --- graph clauses -------------------------------------------------------------------------------

def publishers_clause(publishers: dict[str, int], force_subscribers: int, namespace: str = "",
                      command: str = "force") -> Clause:
    """Exactly one publisher on every telemetry topic and a subscriber on the command topic.

    Why: two publishers on ``joint_states`` interleave two sample streams (a
    second driver, a forgotten emulator) and a bag of them is garbage.
    ``publishers``: absolute topic -> publisher count, shown relative to ``namespace``;
    ``command``: the command topic's relative name (``force``, or ``<controller>/commands``).
    """
    bad = [f"{topic} has {n}" for topic, n in publishers.items() if n != 1]
    if force_subscribers < 1:
        bad.append(f"{command} has no subscriber")
    prefix = namespace.rstrip("/") + "/"
    counts = ", ".join(f"{topic.removeprefix(prefix)} {n}" for topic, n in publishers.items())
    if bad:
        return Clause("publishers", False, "; ".join(bad) + " (want exactly 1 publisher each)")
    return Clause("publishers", True, f"1 each ({counts}); {command} subscribers {force_subscribers}")


def qos_clause(reliabilities: dict[str, list[str]]) -> Clause:
    """Every endpoint of the node on the contract's topics is reliable.

    Why: a best-effort ``joint_states`` drops samples under load and the bag
    silently has holes; a best-effort ``force`` subscription drops commands.
    """
    bad = [f"{topic} {kind}" for topic, kinds in reliabilities.items()
           for kind in kinds if kind != "reliable"]
    if bad:
        return Clause("qos", False, "not reliable: " + ", ".join(bad))
    return Clause("qos", True, f"reliable on {len(reliabilities)} endpoints")


def mode_clause(real_time_rows: int, lockstep_rows: int | None, listened: float) -> Clause:
    """Which clock mode the node runs: timer-driven real time, or one step per command.

    ``real_time_rows``: rows that arrived while no command was sent;
    ``lockstep_rows``: rows one probe command produced (None: not probed).
    """
    if real_time_rows > 1:
        return Clause("mode", True, f"real-time ({real_time_rows} rows in {listened:.2f} s without commands)")
    if lockstep_rows is not None and lockstep_rows >= 1:  # how many per command is the steps clause's
        return Clause("mode", True, f"lock-step (no rows without a command; a command gave {lockstep_rows})")
    probed = "not probed" if lockstep_rows is None else f"a command produced {lockstep_rows} rows"
    return Clause("mode", False, f"neither real-time nor lock-step: {real_time_rows} rows in "
                                 f"{listened:.2f} s without commands, {probed}")


# --- timing clauses (real time) ------------------------------------------------------------------

def stamp_clock_rate(arrivals: FloatArray, stamps_ns: NDArray[np.int64], segments: int = 10) -> float:
    """Seconds of stamp time the node advances per second of wall time (1 for a node keeping time).

    The slope of the lower envelope of lateness (arrival - stamp) against
    arrival: the least-late row of each of ``segments`` stretches, and the
    median of the slopes between them (Theil-Sen). Why not the mean period of
    arrivals: a node that stalls and catches up (as the plant's deadline pacer
    does) delivers a burst of late rows mid-record, which pulls any fit through
    all arrivals; the least-late rows are the ones the load did not touch.
    The clock offset between stamps and arrivals cancels.
    """
    t = np.asarray(arrivals, dtype=np.float64)
    late = t - np.asarray(stamps_ns, dtype=np.float64) * 1e-9
    chunks = [c for c in np.array_split(np.arange(t.size), segments) if c.size]
    pts = [(t[c[np.argmin(late[c])]], float(late[c].min())) for c in chunks]
    slopes = [(b[1] - a[1]) / (b[0] - a[0]) for i, a in enumerate(pts) for b in pts[i + 1:] if b[0] > a[0]]
    return 1.0 - float(np.median(slopes)) if slopes else math.nan


def rate_clause(arrivals: FloatArray, stamps_ns: NDArray[np.int64], limits: Limits) -> Clause:
    """Rows per wall-clock second within ``rate_tolerance`` of 1/dt.

    Rate = (stamp seconds per wall second, :func:`stamp_clock_rate`) / (median
    stamp period): a node stamping 10 ms apart but publishing every 12.5 ms
    runs its stamp clock at 0.8 and fails at 80 Hz; one that stalls and
    catches up keeps 1.0.
    """
    s = np.asarray(stamps_ns, dtype=np.int64)
    if len(arrivals) < 20:
        return Clause("rate", False, f"only {len(arrivals)} rows received")
    period = float(np.median(np.diff(s))) * 1e-9
    speed = stamp_clock_rate(arrivals, s)
    if not (period > 0 and math.isfinite(speed) and speed > 0):
        return Clause("rate", False, "stamps do not advance with wall time")
    rate = speed / period
    want = 1.0 / limits.dt
    err = abs(rate / want - 1.0)
    allowed = limits.rate_tolerance * limits.timing_tolerance
    return Clause("rate", err <= allowed, f"{rate:.2f} Hz over {len(arrivals)} rows ({100 * err:.2f} % off "
                                          f"{want:g} Hz; limit {100 * allowed:.2f} %)")


def stamps_clause(stamps_ns: NDArray[np.int64], limits: Limits) -> Clause:
    """Stamps strictly increase, their median period is dt, and few periods are gaps.

    The median period and monotonicity are asserted strictly (a stamp is the
    node's own account of when it sampled); the fraction of gaps (a period
    over 1.5 dt: a stall that lost samples) is a timing limit.
    """
    s = np.asarray(stamps_ns, dtype=np.int64)
    if s.size < 3:
        return Clause("stamps", False, f"only {s.size} rows received")
    d = np.diff(s).astype(np.float64) * 1e-9
    backwards = int(np.sum(d <= 0))
    median = float(np.median(d))
    period_err = abs(median / limits.dt - 1.0)
    gaps = float(np.mean(d > 1.5 * limits.dt))
    fig = (f"median period {1e3 * median:.3f} ms ({100 * period_err:.2f} % off), "
           f"{backwards} not increasing, {100 * gaps:.1f} % gaps")
    if backwards:
        return Clause("stamps", False, fig + " — stamps must strictly increase")
    if period_err > limits.rate_tolerance:
        return Clause("stamps", False, fig + f" — period must be {1e3 * limits.dt:g} ms within "
                                             f"{100 * limits.rate_tolerance:g} %")
    if gaps > limits.gap_fraction * limits.timing_tolerance:
        allowed = 100 * limits.gap_fraction * limits.timing_tolerance
        return Clause("stamps", False, fig + f" — more than {allowed:g} %")
    return Clause("stamps", True, fig)


def interarrival_clause(arrivals: FloatArray, limits: Limits) -> Clause:
    """99th percentile of the gap between consecutive ``joint_states`` arrivals.

    Why: a controller closing the loop at 100 Hz over this node needs each
    sample soon after the previous one, not only the right mean rate.
    """
    if len(arrivals) < 10:
        return Clause("inter-arrival", False, f"only {len(arrivals)} rows received")
    gaps = np.diff(np.asarray(arrivals, dtype=np.float64))
    p99 = float(np.percentile(gaps, 99))
    limit = limits.p99_limit * limits.timing_tolerance
    return Clause("inter-arrival", p99 <= limit,
                  f"p99 {1e3 * p99:.1f} ms, max {1e3 * float(gaps.max()):.1f} ms (limit {1e3 * limit:g} ms)")


# --- lock-step clauses ---------------------------------------------------------------------------

def lockstep_steps_clause(rows_per_command: list[int], positions_per_command: list[int],
                          idle_rows: int, stamps_ns: NDArray[np.int64], dt: float) -> Clause:
    """Lock-step: each finite command gives exactly one row and one position, stamps k·dt apart, none idle."""
    n = len(rows_per_command)
    wrong = [i for i, (r, p) in enumerate(zip(rows_per_command, positions_per_command, strict=True))
             if r != 1 or p != 1]
    d = np.diff(np.asarray(stamps_ns, dtype=np.int64))
    off = int(np.sum(d != round(dt * 1e9)))
    fig = f"{n} commands, {n - len(wrong)} gave exactly one row and one position; {idle_rows} rows while idle"
    if wrong:
        i = wrong[0]
        return Clause("steps", False, fig + f" — command {i} gave {rows_per_command[i]} rows, "
                                            f"{positions_per_command[i]} positions")
    if idle_rows:
        return Clause("steps", False, fig + " — a lock-step node must not step without a command")
    if off:
        return Clause("steps", False, fig + f" — {off} stamp periods differ from {dt * 1e3:g} ms")
    return Clause("steps", True, fig + f", stamps {dt * 1e3:g} ms apart")


def clock_clause(clock_publishers: list[str], node: str, clock_ns: list[int],
                 expected_ns: list[int]) -> Clause:
    """At most one ``/clock`` publisher in the graph; if it is this node, it tells each step's end.

    ``clock_ns``: /clock values received after the commands whose rows ended
    at ``expected_ns`` (stamp + dt). Why one owner: two /clock publishers make
    sim time jump between them, and every sim-time bag and node goes wrong.
    """
    if len(clock_publishers) > 1:
        owners = ", ".join(clock_publishers)
        return Clause("clock", False, f"{len(clock_publishers)} /clock publishers ({owners}); "
                                      "at most one may own sim time")
    if node not in clock_publishers:
        owner = clock_publishers[0] if clock_publishers else "none"
        return Clause("clock", True, f"not published by this node (owner: {owner})")
    if clock_ns != expected_ns:
        got = clock_ns[:3]
        return Clause("clock", False, f"/clock {got}... differs from stamp + dt {expected_ns[:3]}...")
    return Clause("clock", True, f"published by this node: {len(clock_ns)} values, each = row stamp + dt")


# --- position ------------------------------------------------------------------------------------

class Alignment(NamedTuple):
    """How ``position`` lines up with ``joint_states.position``."""

    offset: int
    """``position[j]`` is compared with ``joint_states[j + offset]``."""
    max_diff: float
    """Largest |difference| over the overlap, m."""
    overlap: int
    """Samples compared."""


def align_positions(js_x: FloatArray, pos: FloatArray, skip: int = 0,
                    max_offset: int = 50) -> Alignment | None:
    """The offset (in received messages) at which the two streams agree best.

    Why search an offset: the two subscriptions of the checker may start
    receiving at different samples; the contract fixes which *sample*
    ``position`` carries, not which message arrived first. The ``skip``
    largest differences are left out of ``max_diff``: the one sample a
    real-time reset replaces (``position`` already carried x_{k+1}, the next
    row is x_0) is not a disagreement.
    """
    a, b = np.asarray(js_x, dtype=np.float64), np.asarray(pos, dtype=np.float64)
    best: Alignment | None = None
    best_median = math.inf
    for s in range(-max_offset, max_offset + 1):
        lo, hi = max(0, -s), min(b.size, a.size - s)
        if hi - lo < 5:
            continue
        diff = np.sort(np.abs(b[lo:hi] - a[lo + s:hi + s]))
        median = float(np.median(diff))
        if median < best_median or (median == best_median and best is not None and abs(s) < abs(best.offset)):
            kept = diff[:max(1, diff.size - skip)]
            best, best_median = Alignment(s, float(kept[-1]), hi - lo), median
    return best


def position_clause(js_x: FloatArray, pos: FloatArray, limits: Limits, resets: int = 0) -> Clause:
    """``position`` carries the same measured samples as ``joint_states``, one for one.

    Compared after the best offset (:func:`align_positions`), ``resets``
    samples excluded; the tolerance is ``position_tolerance`` (default: equal
    up to float rounding), since the contract has one measurement per sample
    published on both topics.
    """
    if len(js_x) < 5 or len(pos) < 5:
        return Clause("position", False, f"too few samples ({len(js_x)} joint_states, {len(pos)} position)")
    if not (np.all(np.isfinite(js_x)) and np.all(np.isfinite(pos))):
        return Clause("position", False, "non-finite positions published")
    al = align_positions(js_x, pos, skip=resets)
    if al is None:
        return Clause("position", False, "streams too short to align")
    fig = f"max |position - joint_states.position| {al.max_diff:.3g} m over {al.overlap} samples"
    if resets:
        fig += " (the sample at the reset excluded)"
    if al.max_diff > limits.position_tolerance:
        return Clause("position", False, fig + f" (limit {limits.position_tolerance:g} m)")
    # How many messages each subscription saw is a delivery-timing matter (a subscriber that
    # matched late, or a starved checker), so the count slack scales with the timing tolerance.
    if abs(len(js_x) - len(pos)) > max(50, 0.1 * len(js_x)) * limits.timing_tolerance:
        return Clause("position", False,
                      fig + f", but {len(pos)} position vs {len(js_x)} joint_states messages")
    return Clause("position", True, fig)


def joint_clause(rows: int, missing: int, joint: str, names: list[str]) -> Clause:
    """Every ``joint_states`` row carries our joint (ros2_control face: found by name, in any order).

    Why: a joint state broadcaster lists every joint of the robot; a bench
    that read the first entry, or a row without ours, would identify another
    joint's motion. ``names``: the joint names of the last row.
    """
    if rows == 0:
        return Clause("joint", False, f"no joint_states row to look for {joint!r} in")
    if missing:
        return Clause("joint", False, f"{missing} of {rows} rows lack joint {joint!r} (last row: {names})")
    where = names.index(joint) + 1 if joint in names else 0
    return Clause("joint", True, f"{joint!r} in all {rows} rows (entry {where} of {len(names)}: {names})")


# --- effort --------------------------------------------------------------------------------------

class StepResponse(NamedTuple):
    """How the applied force followed a commanded step."""

    delay: int
    """Rows from the first row that could carry the command to the first that moved (-1: never moved)."""
    tau: float
    """First-order time constant fitted to the rise, s (0: the whole step in one row)."""
    reached: float
    """Time from the first row that could carry the command to within ``reach_fraction``, s (inf: never)."""
    peak: float
    """Largest |effort| over the window, N."""


def stamps_on_clock(stamps_ns: NDArray[np.int64], arrivals_ns: NDArray[np.int64]) -> bool:
    """Whether the node stamps on the checker's wall clock: its rows arrive 0-0.5 s after their stamps.

    Then command times and row stamps share one timeline, the node's own,
    which CPU starvation of the checker does not distort.
    """
    s = np.asarray(stamps_ns, dtype=np.int64)
    a = np.asarray(arrivals_ns, dtype=np.int64)
    if s.size < 20:
        return False
    lag = float(np.median(a - s))
    speed = stamp_clock_rate(a.astype(np.float64) * 1e-9, s)
    return -5_000_000 <= lag <= 500_000_000 and abs(speed - 1.0) <= 0.02  # and it runs at our clock's rate


def first_carrier(stamps_ns: NDArray[np.int64], arrivals_ns: NDArray[np.int64], sent_ns: int,
                  fallback: int) -> int:
    """Index of the first row that could carry a command sent at ``sent_ns`` (wall clock, ns).

    The first row stamped at or after the send time, if the node stamps on the
    checker's clock (its rows arrive 0–0.5 s after their stamps); else
    ``fallback`` (the first row to arrive after sending). Why stamps: a checker
    starved of CPU reads rows late, and counting from the rows it had not yet
    read would add their number to the measured delay.
    """
    s = np.asarray(stamps_ns, dtype=np.int64)
    if not stamps_on_clock(s, arrivals_ns):
        return fallback
    later = np.flatnonzero(s >= sent_ns)
    return int(later[0]) if later.size else fallback


def step_response(efforts: FloatArray, first: int, before: float, target: float,
                  limits: Limits) -> StepResponse:
    """Delay, time constant and reach time of ``efforts`` after a step from ``before`` to ``target``.

    ``first`` is the index of the first row that could carry the command
    (:func:`first_carrier`). The time constant comes from the remaining
    fraction r_j of the rows from the first move while it is between 2 % and
    100 %: a first-order lag shrinks it by e^(-dt/τ) per sample, whether the
    row reports the lag's value at the sample or its mean over the sample, so
    τ = -dt / (slope of ln r_j against j); with one such row, ln r_0 = -dt/τ.
    A node that applies the step at once has τ = 0.
    """
    e = np.asarray(efforts, dtype=np.float64)[first:]
    size = target - before
    peak = float(np.max(np.abs(e))) if e.size else 0.0
    if e.size == 0 or size == 0:
        return StepResponse(-1, math.inf, math.inf, peak)
    remaining = (target - e) / size
    moved = np.flatnonzero(np.abs(1.0 - remaining) >= limits.reach_fraction)
    near = np.flatnonzero(np.abs(remaining) <= limits.reach_fraction)
    reached = float(near[0]) * limits.dt if near.size else math.inf
    if moved.size == 0:
        return StepResponse(-1, math.inf, reached, peak)
    d = int(moved[0])
    r = remaining[d:]
    keep = (r > limits.reach_fraction) & (r < 1.0)
    if not keep.size or not keep[0]:
        return StepResponse(d, 0.0, reached, peak)
    stop = keep.size if np.all(keep) else int(np.argmin(keep))  # the first contiguous run
    logs = np.log(r[:stop])
    slope = float(np.polyfit(np.arange(stop, dtype=np.float64), logs, 1)[0]) if stop > 1 else 0.0
    tau = -limits.dt / slope if slope < 0 else -limits.dt / float(logs[0])
    return StepResponse(d, tau, reached, peak)


def effort_step_clause(resp: StepResponse, target: float, limits: Limits) -> Clause:
    """The applied force follows a commanded step: reaches it within ``reach_within``, never above F.

    Delay (rows) and time constant are printed, not judged: a real actuator
    has both, and identification models them; what poisons a fit is an
    effort that never becomes the command, or one above the limit. The rise
    (first row that moved to within 2 %) is held to ``reach_within`` strictly,
    being counted in samples; the whole time from the command, which a stalled
    process lengthens, to ``reach_within`` times ``timing_tolerance``.
    """
    fig = (f"step to {target:g} N: delay {resp.delay} samples, time constant {1e3 * resp.tau:.1f} ms, "
           f"reached in {resp.reached * 1e3:.0f} ms" if math.isfinite(resp.reached)
           else f"step to {target:g} N: effort never within {100 * limits.reach_fraction:g} % "
                f"(delay {resp.delay} samples)")
    if resp.peak > limits.force_limit + limits.force_tolerance:
        return Clause("effort-step", False,
                      fig + f" — effort {resp.peak:g} N exceeds the limit {limits.force_limit:g} N")
    rise = resp.reached - max(resp.delay, 0) * limits.dt  # from the first row that moved
    if not (rise <= limits.reach_within and resp.reached <= limits.reach_within * limits.timing_tolerance):
        return Clause("effort-step", False,
                      fig + f" — must reach the command within {limits.reach_within:g} s")
    return Clause("effort-step", True, fig)


def saturation_clause(efforts: FloatArray, commanded: float, limits: Limits) -> Clause:
    """A command beyond ±F is applied as ±F: the effort settles at the limit and never passes it.

    ``efforts``: the rows while the over-limit command was held (long enough
    for the measured lag to settle).
    """
    e = np.asarray(efforts, dtype=np.float64)
    if e.size == 0:
        return Clause("saturation", False, "no rows while commanding beyond the limit")
    bound = math.copysign(limits.force_limit, commanded)
    peak = float(np.max(np.abs(e)))
    settled = float(e[-1])
    fig = f"command {commanded:g} N: effort settles at {settled:g} N, peak |effort| {peak:g} N"
    if not np.all(np.isfinite(e)) or peak > limits.force_limit + limits.force_tolerance:
        return Clause("saturation", False, fig + f" — exceeds the limit {limits.force_limit:g} N")
    if abs(settled - bound) > limits.reach_fraction * limits.force_limit:
        return Clause("saturation", False, fig + f" — should settle at {bound:g} N")
    return Clause("saturation", True, fig)


def nonfinite_clause(efforts: FloatArray, positions: FloatArray, effort_before: float,
                     last_safe: float, sent: int, limits: Limits) -> Clause:
    """NaN and ±inf commands are rejected: the applied force stays a safe, finite one.

    Safe: between the effort before the first non-finite command, the last
    finite command and 0 N (a node may hold the last safe force, or stop), so
    an actuator lag still passes and a node that turns +inf into +F does not.
    """
    e = np.asarray(efforts, dtype=np.float64)
    x = np.asarray(positions, dtype=np.float64)
    if not (np.all(np.isfinite(e)) and np.all(np.isfinite(x))):
        return Clause("non-finite", False,
                      f"{sent} non-finite commands: non-finite effort or position published")
    lo = min(effort_before, last_safe, 0.0) - limits.reach_fraction * limits.force_limit
    hi = max(effort_before, last_safe, 0.0) + limits.reach_fraction * limits.force_limit
    if e.size and (e.min() < lo or e.max() > hi):
        bad = float(e[np.argmax((e < lo) | (e > hi))])
        return Clause("non-finite", False, f"{sent} non-finite commands: effort {bad:g} N applied "
                                           f"(safe: {last_safe:g} N held, or 0 N)")
    return Clause("non-finite", True, f"{sent} non-finite commands rejected: effort stayed in "
                                      f"[{lo:.3g}, {hi:.3g}] N over {e.size} rows")


def watchdog_allowance(resp: StepResponse, limits: Limits) -> float:
    """How long after the last command the effort may take to read 0 N, s.

    The declared timeout, plus the actuator's measured delay and five time
    constants (a first-order lag reaches 0 N within 2 % after four; one more
    for a time constant fitted a little short), plus one sample and a
    scheduling slack that scales with ``timing_tolerance``.
    """
    delay = max(resp.delay, 0) if math.isfinite(resp.tau) else 0
    tau = resp.tau if math.isfinite(resp.tau) else 0.0
    return (limits.watchdog_timeout + (delay + 1) * limits.dt + 5.0 * tau
            + 0.05 * limits.timing_tolerance)


def watchdog_clause(row_times: FloatArray, efforts: FloatArray, last_command: float, held: float,
                    allowance: float, limits: Limits) -> Clause:
    """Without commands the node applies 0 N within the declared watchdog timeout.

    ``row_times`` and ``last_command`` on one clock (s); ``held`` is the force
    commanded until then. "0 N": within ``reach_fraction`` of the held force.
    """
    t = np.asarray(row_times, dtype=np.float64)
    e = np.asarray(efforts, dtype=np.float64)
    after = t > last_command
    zero = np.flatnonzero(after & (np.abs(e) <= limits.reach_fraction * abs(held)))
    early = np.flatnonzero(after & (t < last_command + limits.watchdog_timeout - 2 * limits.dt)
                           & (np.abs(e) <= limits.reach_fraction * abs(held)))
    if zero.size == 0:
        span = float(t[-1] - last_command) if t.size else 0.0
        return Clause("watchdog", False, f"effort still {float(e[-1]) if e.size else math.nan:g} N "
                                         f"{span:.2f} s after the last command (timeout "
                                         f"{limits.watchdog_timeout:g} s)")
    latency = float(t[zero[0]] - last_command)
    fig = (f"0 N {1e3 * latency:.0f} ms after the last command "
           f"(timeout {1e3 * limits.watchdog_timeout:g} ms, allowed {1e3 * allowance:.0f} ms)")
    if latency > allowance:
        return Clause("watchdog", False, fig)
    if early.size:
        return Clause("watchdog", False, fig + " — dropped the held force before the timeout")
    return Clause("watchdog", True, fig)


def reset_realtime_clause(supported: bool, row_times: FloatArray, positions: FloatArray,
                          efforts: FloatArray, sent_at: float, displaced: float,
                          limits: Limits) -> Clause:
    """Real time: a ``reset`` brings the node to rest at the origin, 0 N, within ``reset_within``.

    A node with no ``reset`` subscriber declares it unsupported, which
    passes: a real rig cannot teleport, and the bench brings it to rest
    itself. ``displaced``: |position| when the reset was sent (it must be
    visibly away from the origin for the reset to be seen at all).
    """
    if not supported:
        return Clause("reset", True,
                      "unsupported (no reset subscriber): the bench returns the node to rest itself")
    if displaced <= 3 * limits.rest_tolerance:
        return Clause("reset", False,
                      f"could not see a reset: the node was only {displaced:.3g} m from the origin")
    t = np.asarray(row_times, dtype=np.float64)
    x = np.asarray(positions, dtype=np.float64)
    e = np.asarray(efforts, dtype=np.float64)
    ok = np.flatnonzero((t > sent_at) & (t <= sent_at + limits.reset_within)
                        & (np.abs(x) <= limits.rest_tolerance) & (np.abs(e) <= limits.force_tolerance))
    if ok.size == 0:
        return Clause("reset", False, f"no row at the origin with 0 N within {limits.reset_within:g} s "
                                      f"of the reset (was {displaced:.3g} m away)")
    after = 1e3 * float(t[ok[0]] - sent_at)
    return Clause("reset", True, f"acknowledged: at the origin with 0 N {after:.0f} ms "
                                 f"after the reset (was {displaced:.3g} m away)")


def reset_lockstep_clause(supported: bool, acks: list[float], rows_before_command: int,
                          first_stamp_ns: int | None, first_x: float | None) -> Clause:
    """Lock-step: a ``reset`` is acknowledged by exactly one ``position`` (x0), and no row; the
    next command's row is sample 0 (stamp 0) at that position."""
    if not supported:
        return Clause("reset", True, "unsupported (no reset subscriber)")
    if len(acks) != 1:
        return Clause("reset", False,
                      f"{len(acks)} position messages acknowledged the reset (want exactly 1)")
    if rows_before_command:
        return Clause("reset", False,
                      f"the reset published {rows_before_command} joint_states rows (want none)")
    if first_stamp_ns is None or first_x is None:
        return Clause("reset", False, "no row after the first command following the reset")
    if first_stamp_ns != 0 or first_x != acks[0]:
        return Clause("reset", False, f"next row has stamp {first_stamp_ns} ns, position {first_x:g} "
                                      f"(want sample 0 at the acknowledged {acks[0]:g})")
    return Clause("reset", True, f"acknowledged by position {acks[0]:g}; next row is sample 0")
