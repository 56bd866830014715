"""The supervisor node: :class:`msd_bench.core.safety.supervisor.Supervisor` between a controller and a plant.

It looks like a plant to the controller and like a controller to the plant.
Under its own namespace (``/supervised`` by default) it takes the controller's
commands and relays the plant's state; towards the plant (``plant_ns``) it
publishes the filtered command. Which topics and types that means is the
face's (:class:`msd_msgs_py.interface.PlantInterface`, from the ``interface``
parameters): ``force`` / ``Float64`` and ``position`` and ``reset`` on the
``msd`` face, ``<controller>/commands`` / ``Float64MultiArray`` on the
``ros2_control`` face — the node asks the face object, it never branches on it.

The measured position the filter judges on is the newest the plant reported
(``position`` where the face has it, else the ``joint_states`` row). A
``reset`` from the controller is passed on and starts a new run. The e-stop is
``estop`` (``Empty``: anyone may latch, always honoured) and ``estop_clear``
(``String``: the latch count, docs/faults.md §Trust boundary) under the node's
namespace; on a latch a real-time node sends 0 N to the plant at once, so the
plant applies 0 N from its next sample. A stale state (real time only: no state
for ``stale_timeout``, checked when a command arrives and by the node's own
watch, so a plant that falls silent while its controller waits on it is caught
too: the node then sends 0 N and a run in progress ends) or an e-stop ends the
run as aborted, logged once with its reason. ``/diagnostics`` carries the override
counts by reason, the e-stop state and latch count, and the abort reason.

With ``run_steps`` > 0 (how ``bench.py`` starts it, docs/supervisor.md §bench.py) a ``reference``
starts a *run* of that many state samples: a rig has no ``reset``, and the agent announces each
validation run's set-point as it starts, so that is where a run begins. Each run ends as one
``run`` event line on stdout (:func:`msd_bench.app.serve_protocol.event_line`: its overrides
by reason and its abort, if any), and the node's whole life as one ``supervisor_done`` event
when it closes; the launcher reads them, the node never writes a file. Outside a run (the rests
between runs, a learner training on the rig) no set-point is known, so the divergence detector
has nothing to track; every other guard acts as in a run.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType  # type: ignore[attr-defined]  # re-exported at run time
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from std_msgs.msg import Empty, Float64, String

from msd_bench.app.serve_protocol import event_line
from msd_bench.core.errors import InterfaceError
from msd_bench.core.physics.plant import preset
from msd_bench.core.rigs.scales import Scales
from msd_bench.core.safety.supervisor import (
    MAX_LATCH_TEXT,
    NONE,
    REASONS,
    Decision,
    LogThrottle,
    Supervisor,
    SupervisorOptions,
    parse_latch,
)
from msd_bench.io.storage.supervisor_file import read_options
from msd_bench.nodes.health import diagnostic_array
from msd_bench.nodes.interface_params import declare_interface
from msd_bench.nodes.params import declare_from_dataclass, rig_plant
from msd_msgs_py.contract import DIAGNOSTICS, ESTOP, ESTOP_CLEAR, REFERENCE, TopicSpec
from msd_msgs_py.ros import command, command_force, msg_class, qos

SUPERVISOR_NAMESPACE = "/supervised"
"""Default namespace of the supervisor node: where the controller is pointed."""
NODE_NAME = "supervisor"
"""The node's name; its result events carry it."""
RUN_EVENT = "run"
"""The event of each run that ended (``run_steps`` > 0)."""
DONE_EVENT = "supervisor_done"
"""The event the node prints as it closes: its totals over its whole life."""


@dataclass(frozen=True)
class SupervisorNodeConfig:
    """How the supervisor node is wired (what it guards is :class:`SupervisorOptions`)."""

    plant_ns: str = "/msd"
    """Namespace of the plant the filtered commands go to."""
    preset: str = "default"
    """Plant preset the supervisor's model states (core/physics/plant.py PRESETS); never the rig's truth."""
    options_file: str = ""
    """JSON object of SupervisorOptions fields; empty = the defaults derived from the stroke."""
    reference: float = field(default=1.0, metadata={"range": (-1e4, 1e4)})
    """Set-point the divergence detector tracks until one arrives on ``reference``, m."""
    lockstep: bool = False
    """The plant runs in lock-step: no stale-state check and no extra 0 N on an e-stop (each
    command is one step; the next one the plant gets is 0 N)."""
    run_steps: int = field(default=0, metadata={"range": (0, 100_000_000)})
    """With > 0: each ``reference`` starts a run of this many state samples, reported as a ``run``
    event (a controller without reset: the agent announces each validation run so); 0 = one
    run per ``reset``, no events but ``supervisor_done``."""


class SupervisorNode(Node):
    """Relay state, filter commands, hold the e-stop; thin: the decisions are core's."""

    def __init__(self, *, node_name: str = NODE_NAME, namespace: str = SUPERVISOR_NAMESPACE,
                 **node_kwargs: Any) -> None:
        super().__init__(node_name, namespace=namespace, **node_kwargs)
        self.config = declare_from_dataclass(self, SupervisorNodeConfig)
        self.iface = declare_interface(self)
        plant = rig_plant(preset(self.config.preset))  # a rig file wins over the preset
        scales = Scales.of(plant.L, plant.F, plant.dt)
        opts = (SupervisorOptions().scaled(scales) if not self.config.options_file
                else read_options(Path(self.config.options_file)))
        self.supervisor = Supervisor(opts, plant)
        self._wrong_clears = LogThrottle(1.0)
        self.reference = self.config.reference
        self._y = 0.0
        self._t_state: float | None = None
        self._holding = False
        """The watch sent 0 N for the silence in progress (:meth:`_watch_stale`)."""
        self._t_command: float | None = None
        """When a controller's command last came through (monotonic s): :meth:`_in_charge`."""
        self._logged_abort: str | None = None
        self.runs = RunLog()
        self._wire()
        face = self.iface.describe(self.config.plant_ns)
        self.get_logger().info(f"{self.supervisor.limits.describe()}; {face} behind {self.get_namespace()}")

    def _wire(self) -> None:
        ns, cmd, state = self.config.plant_ns, self.iface.command, self.iface.state
        self._pub_cmd: Publisher[Any] = self.create_publisher(msg_class(cmd), cmd.resolve(ns), qos(cmd))
        self.create_subscription(msg_class(cmd), cmd.name, self._on_command, command_qos(cmd))
        self._pub_state: Publisher[Any] = self.create_publisher(msg_class(state), state.name, qos(state))
        self.create_subscription(msg_class(state), state.resolve(ns), self._on_state, qos(state))
        pos = self.iface.position
        if pos is not None:
            self._pub_pos = self.create_publisher(Float64, pos.name, qos(pos))
            self.create_subscription(Float64, pos.resolve(ns), self._on_position, qos(pos))
        reset = self.iface.reset
        if reset is not None:
            self._pub_reset = self.create_publisher(Empty, reset.resolve(ns), qos(reset))
            self.create_subscription(Empty, reset.name, self._on_reset, qos(reset))
        self._pub_ref = self.create_publisher(Float64, REFERENCE.resolve(ns), qos(REFERENCE))
        self.create_subscription(Float64, REFERENCE.name, self._on_reference, qos(REFERENCE))
        self.create_subscription(Empty, ESTOP.name, self._on_estop, qos(ESTOP))
        self._pub_estop = self.create_publisher(Empty, ESTOP.resolve(ns), qos(ESTOP))
        self.create_subscription(String, ESTOP_CLEAR.name, self._on_clear, qos(ESTOP_CLEAR))
        self._pub_diag = self.create_publisher(DiagnosticArray, DIAGNOSTICS.name, qos(DIAGNOSTICS))
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0, self._on_diagnostics, clock=steady)
        if not self.config.lockstep:
            self._last_watch = time.monotonic()
            self.create_timer(self.supervisor.limits.stale_timeout / STALE_WATCHES, self._watch_stale,
                              clock=steady)

    # --- the plant's side -------------------------------------------------------------------
    def _on_state(self, msg: Any) -> None:
        self._pub_state.publish(msg)
        if self.iface.position is not None:
            return  # the newer position arrives on its own topic
        try:
            self._y = self.iface.pick(msg.name, msg.position, msg.velocity, msg.effort).position
        except InterfaceError as exc:  # relayed as it came; the filter keeps the last good position
            self.get_logger().warning(f"state not usable: {exc}", throttle_duration_sec=5.0)
            return
        self._t_state = time.monotonic()
        self._holding = False
        self._sample()

    def _on_position(self, msg: Float64) -> None:
        self._y = msg.data
        self._t_state = time.monotonic()
        self._holding = False
        self._pub_pos.publish(msg)
        self._sample()

    def _sample(self) -> None:
        """One state sample of the plant: a run lasts ``run_steps`` of them (the plant's clock, not the
        commands: in real time a command can be overtaken by the next one, and a run must still end)."""
        if self.runs.took_last():
            self._end_run()

    # --- the controller's side --------------------------------------------------------------
    def _on_command(self, msg: Any) -> None:
        u = command_force(self.iface, msg)
        if u is None:  # a command the face cannot read (wrong length): the plant's to count
            return
        self._t_command = time.monotonic()
        if not math.isfinite(u):  # judged as 0 N: the plant would keep its last force instead
            u = 0.0
        stale = self._is_stale()
        # outside a run (run_steps mode) there is no set-point to diverge from: the mass is its own
        reference = self.reference if self.config.run_steps == 0 or self.runs.in_run else self._y
        self._send(self.supervisor.stale() if stale else self.supervisor.step(self._y, reference, u))

    def _watch_stale(self) -> None:
        """A plant that stopped reporting: 0 N after ``stale_timeout``, and after
        :data:`SILENT_ABORT_S` (or ``stale_timeout`` if longer) the run ends as aborted (stale).

        Why a watch and not only the check on each command: a controller that waits for the next
        state (every agent here) sends nothing once the plant falls silent, so the check on a
        command never ran and the run never ended. Why two thresholds: an emulated plant on a
        loaded host misses 0.1 s now and then and then goes on; holding 0 N over such a gap costs
        the run little, ending it costs the run. A watch that itself ran late (this process was
        starved) judges nothing this time: the states may be waiting in its own queue."""
        now = time.monotonic()
        starved = now - self._last_watch > self.supervisor.limits.stale_timeout
        self._last_watch = now
        if starved or self._t_state is None or self.supervisor.aborted is not None or not self._in_charge():
            return
        silent = now - self._t_state
        if silent > self.supervisor.limits.stale_timeout and not self._holding:
            self._holding = True
            self._pub_cmd.publish(command(self.iface, 0.0))
            self.get_logger().warning(f"no state for {silent:.2f} s: holding 0 N")
        if silent > max(self.supervisor.limits.stale_timeout, SILENT_ABORT_S):
            self._send(self.supervisor.stale())
            if self.config.run_steps > 0 and self.runs.in_run:
                self._end_run()

    def _in_charge(self) -> bool:
        """Whether a silent plant is this node's to hold at 0 N: a run is in progress, or a controller
        commanded through it within :data:`COMMANDING_WINDOW_S` of the plant's last state.

        Why not always: the node stays in the graph while others command the plant straight (the
        bench's unsupervised recordings, a Dyna-Q agent's real-time training). A 0 N it wrote then
        would land in their experiment: on a loaded host a stalled plant had the watch insert one
        among a recording's commands, and the recording was refused (its commands were not the
        signal's). The plant holds the newest command, so only the node that sent it may replace it."""
        if self.runs.in_run:
            return True
        return (self._t_command is not None and self._t_state is not None
                and self._t_command >= self._t_state - COMMANDING_WINDOW_S)

    def _is_stale(self) -> bool:
        if self.config.lockstep or self._t_state is None:
            return False
        return time.monotonic() - self._t_state > self.supervisor.limits.stale_timeout

    def _send(self, d: Decision) -> None:
        self._pub_cmd.publish(command(self.iface, d.force))
        self.runs.decided(d)
        aborted = self.supervisor.aborted
        if aborted is not None and aborted != self._logged_abort:
            self._logged_abort = aborted
            self.get_logger().warning(f"run aborted: {aborted}; holding 0 N until a reset")
        elif d.reason != NONE and self.supervisor.counts[REASONS[d.reason]] == 1:
            self.get_logger().info(f"override: {REASONS[d.reason]} (first of this run)")

    def _on_reset(self, msg: Empty) -> None:
        self.supervisor.reset()
        self._logged_abort = None
        self._t_state = None
        self._y = 0.0
        self._pub_reset.publish(msg)

    def _on_reference(self, msg: Float64) -> None:
        self.reference = float(msg.data)
        self._pub_ref.publish(msg)
        if self.config.run_steps > 0:
            if self.runs.in_run:  # a run cut short by the next one: reported as it stood
                self._end_run()
            self.supervisor.reset()
            self._logged_abort = None
            self.runs.start(self.config.run_steps, self.reference)

    def _end_run(self) -> None:
        """Report the run that just ended; the next commands are outside a run, judged afresh."""
        record = self.runs.end(self.supervisor)
        print(event_line(NODE_NAME, RUN_EVENT, record), flush=True)
        self.supervisor.reset()
        self._logged_abort = None

    def close(self) -> None:
        """Report an unfinished run and the node's totals (called once before the node is destroyed)."""
        if self.runs.in_run:
            self._end_run()
        print(event_line(NODE_NAME, DONE_EVENT, self.runs.totals(self.supervisor)), flush=True)

    # --- the e-stop -------------------------------------------------------------------------
    def _on_estop(self, _msg: Empty) -> None:
        latch = self.supervisor.latch_estop()
        self._pub_estop.publish(Empty())  # latched at the drive too: 0 N from its next sample
        if not self.config.lockstep:  # and the command it holds is 0 N
            self._pub_cmd.publish(command(self.iface, 0.0))
        self.get_logger().warning(f"e-stop latched (latch {latch}): 0 N; clear with "
                                  f"'{latch}' on {self.get_namespace().rstrip('/')}/{ESTOP_CLEAR.name}")

    def _on_clear(self, msg: String) -> None:
        latch = parse_latch(msg.data[:MAX_LATCH_TEXT + 64])
        if self.supervisor.clear_estop(latch):
            self.get_logger().info(f"e-stop latch {latch} cleared: the next run (after a reset) may go")
        elif count := self._wrong_clears.note(time.monotonic()):
            more = f" (and {count - 1} more wrong clears in the last second)" if count > 1 else ""
            self.get_logger().warning(f"e-stop clear {msg.data[:MAX_LATCH_TEXT]!r} ignored{more}"
                                      f": the current latch is {self.supervisor.estop_latches} "
                                      f"({'latched' if self.supervisor.estop_latched else 'not latched'})")

    def status(self) -> dict[str, Any]:
        """What ``/diagnostics`` reports (also read by tests)."""
        s = self.supervisor
        return {"steps": s.steps, **{f"override_{k}": n for k, n in s.counts.items()},
                "estop": "latched" if s.estop_latched else "clear", "estop_latches": s.estop_latches,
                "aborted": s.aborted or "no", "reference": self.reference}

    def _on_diagnostics(self) -> None:
        s = self.supervisor
        warnings = [f"run aborted: {s.aborted}"] if s.aborted else []
        if s.estop_latched:
            warnings.append(f"e-stop latched (latch {s.estop_latches})")
        self._pub_diag.publish(diagnostic_array(
            self.get_clock().now().to_msg(), f"{self.get_fully_qualified_name()}: supervisor",
            self.config.plant_ns, self.status(), warnings))


SILENT_ABORT_S = 0.5
"""Silence (s) after which the watch ends the run as stale: the plant's own watchdog's default (by
then a drive with one holds 0 N anyway, and a missed sample of a loaded host is long over)."""
COMMANDING_WINDOW_S = 1.0
"""A controller that commanded through the node this long before the plant's last state is the one
the plant listens to (its rate is 1 Hz or more): the watch holds 0 N for it (``_in_charge``)."""
STALE_WATCHES = 2
"""Looks per ``stale_timeout`` the node's watch for a silent plant takes
(:meth:`SupervisorNode._watch_stale`)."""
COMMAND_BACKLOG = 100
"""History of the node's command subscription: after a stall of this node (a loaded host) every
command waiting is filtered in order and the newest is the one the plant holds; the contract's depth
of 1 would drop all but the newest unseen."""


def command_qos(cmd: TopicSpec) -> QoSProfile:
    """The command subscription's QoS: the contract's, with :data:`COMMAND_BACKLOG` of history."""
    profile = qos(cmd)
    profile.depth = max(profile.depth, COMMAND_BACKLOG)
    return profile


class RunLog:
    """The node's bookkeeping of runs (``run_steps`` mode) and of its whole life: counts, no science.

    A run's overrides are the supervisor's own per-run counts (:attr:`Supervisor.counts`, cleared
    by its ``reset`` at the run's start); outside a run they are counted here.
    """

    def __init__(self) -> None:
        self.index = 0
        """Runs started so far."""
        self.length = 0
        """State samples a run lasts."""
        self.left = 0
        """State samples the run in progress still lasts (0: no run in progress)."""
        self.reference = 0.0
        self.records: list[dict[str, Any]] = []
        self.outside = dict.fromkeys(REASONS[1:], 0)
        self.outside_steps = 0
        self.steps = 0

    @property
    def in_run(self) -> bool:
        """Whether a run is in progress."""
        return self.left > 0

    def start(self, steps: int, reference: float) -> None:
        """A run of ``steps`` state samples towards ``reference`` begins."""
        self.index += 1
        self.length = steps
        self.left = steps
        self.reference = reference

    def decided(self, d: Decision) -> None:
        """One command was filtered (counted in the run by the supervisor, outside one here)."""
        self.steps += 1
        if self.in_run:
            return
        self.outside_steps += 1
        if d.reason != NONE:
            self.outside[REASONS[d.reason]] += 1

    def took_last(self) -> bool:
        """After a state sample of the run in progress: True when it was the run's last."""
        if not self.in_run:
            return False
        self.left -= 1
        return self.left == 0

    def end(self, sup: Supervisor) -> dict[str, Any]:
        """The record of the run that ends now (reported as a ``run`` event)."""
        record = {"run": self.index, "reference": self.reference, "samples": self.length - self.left,
                  "steps": sup.steps,
                  "overrides": dict(sup.counts), "overridden": sum(sup.counts.values()),
                  "aborted": sup.aborted, "complete": self.left == 0}
        self.left = 0
        self.records.append(record)
        return record

    def totals(self, sup: Supervisor) -> dict[str, Any]:
        """The node's whole life: runs, commands filtered, overrides inside runs and outside them."""
        inside = dict.fromkeys(REASONS[1:], 0)
        for r in self.records:
            for k, n in r["overrides"].items():
                inside[k] += n
        return {"runs": len(self.records), "steps": self.steps, "overrides": inside,
                "aborted_runs": sum(r["aborted"] is not None for r in self.records),
                "outside_steps": self.outside_steps, "outside_overrides": dict(self.outside),
                "estop_latches": sup.estop_latches}


def build_supervisor() -> SupervisorNode:
    """The node as ``launch_scripts/supervisor.py`` starts it."""
    return SupervisorNode()
