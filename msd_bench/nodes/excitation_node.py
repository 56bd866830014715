"""The excitation node: plays one seeded core signal on the plant's command topic (docs/design.md §Nodes).

The command topic is the plant interface's: ``<ns>/force`` on the msd face,
``<ns>/<controller>/commands`` (one value per controller joint, ours carrying the
force) on the ros2_control face (docs/ros2-control.md §Parameters).

It does not start until its force publisher is matched by a subscriber (the
plant) — a reliable publisher with no reader silently drops the first
samples. In lock-step it also waits for the plant's answers and paces itself
by them: command k + W goes out only after the answer to command k arrived
(W = ``window``; 1 is a strict exchange per command). The answer is
``position`` (x_{k+1}, one Float64 per command, published first), not the
``joint_states`` row that follows it: one reader fewer on the plant's largest
message and a smaller message here (a face without ``position`` answers in
``joint_states``). In
real-time it publishes at 1/dt Hz on a steady-clock timer. A node without
``reset`` (``rest_first``, a rig) is first brought to rest by zero force until
its position is still (:mod:`msd_bench.core.rigs.rest`); the signal then plays from
wherever the mass rests (``x0`` is logged, never assumed).

What a recording relies on: in real time, after the rest's zero commands and the
settle's silence, the node sends exactly the signal's N commands, each once, and nothing
after them, so the last N commands a recorder stored are the signal and the
first of them marks the first played sample of a real-time bag
(:mod:`msd_bench.io.bags.played`).

Done signal: when the whole signal is played the node logs
``excitation done: N commands`` and its ``done`` future completes with 0,
so :func:`msd_bench.nodes.spin.main` returns and the process exits with
status 0 — a launcher waits for the process to end. Timing out on the plant
exits with status 1 and one line.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType  # type: ignore[attr-defined]  # re-exported at run time
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.task import Future
from rclpy.timer import Timer
from std_msgs.msg import Empty, Float64, String

from msd_bench.app.job import shared
from msd_bench.app.serve_protocol import event_line
from msd_bench.core.errors import ConfigError, InterfaceError
from msd_bench.core.identification import excitation as exc
from msd_bench.core.rigs.rest import RestConfig, RestDetector
from msd_bench.nodes import endpoints
from msd_bench.nodes.interface_params import declare_interface
from msd_bench.nodes.params import Section, check_job_used, declare_config, declare_from_dataclass
from msd_msgs_py.contract import (
    JOINT_STATES,
    LOCKSTEP_COMMAND_DEPTH,
    PLANT_NAMESPACE,
    RECORDER_READY,
    RESET,
)
from msd_msgs_py.interface import PlantInterface
from msd_msgs_py.ros import command, msg_class, qos

SIGNALS = ("prbs", "multilevel", "steps")

MAX_SIGNAL_SAMPLES = exc.MAX_SIGNAL_SAMPLES
"""Longest signal a node will build: 28 h at 100 Hz (80 MB of float64). A slip like
``prbs.n_samples:=100000000000`` is refused instead of filling memory and disk."""
SIGNAL_RANGES: dict[str, tuple[float, float]] = {
    "n_samples": (1, MAX_SIGNAL_SAMPLES),
    "settle": (0, MAX_SIGNAL_SAMPLES),
    "hold": (1, 100_000),
    "dwell": (1, MAX_SIGNAL_SAMPLES),
    "min_dwell": (1, MAX_SIGNAL_SAMPLES),
    "max_dwell": (1, MAX_SIGNAL_SAMPLES),
}
"""Bounds of the integer signal fields (samples), shared by every signal kind."""


ROLE = "excitation"
"""The excitation's job role (:mod:`msd_bench.app.job`): bench.py hands it ``-p job:=<file>`` holding
this config's fields and the signal's under ``<signal>.`` (``prbs.bias``), as ``-p`` names them."""

PLAYING_EVENT = "playing"
"""The structured event the node prints as it plays its first command (a launcher waits for it)."""


REALTIME_HISTORY = 256
"""History of the command publisher in real time. The plant takes only the latest command (its
subscription keeps one), but the recorder must get every one: the cut checks the last commands it
recorded against the signal. With a history of one, a reliable writer may replace a command a loaded
recorder has not yet acknowledged when the timer catches up two ticks at once. (The cuts refused as
ambiguous beside a second suite had another cause: the supervisor's watch wrote 0 N on the plant's
command topic during the unsupervised recording; ``SupervisorNode._in_charge`` ends that.)"""


@dataclass(frozen=True)
class ExcitationNodeConfig:
    """Which signal to play and how to pace it."""

    signal: str = "prbs"
    """Signal kind: prbs (around a bias), multilevel (switching with dwell limits) or steps."""
    seed: int = 0
    """Seed of the signal generator (the same seed plays the same signal)."""
    lockstep: bool = False
    """Pace by the plant's answers (one ``position`` per command) instead of a timer."""
    dt: float = field(default=shared("dt"), metadata={"range": (1e-4, 10.0)})
    """Real-time only: seconds between commands (the plant's sample time)."""
    start_timeout: float = field(default=30.0, metadata={"range": (0.1, 3600.0)})
    """Seconds to wait for the plant to be matched before giving up."""
    settle: float = field(default=0.3, metadata={"range": (0.0, 10.0)})
    """Seconds between matching and the first command, so the plant's side has matched too."""
    sample_timeout: float = field(default=5.0, metadata={"range": (0.1, 600.0)})
    """Lock-step only: seconds to wait for a sample before giving up (the first is resent once)."""
    window: int = field(default=1, metadata={"range": (1, LOCKSTEP_COMMAND_DEPTH)})
    """Lock-step only: commands in flight ahead of the samples that came back (1 = one exchange per
    command). The signal is open loop, so nothing waits on a sample's value; more in flight lets the
    plant, this node and a recorder work at once. The plant's lock-step command history holds
    ``LOCKSTEP_COMMAND_DEPTH``; the window opens after the first sample, which proves the plant listens."""
    reset_first: bool = False
    """Publish <ns>/reset once matched (before the settle), so the plant starts at rest, sample 0."""
    min_subscribers: int = field(default=1, metadata={"range": (1, 64)})
    """Force subscribers to wait for: the plant, plus e.g. a recorder that must see every command."""
    wait_recorder: str = ""
    """Bag path of a recorder to wait for (its latched ``recorder/ready``); empty = none."""
    rest_first: bool = False
    """A node without ``reset`` (a rig): command zero force until the position is still, then play."""
    rest_window: int = field(default=300, metadata={"range": (4, 10_000_000)})
    """Samples the stillness is judged over (:class:`msd_bench.core.rigs.rest.RestConfig`)."""
    rest_threshold: float = field(default=0.005, metadata={"range": (1e-6, 1e3)})
    """Largest position standard deviation at rest, m (above the sensor's noise)."""
    rest_timeout: float = field(default=30.0, metadata={"range": (0.1, 3600.0)})
    """Seconds of zero force after which the signal plays even if the mass never looked still."""
    pooled: bool = False
    """Lock-step only, in a served process: keep the publishers and subscriptions (already matched)
    for the next job (:mod:`msd_bench.nodes.endpoints`); the settle then counts from their first
    match, not from this job's start."""

    def __post_init__(self) -> None:
        if self.signal not in SIGNALS:
            raise ConfigError(f"signal must be one of {', '.join(SIGNALS)}, got {self.signal!r}")
        if self.reset_first and self.rest_first:
            raise ConfigError("reset_first and rest_first exclude each other (a node has reset or not)")
        if self.pooled and not self.lockstep:
            raise ConfigError("pooled needs lockstep: a free-running plant publishes between experiments")

    def rest(self) -> RestConfig:
        """The stillness test of ``rest_first``."""
        return RestConfig(self.rest_window, self.rest_threshold, self.rest_timeout)


SIGNAL_SECTIONS: tuple[Section, ...] = (
    ("prbs.", exc.PrbsConfig, SIGNAL_RANGES),
    ("multilevel.", exc.MultilevelConfig, SIGNAL_RANGES),
    ("steps.", exc.StepsConfig, SIGNAL_RANGES),
)
"""The signal kinds' configs, each declared under its prefix (``prbs.bias``), in a job file too."""
SECTIONS: tuple[Section, ...] = (("", ExcitationNodeConfig, None), *SIGNAL_SECTIONS)
"""Every config the node declares besides the face (:func:`msd_bench.nodes.params.sections_from_job`)."""


def build_signal(
    cfg: ExcitationNodeConfig,
    prbs: exc.PrbsConfig,
    multilevel: exc.MultilevelConfig,
    steps: exc.StepsConfig,
) -> np.ndarray:
    """The force sequence the node plays: exactly the core generator's output."""
    if cfg.signal == "prbs":
        return exc.prbs(prbs, cfg.seed)
    if cfg.signal == "multilevel":
        return exc.multilevel(multilevel, cfg.seed)
    return exc.steps(steps)


class ExcitationNode(Node):
    """Publish a precomputed force sequence once the plant listens; complete ``done``."""

    def __init__(
        self,
        *,
        signal: np.ndarray | None = None,
        config: ExcitationNodeConfig | None = None,
        node_name: str = "excitation",
        namespace: str = PLANT_NAMESPACE,
        interface: PlantInterface | None = None,
        **node_kwargs: Any,
    ) -> None:
        """``signal``/``config``/``interface`` given directly (tests) or read from parameters."""
        super().__init__(node_name, namespace=namespace, **node_kwargs)
        self.config = config or declare_config(self, ExcitationNodeConfig, ROLE)
        self.interface = interface or declare_interface(self)
        if self.config.reset_first and self.interface.reset is None:
            raise ConfigError(f"reset_first: the {self.interface.kind} interface has no reset")
        self.signal = np.asarray(signal if signal is not None else self._declare_signal(), dtype=float)
        check_job_used(self)  # every field of a job file was taken by one of the declarations above
        self.sent = 0
        self.done: Future[int] = Future()
        cmd = self.interface.command
        depth = max(cmd.depth, self.config.window if self.config.lockstep else REALTIME_HISTORY)
        pooled = self.config.pooled
        self._pub: Publisher[Any] = endpoints.create_publisher(
            self, msg_class(cmd), cmd.name, qos(cmd, depth), pooled)
        self.received = 0
        self._reset = (endpoints.create_publisher(self, Empty, RESET.name, qos(RESET), pooled)
                       if self.config.reset_first else None)
        self._sub = None
        if self.config.lockstep:
            answer = self.interface.position or JOINT_STATES  # every face with reset has position
            self._sub = endpoints.create_subscription(
                self, msg_class(answer), answer.name, self._on_answer, qos(answer), pooled=pooled)
        # Lock-step: the plant acknowledges a reset with one `position`; until it has, a command could
        # reach it before the reset does (another topic, no ordering) and sample 0 would repeat.
        self._reset_acked = self._reset is None or not self.config.lockstep
        self._t_reset = 0.0
        # No reset (a rig): zero force until still; x0 is then wherever the mass rests.
        self._rest = RestDetector(self.config.rest()) if self.config.rest_first else None
        self._t_rest: float | None = None
        self.x0: float | None = None
        if self._rest is not None:
            pos = self.interface.position or self.interface.state  # ros2_control: our joint's row
            self.create_subscription(msg_class(pos), pos.name, self._on_rest_position, qos(pos))
        self._recorders_ready: set[str] = set()
        if self.config.wait_recorder:
            endpoints.create_subscription(self, String, RECORDER_READY.name,
                                          lambda m: self._recorders_ready.add(m.data), qos(RECORDER_READY),
                                          pooled=pooled)
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._t0 = time.monotonic()
        self._t_match: float | None = None
        self._settle_from = 0.0
        """When our endpoints were all first seen matched (or the mass came to rest): the settle's start."""
        self._t_sent = 0.0
        self._resent = False
        self._poll = self.create_timer(0.02, self._on_poll, clock=self._steady)
        self._timer: Timer | None = None

    @property
    def events_executor(self) -> bool:
        """Lock-step: one exchange with the plant per command, so run on the events executor
        (:mod:`.spin`); real time keeps rclpy's default executor and its steady timer."""
        return self.config.lockstep

    def _declare_signal(self) -> np.ndarray:
        configs: list[Any] = [declare_from_dataclass(self, cls, prefix, ranges=ranges)
                              for prefix, cls, ranges in SIGNAL_SECTIONS]  # prbs, multilevel, steps
        return build_signal(self.config, *configs)

    def _matched(self) -> bool:
        if self._pub.get_subscription_count() < self.config.min_subscribers:
            return False
        if self._reset is not None and self._reset.get_subscription_count() == 0:
            return False
        if self.config.wait_recorder and self.config.wait_recorder not in self._recorders_ready:
            return False
        return self._sub is None or self._sub.get_publisher_count() > 0

    def _matched_since(self, now: float) -> float:
        """Since when all our endpoints to the plant have been matched (earlier than ``now`` only for
        endpoints a served process kept from an earlier job)."""
        return endpoints.all_matched_since((self._pub, self._reset, self._sub), now)

    def _on_poll(self) -> None:
        """Wait for the plant, then start; in lock-step also watch for a lost sample."""
        now = time.monotonic()
        if self._timer is None and self.sent == 0:
            self._wait_for_plant(now)
        elif self.config.lockstep and not self.done.done():
            self._watch_sample(now)

    def _wait_for_plant(self, now: float) -> None:
        if self._t_match is None:
            if self._matched():
                self._t_match = now
                self._settle_from = self._matched_since(now)
                self._send_reset(now)
            elif now - self._t0 > self.config.start_timeout:
                self._finish(1, f"no plant matched on {self._pub.topic_name} "
                                f"within {self.config.start_timeout} s")
            return
        if not self._reset_acked:
            if now - self._t0 > self.config.start_timeout:
                self._finish(1, f"the plant did not acknowledge {RESET.resolve(self.get_namespace())} "
                                f"within {self.config.start_timeout} s")
            elif now - self._t_reset > 1.0:
                self._send_reset(now)  # a reset lost on the way: ask again (still before any command)
            return
        if self._rest is not None and self.x0 is None:
            self._rest_step(now)
            return
        if now - self._settle_from < self.config.settle:
            return
        self.get_logger().info(f"plant matched: playing {self.signal.size} commands")
        print(event_line(self.get_name(), PLAYING_EVENT, {"commands": int(self.signal.size)}), flush=True)
        if self.config.lockstep:
            self._send()
        else:
            self._timer = self.create_timer(self.config.dt, self._on_tick, clock=self._steady)

    def _rest_step(self, now: float) -> None:
        """Zero force (also keeps a watchdog fed) until the position is still or the timeout passes."""
        assert self._rest is not None
        self._pub.publish(command(self.interface, 0.0))
        if self._t_rest is None:
            self._t_rest = now
        timed_out = now - self._t_rest > self.config.rest_timeout
        if timed_out and self._rest.samples == 0:
            pos = self.interface.position or self.interface.state
            self._finish(1, f"no {pos.resolve(self.get_namespace())} sample within "
                            f"{self.config.rest_timeout} s of zero force: the initial position is unknown")
            return
        if not (self._rest.still or timed_out):
            return
        self.x0 = self._rest.x0
        if self._rest.still:
            self.get_logger().info(f"at rest after {now - self._t_rest:.1f} s: x0 = {self.x0:+.4f} m")
        else:
            self.get_logger().warning(
                f"not still after {self.config.rest_timeout:.0f} s of zero force (position spread "
                f"{self._rest.spread() * 1e3:.1f} mm); playing from x0 = {self.x0:+.4f} m")
        self._t_match = self._settle_from = now  # the settle counts from here

    def _on_rest_position(self, msg: Any) -> None:
        """A position while resting: ``position``'s value, or our joint's in a joint_states row."""
        if self._rest is None or self._t_rest is None or self.x0 is not None:
            return
        if isinstance(msg, Float64):
            self._rest.push(msg.data)
            return
        try:
            ours = self.interface.pick(list(msg.name), msg.position, msg.velocity, msg.effort)
        except InterfaceError as err:
            self._finish(1, f"resting: {err}")
            return
        self._rest.push(ours.position)

    def _send_reset(self, now: float) -> None:
        if self._reset is not None:
            self._t_reset = now
            self._reset.publish(Empty())

    def _on_answer(self, msg: Any) -> None:
        """Lock-step: before the first command, the reset's acknowledgement; then one per command."""
        if self.sent == 0:
            if self._t_match is not None:  # only a position after our reset counts
                self._reset_acked = True
            return
        self._on_sample(msg)

    def _watch_sample(self, now: float) -> None:
        if now - self._t_sent <= self.config.sample_timeout:
            return
        if self.sent == 1 and not self._resent:  # the first command may race the plant's matching
            self._resent, self.sent = True, 0
            self._send()
            return
        self._finish(1, f"no answer to command {self.sent - 1} within {self.config.sample_timeout} s")

    def _send(self) -> None:
        self._pub.publish(command(self.interface, float(self.signal[self.sent])))
        self.sent += 1
        self._t_sent = time.monotonic()

    def _on_tick(self) -> None:
        if self.sent < self.signal.size:
            self._send()
        if self.sent >= self.signal.size:
            self._pub.wait_for_all_acked(Duration(seconds=2.0))
            self._finish(0, f"excitation done: {self.sent} commands")

    def _on_sample(self, _msg: Any) -> None:
        if self.done.done() or self.sent == 0:
            return
        self.received += 1
        if self.received >= self.signal.size:
            self._finish(0, f"excitation done: {self.sent} commands")
            return
        while self.sent < self.signal.size and self.sent - self.received < self.config.window:
            self._send()

    def _finish(self, status: int, line: str) -> None:
        for timer in (self._timer, self._poll):
            if timer is not None:
                timer.cancel()
        if status == 0:
            self.get_logger().info(line)
        else:
            self.get_logger().error(line)
        if not self.done.done():
            self.done.set_result(status)
