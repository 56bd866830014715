"""Deliberately broken plant-like nodes: each breaks exactly one clause of check-rig.

Each fake is the real :class:`PlantNode` with one method overridden, so
everything it does not break it does exactly as the plant does, and a check
that failed a second clause would be a wrong clause, not a sloppy fake.
"""

from __future__ import annotations

import math
from typing import Any

from rclpy.qos import ReliabilityPolicy

from msd_bench.nodes.plant_node import ModelSpec, PlantNode, PlantNodeConfig, true_plant_spec
from msd_msgs_py.contract import JOINT_STATES
from msd_msgs_py.ros import float64, joint_state, msg_class, qos

REALTIME = PlantNodeConfig(lockstep=False, duplicate_check=0.0)
DT_NS = 10_000_000


class WrongRate(PlantNode):
    """Publishes at 80 Hz but stamps every row 10 ms after the previous one (breaks: rate)."""

    def __init__(self, spec: ModelSpec, **kw: Any) -> None:
        super().__init__(ModelSpec(spec.model, 0.0125, spec.force_limit), **kw)

    def _step(self, u: float, stamp: int) -> None:
        super()._step(u, self._ros0 + self.counters["steps"] * DT_NS)


class NonMonotonicStamps(PlantNode):
    """Every 25th row is stamped two periods early (breaks: stamps)."""

    def _step(self, u: float, stamp: int) -> None:
        early = self.counters["steps"] % 25 == 24
        super()._step(u, stamp - 2 * DT_NS if early else stamp)


class NoSaturation(PlantNode):
    """Reports the command as the applied force even beyond ±F (breaks: saturation)."""

    def _accept(self, u: float) -> float | None:
        return u if math.isfinite(u) else None


class AcceptsNonFinite(PlantNode):
    """Takes NaN/inf as a force and publishes it as the effort, holding still (breaks: non-finite)."""

    def _accept(self, u: float) -> float | None:
        return super()._accept(u) if math.isfinite(u) else u

    def _step(self, u: float, stamp: int) -> None:
        if math.isfinite(u):
            super()._step(u, stamp)
            return
        self._pub_js.publish(joint_state(stamp, self._y, 0.0, u))
        self._k += 1
        self.counters["steps"] += 1
        self._pub_x.publish(float64(self._y))


class NoWatchdog(PlantNode):
    """Holds the last command for ever (breaks: watchdog)."""

    def _check_watchdog(self, t: float) -> None:
        return


class SlowActuator(PlantNode):
    """A first-order actuator lag of 0.3 s: the effort needs > 0.5 s to reach a step (breaks: effort-step)."""

    TAU = 0.3

    def _on_reset(self, msg: Any) -> None:
        self._lag = 0.0
        super()._on_reset(msg)

    def _step(self, u: float, stamp: int) -> None:
        self._lag += (1.0 - math.exp(-self.spec.dt / self.TAU)) * (u - self._lag)
        super()._step(self._lag, stamp)


class RealisticActuator(PlantNode):
    """Conforming, but like hardware: one sample of delay, a 30 ms lag, a 2 mm noisy sensor."""

    TAU = 0.03

    def _on_reset(self, msg: Any) -> None:
        self._lag, self._queued = 0.0, 0.0
        super()._on_reset(msg)

    def _step(self, u: float, stamp: int) -> None:
        self._lag += (1.0 - math.exp(-self.spec.dt / self.TAU)) * (self._queued - self._lag)
        self._queued = u
        super()._step(self._lag, stamp)


class TwoPublishers(PlantNode):
    """A second (silent) publisher on joint_states, as a forgotten driver would leave (breaks: publishers)."""

    def __init__(self, spec: ModelSpec, **kw: Any) -> None:
        super().__init__(spec, **kw)
        self._second = self.create_publisher(msg_class(JOINT_STATES), JOINT_STATES.name, qos(JOINT_STATES))


class BestEffort(PlantNode):
    """Publishes joint_states best-effort (breaks: qos)."""

    def __init__(self, spec: ModelSpec, **kw: Any) -> None:
        super().__init__(spec, **kw)
        self.destroy_publisher(self._pub_js)
        profile = qos(JOINT_STATES)
        profile.reliability = ReliabilityPolicy.BEST_EFFORT
        self._pub_js = self.create_publisher(msg_class(JOINT_STATES), JOINT_STATES.name, profile)


class IgnoresReset(PlantNode):
    """Subscribes to reset but does nothing with it (breaks: reset)."""

    def _on_reset_msg(self, msg: Any) -> None:
        return


class SilentReset(PlantNode):
    """Lock-step: resets, but publishes no acknowledgement (breaks: reset)."""

    def _on_reset_msg(self, msg: Any) -> None:
        self._on_reset(msg)


class DoubleStep(PlantNode):
    """Lock-step: two steps per command (breaks: steps)."""

    def _on_force(self, msg: Any) -> None:
        super()._on_force(msg)
        super()._on_force(msg)


LOCKSTEP = PlantNodeConfig(lockstep=True, duplicate_check=0.0)

FAKES: dict[str, tuple[type[PlantNode], str]] = {
    "wrong-rate": (WrongRate, "rate"),
    "non-monotonic": (NonMonotonicStamps, "stamps"),
    "no-saturation": (NoSaturation, "saturation"),
    "accepts-nan": (AcceptsNonFinite, "non-finite"),
    "no-watchdog": (NoWatchdog, "watchdog"),
    "slow-actuator": (SlowActuator, "effort-step"),
    "two-publishers": (TwoPublishers, "publishers"),
    "best-effort": (BestEffort, "qos"),
    "ignores-reset": (IgnoresReset, "reset"),
    "lockstep-silent-reset": (SilentReset, "reset"),
    "lockstep-double-step": (DoubleStep, "steps"),
}
"""Fake name -> (node class, the one clause it breaks)."""


def build(name: str, namespace: str, **node_kwargs: Any) -> PlantNode:
    """The fake ``name`` serving the default plant under ``namespace`` (real time unless ``lockstep-*``)."""
    cls, _ = FAKES[name]
    config = LOCKSTEP if name.startswith("lockstep-") else REALTIME
    return cls(true_plant_spec(), config=config, namespace=namespace, **node_kwargs)


def realistic(namespace: str, **node_kwargs: Any) -> PlantNode:
    """A conforming node with delay, lag and a noisy, quantised sensor."""
    config = PlantNodeConfig(lockstep=False, duplicate_check=0.0, sensor_noise=0.002, sensor_quant=0.0001)
    return RealisticActuator(true_plant_spec(), config=config, namespace=namespace, **node_kwargs)
