"""The ROS side of ``msd-bench check-rig``: drive a plant-like node through a short script and record.

Thin by design: this module only sends commands and keeps arrays; every
verdict is a pure function of :mod:`msd_bench.core.rigs.conformance`
(docs/check-rig.md describes the script and every clause).

Real time: commands go out in reply to ``joint_states`` rows, as a 100 Hz
controller's would, so the row that can first carry a command is known (the
next one) and the watchdog stays fed; a phase lasts a number of rows, not
of wall-clock seconds. Lock-step: one command at a time, each waited for.
Forces stay small (a fraction of F) except a short over-limit command for
the saturation clause, sent in the direction that brings the node back
toward the origin.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Empty, Float64

from msd_bench.core.errors import InterfaceError
from msd_bench.core.rigs import conformance as cf
from msd_bench.core.rigs.conformance import Clause, Limits
from msd_bench.core.rigs.description import measured_parameters
from msd_msgs_py.contract import CLOCK, FORCE, JOINT_STATES, POSITION, RESET, TRUTH_JOINT_STATES
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface
from msd_msgs_py.ros import command, msg_class, qos

UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"
"""What rclpy names a node whose endpoint is discovered before the participant data naming it."""
NAME_WAIT_S = 10.0
"""The longest wait for discovery to name the nodes behind endpoints (seconds on a loaded machine)."""

NONFINITE = (math.nan, math.nan, math.inf, math.inf, -math.inf, -math.inf)
"""The non-finite commands sent, one per row (lock-step: one at a time)."""


@dataclass(frozen=True)
class Script:
    """What the checker commands (fractions of the force limit) and how long it listens."""

    step_fraction: float = 0.3
    """The step command, as a fraction of F: small and safe."""
    saturation_factor: float = 1.25
    """The over-limit command, as a multiple of F (sent briefly, toward the origin)."""
    seconds: float = 10.0
    """Least telemetry (s) the timing clauses see; the node is listened to until then."""
    discovery_timeout: float = 5.0
    """How long to wait for the node's endpoints to appear, s."""
    listen: float = 0.5
    """Listening without commands to tell real time from lock-step, s."""


@dataclass
class Record:
    """Everything received, in arrival order."""

    stamps: list[int] = field(default_factory=list)
    arrivals: list[float] = field(default_factory=list)
    arrivals_ns: list[int] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    effort: list[float] = field(default_factory=list)
    pos: list[float] = field(default_factory=list)
    clock: list[int] = field(default_factory=list)

    def efforts(self) -> np.ndarray:
        return np.asarray(self.effort, dtype=np.float64)


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _reliability(profile: Any) -> str:
    return "reliable" if profile.reliability == ReliabilityPolicy.RELIABLE else "best-effort"


class RigChecker:
    """One check of one namespace; :meth:`run` returns the clauses in report order."""

    def __init__(self, node: Node, namespace: str, limits: Limits, script: Script,
                 iface: PlantInterface = MSD_INTERFACE) -> None:
        self.node, self.ns, self.limits, self.script = node, namespace.rstrip("/") or "/", limits, script
        self.iface = iface
        self.rec = Record()
        self.missing_joint = 0
        self.names: list[str] = []
        self.executor = SingleThreadedExecutor(context=node.context)
        self.executor.add_node(node)
        self._hold: float | None = None
        self._moves = True
        """Whether the effort step moved the applied effort (else the settle waits are skipped)."""
        self._on_row: Callable[[], None] | None = None
        self.saturated = np.empty(0)
        """The efforts while the over-limit command was held (``check-rig --write-rig``'s force limit)."""
        self.topic = {s.name: s.resolve(self.ns) for s in (JOINT_STATES, POSITION, FORCE, RESET,
                                                             TRUTH_JOINT_STATES)}
        self.topic[FORCE.name] = iface.command.resolve(self.ns)  # the command topic of the face

    # --- plumbing ----------------------------------------------------------------------------

    def spin_for(self, seconds: float) -> None:
        """Spin for ``seconds`` of wall time."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=min(0.01, max(0.0, end - time.monotonic())))

    def spin_until(self, done: Callable[[], bool], timeout: float) -> bool:
        """Spin until ``done()`` or ``timeout`` s; return ``done()``."""
        end = time.monotonic() + timeout
        while not done() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.005)
        return done()

    def names_of(self, infos_of: Callable[[], list[Any]]) -> list[str]:
        """Full names of the nodes behind some endpoints, once discovery has named them.

        DDS reports an endpoint before the participant data that names its node: until then rclpy
        gives ``_NODE_NAME_UNKNOWN_``. On a loaded machine that gap lasts seconds, so the names are
        read again while any is unknown, for at most :data:`NAME_WAIT_S`.
        """
        def names() -> list[str]:
            return [f"{i.node_namespace.rstrip('/')}/{i.node_name}" for i in infos_of()]

        self.spin_until(lambda: not any(UNKNOWN_NODE in n for n in names()), NAME_WAIT_S)
        return names()

    def _discover(self) -> str | None:
        """Wait for the node's endpoints; None if there is no node, else its full name."""
        js, force = self.topic[JOINT_STATES.name], self.topic[FORCE.name]
        n = self.node
        if not self.spin_until(lambda: n.count_publishers(js) > 0 or n.count_subscribers(force) > 0,
                               self.script.discovery_timeout):
            return None
        self.spin_for(0.5)  # let every endpoint of the graph (a second publisher too) be discovered
        found = self.names_of(lambda: n.get_publishers_info_by_topic(js)
                              or n.get_subscriptions_info_by_topic(force))
        return found[0] if found else None

    def _subscribe(self) -> None:
        """Subscribe to the telemetry with a QoS the node's publishers match (reliable or not)."""
        def profile(spec: Any, topic: str) -> QoSProfile:
            p = qos(spec)
            p.depth = 1000
            infos = self.node.get_publishers_info_by_topic(topic)
            if any(i.qos_profile.reliability != ReliabilityPolicy.RELIABLE for i in infos):
                p.reliability = ReliabilityPolicy.BEST_EFFORT  # still receive; the qos clause judges it
            return p
        js, pos = self.topic[JOINT_STATES.name], self.topic[POSITION.name]
        sub = self.node.create_subscription
        subs = [sub(msg_class(JOINT_STATES), js, self._row, profile(JOINT_STATES, js))]
        if self.iface.position is not None:
            subs.append(sub(Float64, pos, self._position, profile(POSITION, pos)))
        self.node.create_subscription(msg_class(CLOCK), CLOCK.name, self._clock, profile(CLOCK, CLOCK.name))
        cmd = self.iface.command
        self.force: Publisher[Any] = self.node.create_publisher(msg_class(cmd), self.topic[FORCE.name],
                                                                qos(cmd))
        self.reset = self.node.create_publisher(Empty, self.topic[RESET.name], qos(RESET))
        self.spin_until(lambda: self.force.get_subscription_count() > 0  # both telemetry streams matched
                        and all(s.get_publisher_count() > 0 for s in subs), self.script.discovery_timeout)
        self.spin_for(0.1)

    def _row(self, msg: Any) -> None:
        r = self.rec
        r.stamps.append(_stamp_ns(msg.header.stamp))
        r.arrivals.append(time.monotonic())
        r.arrivals_ns.append(time.time_ns())
        self.names = list(msg.name)
        try:
            ours = self.iface.pick(self.names, msg.position, msg.velocity, msg.effort)
            x, effort = ours.position, ours.effort
        except InterfaceError:
            self.missing_joint += 1
            x, effort = math.nan, math.nan
        r.x.append(x)
        r.effort.append(effort)
        if self._hold is not None:
            self.command(self._hold)
        if self._on_row is not None:
            self._on_row()

    def _position(self, msg: Float64) -> None:
        self.rec.pos.append(float(msg.data))

    def _clock(self, msg: Any) -> None:
        self.rec.clock.append(_stamp_ns(msg.clock))

    def command(self, u: float) -> None:
        """Publish one force command and remember when."""
        self.force.publish(command(self.iface, u))
        self.last_command = time.monotonic()
        self.last_command_ns = time.time_ns()

    # --- the check ---------------------------------------------------------------------------

    def run(self) -> list[Clause]:
        """Discover, detect the mode, run the script, judge; one FAIL line if there is no node."""
        name = self._discover()
        if name is None:
            return [Clause("node", False, f"no plant-like node on {self.ns}: no publisher on "
                                          f"{self.topic[JOINT_STATES.name]} and no subscriber on "
                                          f"{self.topic[FORCE.name]} "
                                          f"(waited {self.script.discovery_timeout:g} s)")]
        self.name = name
        self._subscribe()
        t0 = time.monotonic()
        self.spin_for(self.script.listen)
        quiet_rows = len(self.rec.stamps)
        probe: int | None = None
        if quiet_rows <= 1:
            before = len(self.rec.stamps)
            self.command(0.0)
            self.spin_for(self.script.listen)
            probe = len(self.rec.stamps) - before
        mode = cf.mode_clause(quiet_rows, probe, time.monotonic() - t0)
        if not mode.passed:
            return [*self._graph_clauses(), mode]
        lockstep = probe is not None and probe >= 1
        body = self._lockstep() if lockstep else self._realtime()
        return [*self._graph_clauses(), mode, *body]

    def measured(self) -> dict[str, float]:
        """The rate, stroke seen and force limit this check measured (:func:`measured_parameters`)."""
        return measured_parameters(self.rec.stamps, self.rec.x, self.saturated)

    def _graph_clauses(self) -> list[Clause]:
        n = self.node
        topics = [self.topic[JOINT_STATES.name]]
        if self.iface.position is not None:
            topics.append(self.topic[POSITION.name])
        truth = self.topic[TRUTH_JOINT_STATES.name]
        if n.count_publishers(truth):
            topics.append(truth)
        pubs = {t: n.count_publishers(t) for t in topics}
        force = self.topic[FORCE.name]
        rel: dict[str, list[str]] = {
            t: [_reliability(i.qos_profile) for i in n.get_publishers_info_by_topic(t)] for t in topics}
        rel[force] = [_reliability(i.qos_profile) for i in n.get_subscriptions_info_by_topic(force)]
        if self._reset_supported():
            rel[self.topic[RESET.name]] = [_reliability(i.qos_profile)
                                           for i in n.get_subscriptions_info_by_topic(self.topic[RESET.name])]
        return [cf.publishers_clause(pubs, n.count_subscribers(force), self.ns, self.iface.command.name),
                cf.qos_clause(rel)]

    def _reset_supported(self) -> bool:
        return self.iface.reset is not None and self.node.count_subscribers(self.topic[RESET.name]) > 0

    def _position_or_joint(self, js_x: np.ndarray, pos: np.ndarray, resets: int = 0) -> Clause:
        """``position`` against ``joint_states`` on the msd face; our joint in every row otherwise."""
        if self.iface.position is None:
            return cf.joint_clause(len(self.rec.stamps), self.missing_joint, self.iface.joint, self.names)
        return cf.position_clause(js_x, pos, self.limits, resets=resets)

    # --- real time ---------------------------------------------------------------------------

    def _timeline(self) -> None:
        """Decide once which clock phases are timed on: the node's stamps, if on our wall clock."""
        self._wall = cf.stamps_on_clock(np.asarray(self.rec.stamps, dtype=np.int64),
                                        np.asarray(self.rec.arrivals_ns, dtype=np.int64))

    def _row_times(self, r: slice) -> np.ndarray:
        """Times of rows ``r`` (s): their stamps on the wall clock, else their arrival (monotonic)."""
        if self._wall:
            return np.asarray(self.rec.stamps[r], dtype=np.float64) * 1e-9
        return np.asarray(self.rec.arrivals[r], dtype=np.float64)

    def _last_command_time(self) -> float:
        """When the last command was sent, on the clock of :meth:`_row_times`."""
        return self.last_command_ns * 1e-9 if self._wall else self.last_command

    def _carrier(self, sent_ns: int, fallback: int) -> int:
        """First row that could carry a command sent at ``sent_ns`` (see core's first_carrier)."""
        if not self._wall:
            return fallback
        return cf.first_carrier(np.asarray(self.rec.stamps, dtype=np.int64),
                                np.asarray(self.rec.arrivals_ns, dtype=np.int64), sent_ns, fallback)

    def _until_row_time(self, t: float, timeout: float) -> None:
        """Spin until a row at or after time ``t`` (clock of :meth:`_row_times`) has arrived."""
        self.spin_until(lambda: bool(self.rec.stamps) and float(self._row_times(slice(-1, None))[0]) >= t,
                        timeout)

    def _rows(self, hold: float | None, rows: int) -> int:
        """Command ``hold`` in reply to each row until ``rows`` rows could carry it; return the first's index.

        Counted on the node's stamps: a checker starved of CPU reads rows late,
        and rows published before the command was sent do not count.
        """
        fallback = len(self.rec.stamps)
        self._hold = hold
        sent = time.time_ns()
        if hold is not None:
            self.command(hold)
            sent = self.last_command_ns
        budget = 2.0 + 3.0 * rows * self.limits.dt * self.limits.timing_tolerance
        self.spin_until(lambda: len(self.rec.stamps) >= self._carrier(sent, fallback) + rows, budget)
        return self._carrier(sent, fallback)

    def _settled(self, hold: float, rows: int) -> int:
        """:meth:`_rows`, then hold on until the last 5 efforts agree within 0.5 % of F (at most 3 s
        more, times the timing tolerance): a stalled node or checker must not cut a phase short."""
        before = self.rec.effort[-1] if self.rec.effort else 0.0
        first = self._rows(hold, rows)
        band = 0.005 * self.limits.force_limit
        change = 0.02 * self.limits.force_limit

        def steady() -> bool:  # and, if the command changed, the effort has moved (not stuck before it)
            if not self._moves:  # the step never moved it: waiting for a settled effort is minutes lost
                return len(self.rec.effort) >= first + 5
            tail = self.rec.effort[-5:]
            moved = abs(hold - before) <= change or abs(tail[-1] - before) > change
            return len(self.rec.effort) >= first + 5 and max(tail) - min(tail) <= band and moved
        self.spin_until(steady, 3.0 * self.limits.timing_tolerance)
        return first

    def _realtime(self) -> list[Clause]:
        lim, F = self.limits, self.limits.force_limit
        a = self.script.step_fraction * F
        self._timeline()
        self._rows(0.0, 20)
        before = self.rec.effort[-1] if self.rec.effort else 0.0
        first = self._rows(a, round((lim.reach_within + 0.3) / lim.dt))
        resp = cf.step_response(self.rec.efforts(), first, before, a, lim)
        self._moves = resp.delay >= 0
        step = cf.effort_step_clause(resp, a, lim)
        settle = self._settle_rows(resp)
        sat_cmd = -self.script.saturation_factor * F  # back toward the origin
        first = self._settled(sat_cmd, settle)
        self.saturated = self.rec.efforts()[first:]
        sat = cf.saturation_clause(self.saturated, sat_cmd, lim)
        self._settled(a, settle)
        nonfinite = self._realtime_nonfinite(a)
        reset = self._realtime_reset(a)
        self._settled(a, settle)
        watchdog = self._realtime_watchdog(a, resp)
        arrivals = self.rec.arrivals
        rest = self.script.seconds - (arrivals[-1] - arrivals[0]) if arrivals else 0.0
        if rest > 0:
            self.spin_for(rest)
        arr = np.asarray(self.rec.arrivals)
        stamps = np.asarray(self.rec.stamps, dtype=np.int64)
        timing = [cf.rate_clause(arr, stamps, lim), cf.stamps_clause(stamps, lim),
                  cf.interarrival_clause(arr, lim)]
        pos = self._position_or_joint(np.asarray(self.rec.x), np.asarray(self.rec.pos),
                                      resets=int(self._reset_supported()))
        return [*timing, pos, step, sat, nonfinite, watchdog, reset]

    def _settle_rows(self, resp: cf.StepResponse) -> int:
        """Rows to hold a command so the measured actuator settles (at least 0.3 s, at most 2.5 s)."""
        tau = resp.tau if math.isfinite(resp.tau) else 0.5
        seconds = (max(resp.delay, 0) + 1) * self.limits.dt + 5.0 * tau + 0.2
        return round(min(2.5, max(0.3, seconds)) / self.limits.dt)

    def _realtime_nonfinite(self, safe: float) -> Clause:
        start = len(self.rec.stamps)
        before = self.rec.effort[-1]
        sequence = iter(NONFINITE)
        self._hold = None

        def next_bad() -> None:
            u = next(sequence, None)
            if u is not None:
                self.command(u)
        self._on_row = next_bad
        next_bad()
        self.spin_until(lambda: len(self.rec.stamps) >= start + len(NONFINITE) + 5, 3.0)
        self._on_row = None
        self._rows(safe, 20)
        r = slice(start + 1, len(self.rec.stamps))
        return cf.nonfinite_clause(self.rec.efforts()[r], np.asarray(self.rec.x[r]), before, safe,
                                   len(NONFINITE), self.limits)

    def _realtime_reset(self, push: float) -> Clause:
        """Push the node visibly away from the origin (at most 3 s), then reset it and watch."""
        supported = self._reset_supported()
        if not supported:
            none = np.array([])
            return cf.reset_realtime_clause(False, none, none, none, 0.0, 0.0, self.limits)
        self._hold = push
        away = 10.0 * self.limits.rest_tolerance
        self.spin_until(lambda: abs(self.rec.x[-1]) > away, 3.0 * self.limits.timing_tolerance)
        self._hold = None
        displaced = abs(self.rec.x[-1])
        start = len(self.rec.stamps)
        self.reset.publish(Empty())
        sent = time.time_ns() * 1e-9 if self._wall else time.monotonic()
        self._until_row_time(sent + self.limits.reset_within + 0.05,
                             self.limits.reset_within + 1.0 * self.limits.timing_tolerance)
        r = slice(start, len(self.rec.stamps))
        return cf.reset_realtime_clause(True, self._row_times(r), np.asarray(self.rec.x[r]),
                                        self.rec.efforts()[r], sent, displaced, self.limits)

    def _realtime_watchdog(self, held: float, resp: cf.StepResponse) -> Clause:
        self._hold = None
        last = self._last_command_time()
        start = len(self.rec.stamps)
        allowance = cf.watchdog_allowance(resp, self.limits)
        self._until_row_time(last + allowance + 0.3, allowance + 0.5 + 1.0 * self.limits.timing_tolerance)
        r = slice(start, len(self.rec.stamps))
        return cf.watchdog_clause(self._row_times(r), self.rec.efforts()[r], last, held, allowance,
                                  self.limits)

    # --- lock-step ---------------------------------------------------------------------------

    def _step(self, u: float) -> tuple[int, int]:
        """Send one command, wait for its row and position; return (rows, positions) it gave.

        Waits 1 s, or 0.1 s once two commands in a row went unanswered, so a
        node that stopped stepping fails the steps clause in seconds, not minutes.
        """
        rows, positions = len(self.rec.stamps), len(self.rec.pos)
        self.command(u)
        wait = 0.1 if getattr(self, "_unanswered", 0) >= 2 else 1.0
        self.spin_until(lambda: len(self.rec.stamps) > rows and len(self.rec.pos) > positions, wait)
        self.executor.spin_once(timeout_sec=0.0)
        got = len(self.rec.stamps) - rows, len(self.rec.pos) - positions
        self._unanswered = getattr(self, "_unanswered", 0) + 1 if got[0] == 0 else 0
        return got

    def _lockstep(self) -> list[Clause]:
        lim, F = self.limits, self.limits.force_limit
        a = self.script.step_fraction * F
        supported = self._lockstep_reset()
        start = len(self.rec.stamps)
        counts: list[tuple[int, int]] = []
        plan = [0.0] * 5 + [a] * 60
        for u in plan:
            counts.append(self._step(u))
        first_row = self.rec.stamps[start] if len(self.rec.stamps) > start else None
        first_x = self.rec.x[start] if len(self.rec.x) > start else None
        reset = cf.reset_lockstep_clause(supported, self._acks, self._reset_rows, first_row, first_x)
        first = start + 5
        resp = cf.step_response(self.rec.efforts(), first, self.rec.effort[first - 1], a, lim)
        step = cf.effort_step_clause(resp, a, lim)
        settle = max(20, self._settle_rows(resp) // 2)
        sat_cmd = -self.script.saturation_factor * F
        first = len(self.rec.stamps)
        counts += [self._step(sat_cmd) for _ in range(settle)]
        self.saturated = self.rec.efforts()[first:]
        sat = cf.saturation_clause(self.saturated, sat_cmd, lim)
        counts += [self._step(a) for _ in range(settle)]
        nonfinite = self._lockstep_nonfinite(a)
        counts += [self._step(a) for _ in range(5)]
        idle_from = len(self.rec.stamps)
        self.spin_for(max(0.5, lim.watchdog_timeout + 0.1))
        idle = len(self.rec.stamps) - idle_from
        stamps = np.asarray(self.rec.stamps[start:idle_from], dtype=np.int64)
        steps = cf.lockstep_steps_clause([c[0] for c in counts], [c[1] for c in counts], idle, stamps, lim.dt)
        clock = self._clock_clause()
        pos = self._position_or_joint(np.asarray(self.rec.x[start:]),
                                      np.asarray(self.rec.pos[self._pos_start:]))
        watchdog = Clause("watchdog", True, "not applicable in lock-step: without a command the node "
                                            "does not step (asserted by the steps clause)")
        return [steps, clock, pos, step, sat, nonfinite, watchdog, reset]

    def _lockstep_reset(self) -> bool:
        """Send ``reset`` (if the node subscribes to it) and keep what answered; return whether it does."""
        self._acks: list[float] = []
        self._reset_rows = 0
        if not self._reset_supported():
            self._pos_start = len(self.rec.pos)
            return False
        rows, positions = len(self.rec.stamps), len(self.rec.pos)
        self.reset.publish(Empty())
        self.spin_until(lambda: len(self.rec.pos) > positions, 2.0)
        self.spin_for(0.2)  # a second acknowledgement or a stray row would arrive by now
        self._acks = self.rec.pos[positions:]
        self._reset_rows = len(self.rec.stamps) - rows
        self._pos_start = len(self.rec.pos)
        return True

    def _lockstep_nonfinite(self, safe: float) -> Clause:
        start = len(self.rec.stamps)
        before = self.rec.effort[-1]
        for u in NONFINITE:
            self.command(u)
            self.spin_for(0.05)
        r = slice(start, len(self.rec.stamps))  # none from a node that rejects them without stepping
        return cf.nonfinite_clause(self.rec.efforts()[r], np.asarray(self.rec.x[r]), before, safe,
                                   len(NONFINITE), self.limits)

    def _clock_clause(self) -> Clause:
        owners = self.names_of(lambda: self.node.get_publishers_info_by_topic(CLOCK.name))
        expected = [s + round(self.limits.dt * 1e9) for s in self.rec.stamps]
        return cf.clock_clause(owners, self.name, list(self.rec.clock), expected)
