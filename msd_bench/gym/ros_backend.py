"""The ROS 2 backend: step a plant-like node, one force per ``env.step``.

Lock-step (default) follows the lock-step contract of
:mod:`msd_bench.nodes.plant_node`: ``reset`` is acknowledged by one
``position`` (x_0), and each ``force`` command is answered by exactly one
``position`` (x_{k+1}). One command is in flight at a time, so an episode is
as deterministic as the node.

Real time (``lockstep=False``): the node runs its own 100 Hz clock and holds
the latest command. A step publishes the force and returns the next position
sample that arrives after it (which may still have been computed with the
previous force: a real rig's one-sample latency; the agent must be quicker
than the node's watchdog between steps). An episode starts from rest: with
``reset`` the node is sent 0 N and reset; without one (real hardware cannot
teleport) the backend holds 0 N until the mass is still, judged exactly as
``bench.py --plant-ns`` judges it (:class:`msd_bench.core.rigs.rest.RestDetector`:
spread and drift over a window, so a noisy sensor at rest counts as still),
and the episode starts wherever it came to rest: x_0 is the detector's mean of
the last positions, read, never assumed 0.

The backend owns a private rclpy context and executor and spins them only
while it waits for an answer, so it lives happily in a training loop that
knows nothing of ROS, beside other nodes of the same process. It uses the
caller's ``ROS_DOMAIN_ID`` and discovery range (LOCALHOST: confined to
127.0.0.1, :func:`msd_bench.dds.start_confined`). One environment per
namespace: two clients stepping the same lock-step node would interleave.

A node with the ros2_control face (``interface=``, docs/ros2-control.md §Face)
is driven through ``<controller>/commands`` and read from ``joint_states``
(our joint picked by name): it has neither ``position`` nor ``reset``, so it
runs in real time only.

"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from std_msgs.msg import Empty, Float64

from msd_bench.core.errors import InterfaceError, MsdBenchError
from msd_bench.core.physics.plant import DT, PlantParams
from msd_bench.core.rigs.rest import RestConfig, RestDetector
from msd_bench.dds import start_confined
from msd_msgs_py.interface import MSD_INTERFACE, PlantInterface
from msd_msgs_py.ros import command, msg_class, qos

MATCH_SETTLE_S = 0.3
"""After our side sees the match, wait this long so the node's side sees it too (as the episode client)."""


def _new_session() -> tuple[Context, Node]:
    """A private rclpy context and the backend's node (its DDS participant opens the sockets)."""
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    return ctx, rclpy.create_node("msd_gym", context=ctx, start_parameter_services=False)


def _end_session(session: tuple[Context, Node]) -> None:
    session[1].destroy_node()
    session[0].shutdown()


class RosBackendError(MsdBenchError):
    """The plant-like node did not answer as the lock-step contract requires."""


class RosBackend:
    """A lock-step plant-like node under ``namespace``, driven over its topics."""

    def __init__(self, namespace: str = "/msd", timeout_s: float = 5.0, match_timeout_s: float = 15.0,
                 dt: float = DT, x_max: float = 0.5 * PlantParams().L, *, lockstep: bool = True,
                 rest: RestConfig | None = None, interface: PlantInterface = MSD_INTERFACE) -> None:
        """``dt`` and ``x_max`` are the node's sample time and half stroke (the topics do not carry them).

        ``rest`` says when a real-time node without ``reset`` counts as at rest
        (the bench's own rule by default).
        """
        if not namespace.startswith("/"):
            raise RosBackendError(f"ROS namespace must be absolute (start with '/'), got {namespace!r}")
        if lockstep and interface.reset is None:
            raise RosBackendError(f"the {interface.kind} interface has no reset: lock-step is impossible, "
                                  "use ros_lockstep=False")
        self.namespace = namespace
        self.interface = interface
        self.dt = float(dt)
        self.x_max = float(x_max)
        self.timeout_s = float(timeout_s)
        self.lockstep = lockstep
        self.rest = rest or RestConfig()
        self._positions: deque[float] = deque()
        self._ctx, self._node = start_confined(_new_session, _end_session)  # loopback under LOCALHOST
        cmd, reset, pos = interface.command, interface.reset, interface.position or interface.state
        self._force: Publisher[Any] = self._node.create_publisher(msg_class(cmd), cmd.resolve(namespace),
                                                                  qos(cmd))
        self._reset = (None if reset is None else
                       self._node.create_publisher(Empty, reset.resolve(namespace), qos(reset)))
        self._pos = self._node.create_subscription(msg_class(pos), pos.resolve(namespace), self._on_sample,
                                                   qos(pos))
        self._bad_sample: str | None = None
        self._executor = SingleThreadedExecutor(context=self._ctx)
        self._executor.add_node(self._node)
        self._closed = False
        self._wait_for_match(match_timeout_s)

    def _on_sample(self, msg: Float64 | object) -> None:
        """A position: ``position``'s value, or our joint's in a ``joint_states`` message."""
        if isinstance(msg, Float64):
            self._positions.append(msg.data)
            return
        m: Any = msg
        try:
            sample = self.interface.pick(list(m.name), m.position, m.velocity, m.effort)
            self._positions.append(sample.position)
        except InterfaceError as exc:
            self._bad_sample = str(exc)

    def _publish(self, u: float) -> None:
        self._force.publish(command(self.interface, u))

    @property
    def has_reset(self) -> bool:
        """Whether the node subscribes to ``reset`` (a real rig may not)."""
        return self._reset is not None and self._reset.get_subscription_count() > 0

    def _matched(self) -> bool:
        return (self._force.get_subscription_count() > 0 and self._pos.get_publisher_count() > 0
                and (self.has_reset or not self.lockstep))

    def _wait_for_match(self, timeout_s: float) -> None:
        if not self._spin_until(self._matched, timeout_s):
            self.close()
            cmd, pos = self.interface.command.name, (self.interface.position or self.interface.state).name
            needs = f"{cmd}, reset and {pos}" if self.lockstep else f"{cmd} and {pos}"
            raise RosBackendError(
                f"no plant-like node with {needs} under {self.namespace} (waited {timeout_s:g} s)")
        self._spin_for(MATCH_SETTLE_S)

    def _spin_until(self, done: Callable[[], bool], timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while not done() and time.monotonic() < deadline:
            self._executor.spin_once(timeout_sec=0.005)
        return done()

    def _spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self._executor.spin_once(timeout_sec=0.005)

    def _answer(self, what: str) -> float:
        if not self._spin_until(lambda: bool(self._positions) or self._bad_sample is not None,
                                self.timeout_s):
            raise RosBackendError(
                f"{self.namespace}: no position answered the {what} within {self.timeout_s:g} s "
                "(the ROS backend needs a lock-step plant-like node)")
        if self._bad_sample is not None and not self._positions:
            raise RosBackendError(f"{self.namespace}: {self._bad_sample}")
        return self._positions.popleft()

    def reset(self) -> float:
        """Bring the node to rest and return the position there (see the module docstring)."""
        self._check_open()
        if self.lockstep:
            self._positions.clear()
            assert self._reset is not None  # lock-step needs a reset (checked in __init__)
            self._reset.publish(Empty())
            return self._answer("reset")
        self._publish(0.0)
        if self._reset is None or not self.has_reset:
            return self._come_to_rest()
        self._positions.clear()
        for _ in range(2):  # two samples later the 0 N command has overtaken nothing: it is applied
            self._answer("zero force")
        self._reset.publish(Empty())
        self._positions.clear()
        self._answer("reset")  # a sample from before the reset may still be in flight:
        self._positions.clear()  # the next one is from after it
        return self._answer("reset")

    def _come_to_rest(self) -> float:
        """Hold 0 N until the position is still; the rest position (read, not assumed)."""
        deadline = time.monotonic() + self.rest.timeout
        self._positions.clear()
        detector = RestDetector(self.rest)
        detector.push(self._answer("zero force"))
        while not detector.still:
            if time.monotonic() > deadline:
                raise RosBackendError(
                    f"{self.namespace}: not at rest after {self.rest.timeout:g} s of 0 N "
                    f"(position spread {1000 * detector.spread():.1f} mm over the last "
                    f"{self.rest.window} samples, limit {1000 * self.rest.threshold:g} mm)")
            self._publish(0.0)  # keeps the node's watchdog fed with a safe command
            detector.push(self._answer("zero force"))
        return detector.x0

    def step(self, u: float) -> float:
        """Send one force and wait for the position that follows it."""
        self._check_open()
        if not self.lockstep:
            self._positions.clear()  # real time: only a sample arriving after the command counts
        self._publish(u)
        return self._answer("force command")

    def _check_open(self) -> None:
        if self._closed:
            raise RosBackendError(f"the ROS backend on {self.namespace} is closed")

    def close(self) -> None:
        """Destroy the node and shut the private context down (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._executor.shutdown()
        self._node.destroy_node()
        rclpy.try_shutdown(context=self._ctx)
