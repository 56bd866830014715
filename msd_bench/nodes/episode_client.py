"""Run control episodes against plant-like nodes over their topics, driven by callbacks.

An :class:`Episode` pairs a controller (anything with ``start(x0)``, ``act()``
and ``observe(x)``) with the namespace of a plant-like node and a length. The
:class:`EpisodeClient` plays a queue of episodes:

* lock-step: publish ``reset``, wait for its acknowledgement (``position`` =
  x_0), then for each step publish ``u_k`` and wait for ``position`` =
  x_{k+1}. One command in flight at a time, so the exchange is deterministic
  and as fast as the middleware allows.
* real-time: publish ``reset``, let the node settle at rest for
  ``settle_s``, then answer every ``position`` sample with a force (the plant
  holds the latest command; its watchdog covers a silent client). The episode
  starts from the last position measured, not from an assumed 0.
* real-time without ``reset`` (``reset=False``, a rig): answer every
  ``position`` with zero force until the position is still
  (:class:`msd_bench.core.rigs.rest.RestDetector`, or its timeout), then start the
  episode from the rest position it measured (the window's mean).

Each namespace speaks a plant interface (``interfaces``; the msd face unless
named): commands go out in the face's message, and on a face without
``position`` (ros2_control) our joint's position in each ``joint_states`` row
answers the last force (docs/ros2-control.md §Face).

When ``record`` is set the episode also collects the node's ``joint_states``
rows (x_k, v_k, applied u_k) so the run can be written as a bag; the episode
ends only once every row has arrived (the two topics are not ordered).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription
from std_msgs.msg import Empty, Float64

from msd_bench.core.errors import InterfaceError, MsdBenchError
from msd_bench.core.rigs.rest import RestConfig, RestDetector
from msd_bench.nodes import endpoints
from msd_msgs_py.contract import JOINT_STATES, POSITION
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface
from msd_msgs_py.ros import command, msg_class, qos


class EpisodeError(MsdBenchError):
    """A plant-like node did not answer as the contract requires."""


class EpisodeAgent(Protocol):
    """What an episode drives: a learner or a fixed policy."""

    def start(self, x0: float) -> None:
        """The node is at rest at ``x0``; the episode begins."""

    def act(self) -> float:
        """Force for the current step, N."""

    def observe(self, x: float) -> None:
        """The position that followed the last force."""


@dataclass
class Episode:
    """One episode to play."""

    controller: EpisodeAgent
    namespace: str
    steps: int
    record: bool = False
    on_done: Callable[[Episode], None] | None = None
    rows: list[tuple[int, float, float, float]] = field(default_factory=list)
    """(stamp ns, x, v, applied force) per sample when ``record`` is set."""
    taken: int = 0
    x0: float | None = None
    """The position the episode started from (measured, not assumed)."""


class _Endpoint:
    """Publishers/subscriptions of one plant-like namespace, through its interface.

    On a face without ``position`` (ros2_control) our joint's position in each
    ``joint_states`` row is the answer to the last force.
    """

    def __init__(self, node: Node, ns: str, client: EpisodeClient, iface: PlantInterface) -> None:
        self.ns = ns
        self.iface = iface
        self.needs_reset = client.reset
        self._node, self._client = node, client
        cmd, pooled = iface.command, client.pooled
        self.force: Publisher[Any] = endpoints.create_publisher(
            node, msg_class(cmd), cmd.resolve(ns), qos(cmd), pooled)
        self.reset = (None if iface.reset is None else endpoints.create_publisher(
            node, Empty, iface.reset.resolve(ns), qos(iface.reset), pooled))
        self.pos = None if iface.position is None else endpoints.create_subscription(
            node, Float64, iface.position.resolve(ns),
            client.guarded(lambda m: client.on_position(ns, m.data)), qos(POSITION), pooled=pooled)
        self.js: Subscription[Any] | endpoints.PooledSubscription | None = None
        if self.pos is None:  # a face without position answers in joint_states
            self.want_rows()

    def want_rows(self) -> bool:
        """Subscribe to ``joint_states`` (once): for recorded episodes, or as the only answer.
        Return whether the subscription is new (so its match has yet to be seen).

        Why not always: training episodes on a surrogate record nothing, and a
        JointState deserialised and dropped on every step costs the ROS training
        path time per step for nothing.
        """
        if self.js is not None:
            return False
        self.js = endpoints.create_subscription(
            self._node, msg_class(JOINT_STATES), JOINT_STATES.resolve(self.ns),
            self._client.guarded(lambda m: self._on_row(self._client, m)), qos(JOINT_STATES),
            pooled=self._client.pooled)
        return True

    def _on_row(self, client: EpisodeClient, msg: Any) -> None:
        try:
            ours = self.iface.pick(list(msg.name), msg.position, msg.velocity, msg.effort)
        except InterfaceError as err:
            raise EpisodeError(f"{self.ns}: {err}") from None
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        client.on_row(self.ns, stamp, ours.position, ours.velocity, ours.effort)
        if self.pos is None:
            client.on_position(self.ns, ours.position)

    def send(self, u: float) -> None:
        """Ask for force ``u`` in the face's command message."""
        self.force.publish(command(self.iface, u))

    def matched_since(self, now: float) -> float | None:
        """Since when every endpoint has been matched (None: not all are); earlier than ``now`` for
        endpoints a served process kept from an earlier job."""
        if not self.matched():
            return None
        return endpoints.all_matched_since((self.force, self.reset, self.pos, self.js), now)

    def matched(self) -> bool:
        reset_ok = not self.needs_reset or (self.reset is not None
                                            and self.reset.get_subscription_count() > 0)
        return (self.force.get_subscription_count() > 0 and reset_ok
                and (self.pos is None or self.pos.get_publisher_count() > 0)
                and (self.js is None or self.js.get_publisher_count() > 0))


class EpisodeClient:
    """Plays queued episodes on plant-like nodes; calls ``on_idle`` when the queue empties."""

    def __init__(self, node: Node, lockstep: bool = True, settle_s: float = 0.5,
                 match_timeout_s: float = 30.0, reset: bool = True, rest: RestConfig | None = None,
                 interfaces: dict[str, PlantInterface] | None = None, pooled: bool = False) -> None:
        """``interfaces``: the face of each namespace that is not the msd face (docs/ros2-control.md).
        ``pooled`` (lock-step only): take the endpoints from a served process's pool
        (:mod:`msd_bench.nodes.endpoints`), matched already by an earlier job."""
        if pooled and not lockstep:
            raise EpisodeError("pooled endpoints need lock-step: a free-running node publishes between jobs")
        if lockstep and not reset:
            raise EpisodeError("lock-step episodes need the node's reset (its acknowledgement paces them)")
        self.node = node
        self.pooled = pooled
        self.interfaces = dict(interfaces or {})
        self.lockstep = lockstep
        self.reset = reset
        self.rest = rest or RestConfig()
        self._detector: RestDetector | None = None
        self._last_x: float | None = None
        self.log: Callable[[str], None] | None = None
        """Where a rest that timed out is reported (the node's logger)."""
        self.settle_s = settle_s
        self.match_timeout_s = match_timeout_s
        self.on_idle: Callable[[], None] | None = None
        self.on_error: Callable[[MsdBenchError], None] | None = None
        """Where a user error raised in a callback goes (None: raised to the executor)."""
        self._endpoints: dict[str, _Endpoint] = {}
        self._queue: deque[Episode] = deque()
        self._ep: Episode | None = None
        self._phase = "idle"
        self._since = 0.0
        node.create_timer(0.05, self.guarded_timer(self._on_tick))

    def guarded(self, callback: Callable[[Any], None]) -> Callable[[Any], None]:
        """Subscription ``callback`` with its :class:`MsdBenchError` handed to ``on_error`` (if set).

        Why: an executor that meets an exception in a callback may log it with
        its stack (rclpy's events executor does) before passing it on; the
        node instead ends with the error's one line.
        """
        def run(msg: Any) -> None:
            self._run_guarded(callback, msg)
        return run

    def guarded_timer(self, callback: Callable[[], None]) -> Callable[[], None]:
        """Timer ``callback`` guarded as :meth:`guarded` (no argument: rclpy passes timer info to
        a callback that takes one)."""
        def run() -> None:
            self._run_guarded(callback)
        return run

    def _run_guarded(self, callback: Callable[..., None], *args: Any) -> None:
        try:
            callback(*args)
        except MsdBenchError as exc:
            if self.on_error is None:
                raise
            self.on_error(exc)

    def endpoint(self, ns: str) -> _Endpoint:
        """Create (once) the publishers and subscriptions for namespace ``ns``, through its interface."""
        if ns not in self._endpoints:
            iface = self.interfaces.get(ns, MSD_INTERFACE)
            if self.reset and iface.reset is None:
                raise EpisodeError(f"{ns}: the {iface.kind} interface has no reset; use reset=False")
            self._endpoints[ns] = _Endpoint(self.node, ns, self, iface)
        return self._endpoints[ns]

    def submit(self, episode: Episode) -> None:
        """Queue an episode; it starts once its node is matched."""
        end = self.endpoint(episode.namespace)
        if episode.record:
            end.want_rows()  # a new subscription: the episode waits for its match (matched_since)
        self._queue.append(episode)

    @property
    def busy(self) -> bool:
        """True while an episode runs or waits in the queue."""
        return self._ep is not None or bool(self._queue)

    def _on_tick(self) -> None:
        now = time.monotonic()
        if self._ep is None and self._queue:
            self._begin(self._queue.popleft(), now)
        if self._ep is None:
            return
        if self._phase == "match":
            self._check_match(now)
        elif self._phase == "settle" and now - self._since >= self.settle_s:
            self._start_steps(0.0 if self._last_x is None else self._last_x)
        elif self._phase == "rest" and now - self._since > self.rest.timeout:
            self._rest_timed_out()

    def _begin(self, ep: Episode, now: float) -> None:
        self._ep, self._phase, self._since = ep, "match", now
        self._check_match(now)

    def _check_match(self, now: float) -> None:
        assert self._ep is not None
        ns = self._ep.namespace
        since = self._endpoints[ns].matched_since(now)
        if since is not None:
            if now - since >= 0.3:  # both sides see the match, not just ours
                self._send_reset(now)
        elif now - self._since > self.match_timeout_s:
            raise EpisodeError(f"no plant-like node answers under {ns} (waited {self.match_timeout_s:.0f} s)")

    def _send_reset(self, now: float) -> None:
        assert self._ep is not None
        self._last_x = None
        if not self.reset:
            self._phase, self._since = "rest", now
            self._detector = RestDetector(self.rest)
            return
        self._phase, self._since = ("reset" if self.lockstep else "settle"), now
        reset = self._endpoints[self._ep.namespace].reset
        assert reset is not None  # a face without reset needs reset=False (checked in endpoint())
        reset.publish(Empty())

    def _rest_step(self, x: float) -> None:
        """Zero force for every sample until the detector calls the mass still."""
        assert self._ep is not None and self._detector is not None
        self._endpoints[self._ep.namespace].send(0.0)
        if self._detector.push(x):
            self._start_steps(self._detector.x0)

    def _rest_timed_out(self) -> None:
        assert self._ep is not None and self._detector is not None
        if self._detector.samples == 0:
            raise EpisodeError(f"no position from {self._ep.namespace} "
                               f"in {self.rest.timeout:.0f} s of zero force")
        if self.log is not None:
            self.log(f"not still after {self.rest.timeout:.0f} s of zero force (spread "
                     f"{self._detector.spread() * 1e3:.1f} mm); "
                     f"starting from x0 = {self._detector.x0:+.4f} m")
        self._start_steps(self._detector.x0)

    def on_position(self, ns: str, x: float) -> None:
        """Position callback: the reset acknowledgement or the answer to the last force."""
        ep = self._ep
        if ep is None or ns != ep.namespace:
            return
        if self._phase == "reset":
            self._start_steps(x)
        elif self._phase == "rest":
            self._rest_step(x)
        elif self._phase == "settle":
            self._last_x = x
        elif self._phase == "step":
            ep.controller.observe(x)
            ep.taken += 1
            if ep.taken < ep.steps:
                self._send(ep)
            else:
                self._phase = "drain"
                self._maybe_finish()

    def on_row(self, ns: str, stamp: int, x: float, v: float, effort: float) -> None:
        """joint_states callback (our joint, picked by the endpoint): collect rows of recorded episodes."""
        ep = self._ep
        if ep is None or ns != ep.namespace or not ep.record or self._phase not in ("step", "drain"):
            return
        ep.rows.append((stamp, x, v, effort))
        self._maybe_finish()

    def _start_steps(self, x0: float) -> None:
        assert self._ep is not None
        self._phase = "step"
        self._ep.x0 = float(x0)
        self._ep.controller.start(x0)
        self._send(self._ep)

    def _send(self, ep: Episode) -> None:
        self._endpoints[ep.namespace].send(ep.controller.act())

    def _maybe_finish(self) -> None:
        ep = self._ep
        if ep is None or self._phase != "drain" or (ep.record and len(ep.rows) < ep.steps):
            return
        self._ep, self._phase = None, "idle"
        if ep.on_done is not None:
            ep.on_done(ep)
        if self._queue:
            self._begin(self._queue.popleft(), time.monotonic())
        elif self.on_idle is not None:
            self.on_idle()
