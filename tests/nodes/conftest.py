"""In-process node fixtures: a private rclpy Context per test, shut down in the finalizer."""

from __future__ import annotations

import contextlib
import gc
import time
import warnings
from collections.abc import Callable, Iterator

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

# rclpy imports lark lazily (parameter events), which imports the deprecated sre_parse;
# import it once here with that one warning silenced so warnings-as-errors stays on for ours.
with warnings.catch_warnings():
    warnings.filterwarnings("ignore", "module 'sre_.*' is deprecated", DeprecationWarning)
    import lark  # noqa: F401


def shutdown_context(context: Context) -> None:
    """Destroy the nodes still alive in ``context``, then shut it down.

    Why: neither distro's context shutdown can be trusted to take its nodes with
    it. Jazzy's only shuts the context down; Kilted's destroys its tracked nodes
    while iterating the very list each ``destroy_node`` removes itself from, so
    every second node survives. A surviving node — and its DDS participant, with
    every publisher and subscription — stays in the graph until garbage
    collection: the next test's plant refuses to start ("already has a
    publisher"), a census counts a second ``/clock`` publisher, and publishers see
    the old subscriptions as matched and send before the new node listens. Nodes a
    test forgot (or whose ``__init__`` raised) are found by scanning the heap (~0.1 s).
    """
    for obj in gc.get_objects():
        if issubclass(type(obj), Node) and obj.context is context:  # type(): no proxy __class__
            with contextlib.suppress(AttributeError):  # Node.__init__ failed before its rcl node
                obj.destroy_node()  # a second destroy (test already did) is a no-op
    rclpy.try_shutdown(context=context)


@pytest.fixture
def ctx() -> Iterator[Context]:
    """A private, initialised context (no signal handlers), isolated from other tests."""
    context = Context()
    rclpy.init(args=[], context=context)
    try:
        yield context
    finally:
        shutdown_context(context)


@pytest.fixture
def executor(ctx: Context) -> Iterator[SingleThreadedExecutor]:
    """A single-threaded executor on the private context."""
    ex = SingleThreadedExecutor(context=ctx)
    try:
        yield ex
    finally:
        ex.shutdown()


def spin_until(
    executor: SingleThreadedExecutor, done: Callable[[], bool], timeout: float = 30.0
) -> bool:
    """Spin until ``done()`` is true or ``timeout`` s pass; return ``done()``.

    The default is a deadline, not an expectation: what takes 0.2 s idle (20 samples at 100 Hz)
    took over 5 s beside three parallel suites (load 8 on 2 cores); a pass returns at once."""
    deadline = time.monotonic() + timeout
    while not done() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
    return done()


def spin_for(executor: SingleThreadedExecutor, seconds: float) -> None:
    """Spin for a fixed time (for things that must *not* happen)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
