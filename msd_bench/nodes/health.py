"""Live health of a plant-like node: stall tracking and the ``/diagnostics`` message.

Why: the rejected / saturated / watchdog counters used to appear only in the
shutdown log, and a 2 s stall of the real-time timer left a hole in the
stamps that nobody reported. Now every plant-like node publishes a
``diagnostic_msgs/DiagnosticArray`` once a second (the ROS convention rqt's
Runtime Monitor and Foxglove display) and logs a stall when it happens.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

OK, WARN = DiagnosticStatus.OK, DiagnosticStatus.WARN


@dataclass
class StallTracker:
    """Gaps between real-time sample wake-ups longer than one sample beyond the period."""

    period: float
    """The sample time, s."""
    count: int = 0
    """Stalls seen."""
    longest_s: float = 0.0
    """Longest gap between two ticks, s."""
    last_s: float = 0.0
    """The most recent stall's gap, s (0 before the first)."""
    _last_tick: float | None = None

    def tick(self, now: float) -> float | None:
        """Record a tick at monotonic ``now``; the gap (s) if it was a stall, else None."""
        last, self._last_tick = self._last_tick, now
        if last is None:
            return None
        gap = now - last
        if gap <= 2.0 * self.period:
            return None
        self.count += 1
        self.last_s = gap
        self.longest_s = max(self.longest_s, gap)
        return gap


def _kv(values: dict[str, Any]) -> list[KeyValue]:
    return [KeyValue(key=k, value=f"{v:.4g}" if isinstance(v, float) else str(v)) for k, v in values.items()]


def diagnostic_array(stamp: Any, name: str, hardware_id: str, values: dict[str, Any],
                     warnings: list[str]) -> DiagnosticArray:
    """One status for the node: OK, or WARN with the warnings joined as its message."""
    status = DiagnosticStatus(
        level=WARN if warnings else OK,
        name=name,
        message="; ".join(warnings) if warnings else "running",
        hardware_id=hardware_id,
        values=_kv(values),
    )
    msg = DiagnosticArray()
    msg.header.stamp = stamp
    msg.status = [status]
    return msg
