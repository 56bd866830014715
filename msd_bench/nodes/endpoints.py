"""Publishers and subscriptions that outlive the node that asked for them, in a served process.

Why: a served process (:mod:`msd_bench.nodes.serve`) builds a new node per
job, and every new endpoint must be discovered by its peers before data flows.
Measured on the recording stage: 0.1-1.1 s until a new recorder's reader saw
the plant's writer (sometimes 3 s), then the grace and settle the nodes wait
on top, because discovery is not symmetric (the reader seeing the writer does
not mean the writer sees the reader): 1.5-2.5 s per experiment, a third of
the stage. A pooled endpoint is matched from both sides once; the next job
that asks for the same topic, type and QoS gets it already matched.

Rules that keep a reused endpoint from carrying one job's data into the next:

* a node opts in (``pooled=True``) only where its peers publish nothing
  between jobs: lock-step, where the plant answers commands and nothing else;
* a job that did not finish by itself (failed, stopped) discards the pool, so
  whatever it left in flight dies with its endpoints;
* one handler per pooled subscription; a second asker in the same job gets a
  private endpoint, as without a pool;
* a transient-local subscription keeps its last messages and hands them to
  the next handler, as a new late-joining reader would get them.

Outside a served process there is no pool: every helper here creates the
node's own endpoints, as ``Node.create_publisher`` would.
"""

from __future__ import annotations

import time
import weakref
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.subscription import Subscription

Handler = Callable[[Any], None]


def _qos_key(profile: QoSProfile) -> tuple[Any, ...]:
    """What makes two profiles the same endpoint (QoSProfile is not hashable)."""
    return (profile.history, profile.depth, profile.reliability, profile.durability,
            profile.deadline.nanoseconds, profile.lifespan.nanoseconds, profile.liveliness,
            profile.liveliness_lease_duration.nanoseconds)


class PooledSubscription:
    """A pool's subscription: dispatches to the handler attached by the current job."""

    def __init__(self, latched: int) -> None:
        self.subscription: Subscription[Any] | None = None
        self.handler: Handler | None = None
        self._kept: deque[Any] = deque(maxlen=latched)

    def dispatch(self, msg: Any) -> None:
        """The rclpy callback: keep it if latched, hand it to the job's handler if there is one."""
        if self._kept.maxlen:
            self._kept.append(msg)
        if self.handler is not None:
            self.handler(msg)

    def attach(self, handler: Handler) -> None:
        """Route messages to ``handler``; replay what a late-joining transient-local reader would get."""
        self.handler = handler
        for msg in list(self._kept):
            handler(msg)

    @property
    def topic_name(self) -> str:
        assert self.subscription is not None
        return str(self.subscription.topic_name)

    def get_publisher_count(self) -> int:
        """Publishers matched with the pooled reader."""
        assert self.subscription is not None
        return int(self.subscription.get_publisher_count())


class EndpointPool:
    """The endpoints of one served process, owned by one extra node spun beside each job's node."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self._pubs: dict[tuple[Any, ...], Publisher[Any]] = {}
        self._subs: dict[tuple[Any, ...], PooledSubscription] = {}

    def publisher(self, owner: Node, msg_type: Any, topic: str, profile: QoSProfile) -> Publisher[Any]:
        """The pool's publisher of ``topic`` (resolved in ``owner``'s namespace and remappings)."""
        name = owner.resolve_topic_name(topic)
        key = (name, msg_type, _qos_key(profile))
        if key not in self._pubs:
            self._pubs[key] = self.node.create_publisher(msg_type, name, profile)
            self.node.get_logger().info(f"pooled publisher {name}")
        return self._pubs[key]

    def subscription(self, owner: Node, msg_type: Any, topic: str, handler: Handler, profile: QoSProfile,
                     raw: bool = False) -> PooledSubscription | None:
        """The pool's subscription of ``topic`` routed to ``handler``; None if another handler holds it."""
        name = owner.resolve_topic_name(topic)
        key = (name, msg_type, _qos_key(profile), raw)
        entry = self._subs.get(key)
        if entry is None:
            latched = profile.depth if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL else 0
            entry = PooledSubscription(latched)
            entry.subscription = self.node.create_subscription(msg_type, name, entry.dispatch, profile,
                                                               raw=raw)
            self._subs[key] = entry
            self.node.get_logger().info(f"pooled subscription {name}")
        elif entry.handler is not None:
            return None
        entry.attach(handler)
        return entry

    def end_job(self, finished: bool) -> None:
        """The job is over: detach its handlers; discard every endpoint unless it finished by itself."""
        for entry in self._subs.values():
            entry.handler = None
        if finished:
            return
        for sub in self._subs.values():
            if sub.subscription is not None:
                self.node.destroy_subscription(sub.subscription)
        for pub in self._pubs.values():
            self.node.destroy_publisher(pub)
        self._subs.clear()
        self._pubs.clear()


_POOL: EndpointPool | None = None
_MATCHED_AT: weakref.WeakKeyDictionary[Any, float] = weakref.WeakKeyDictionary()
"""Endpoint → when it was first seen matched (pooled endpoints live on, and keep theirs, across jobs)."""


def install(pool: EndpointPool | None) -> None:
    """Make ``pool`` the served process's pool (None: no pool, as in a plain node process)."""
    global _POOL
    _POOL = pool
    _MATCHED_AT.clear()


def pool() -> EndpointPool | None:
    """The served process's pool, if any."""
    return _POOL


def create_publisher(owner: Node, msg_type: Any, topic: str, profile: QoSProfile,
                     pooled: bool = False) -> Publisher[Any]:
    """``owner.create_publisher``, or the pool's publisher when ``pooled`` and the process has a pool."""
    if pooled and _POOL is not None:
        return _POOL.publisher(owner, msg_type, topic, profile)
    return owner.create_publisher(msg_type, topic, profile)


def create_subscription(owner: Node, msg_type: Any, topic: str, handler: Handler, profile: QoSProfile,
                        raw: bool = False, pooled: bool = False) -> Subscription[Any] | PooledSubscription:
    """``owner.create_subscription``, or the pool's subscription when ``pooled`` and there is a pool."""
    if pooled and _POOL is not None:
        entry = _POOL.subscription(owner, msg_type, topic, handler, profile, raw)
        if entry is not None:
            return entry
    return owner.create_subscription(msg_type, topic, handler, profile, raw=raw)


def matched_since(endpoint: Any, matched: bool, now: float | None = None) -> float | None:
    """Since when ``endpoint`` has been seen matched (``matched``: it is now); None while it is not.

    A pooled endpoint keeps its time across jobs, so a wait for the far side's
    match ("grace", "settle") is already over when the next job reuses it.
    """
    if not matched:
        _MATCHED_AT.pop(endpoint, None)
        return None
    return _MATCHED_AT.setdefault(endpoint, time.monotonic() if now is None else now)


def all_matched_since(ours: Sequence[Any], now: float) -> float:
    """Since when every one of ``ours`` (all matched now; None entries skipped) has been matched:
    ``now`` for any seen matched for the first time, earlier only if all were kept from earlier jobs."""
    return max(matched_since(e, True, now) or now for e in ours if e is not None)
