"""How a node is spun and closed: the executors, the spin loop, the stop flag, the exit status.

Shared by the one-node process (:mod:`.spin`) and the served process (:mod:`.serve`).
Why a module of its own: :func:`msd_bench.nodes.spin.run` hands a ``--serve``
process to :mod:`.serve`, and :mod:`.serve` needs these helpers; kept in
:mod:`.spin` they made the two modules import each other (docs/design.md §Layers:
no circle of modules). :mod:`.spin` re-exports every name here, so callers keep
their imports.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType

import rclpy
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.node import Node

EXIT_USAGE = 2
"""Exit status of a process that stopped on a user mistake."""


def make_executor(context: rclpy.context.Context | None = None, events: bool = False) -> Executor:
    """The executor a node runs on: rclpy's events executor if ``events``, else the single-threaded one.

    Why two: rclpy's SingleThreadedExecutor rebuilds a wait set over every
    entity of the node (parameter services, timers, QoS event handlers, ...)
    in Python for each message it dispatches, which costs a lock-step exchange
    more than the middleware round trip itself; the events executor (C++,
    rclpy >= 7.1, ``rclpy.experimental``) dispatches each message from its rmw
    callback. Nodes whose speed is one message per step opt in
    (:func:`wants_events_executor`); the rest keep the executor rclpy spins by
    default (benchmarks/bench_lockstep.py measures both against a bare
    ping-pong that uses that default).
    """
    if events:
        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def wants_events_executor(node: Node) -> bool:
    """Whether ``node`` asks for the events executor (its ``events_executor`` attribute, default no)."""
    return bool(getattr(node, "events_executor", False))


EVENTS_SPIN_S = 0.5
"""Longest single spin call on the events executor. Spun without a timeout it ran no callback at all
here (a 100 Hz timer never fired; rclpy 9.1.2 on Kilted and 7.1.5 on Jazzy alike, busy in the
spin), so it is spun in bounded slices until the node is done, stopped or the context shuts down."""


def spin_node(node: Node, executor: Executor) -> int:
    """Spin until shutdown or until ``node.done`` completes; return the exit status.

    A ``done`` completed with an exception (a node that routes its one-line
    errors through it) raises that exception here.
    """
    executor.add_node(node)
    done = getattr(node, "done", None)
    if not _is_events(executor):
        if done is None:
            executor.spin()
            return 0
        executor.spin_until_future_complete(done)
    else:
        with stops_requested() as stopped:
            while not stopped() and executor.context.ok() and (done is None or not done.done()):
                if done is None:
                    executor.spin_once(timeout_sec=EVENTS_SPIN_S)
                else:
                    executor.spin_until_future_complete(done, timeout_sec=EVENTS_SPIN_S)
        if stopped():
            raise KeyboardInterrupt
    return int(done.result()) if done is not None and done.done() else 0


@contextmanager
def stops_requested() -> Iterator[Callable[[], bool]]:
    """SIGINT/SIGTERM only flag a stop (read through the yielded callable) while the block runs.

    Why: the events executor calls Python callbacks from C++; a KeyboardInterrupt
    raised inside one reaches the spin as a RuntimeError from pybind11 (a
    traceback and exit 1 instead of a clean stop). The spin loop checks the
    flag between slices and raises KeyboardInterrupt itself, outside any callback.
    """
    flagged: list[int] = []
    held = (signal.SIGINT, signal.SIGTERM)
    old = {sig: signal.getsignal(sig) for sig in held}
    for sig in held:
        signal.signal(sig, lambda signum, _frame: flagged.append(signum))
    try:
        yield lambda: bool(flagged)
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


class _Deferral:
    """The stops a :func:`stops_deferred` block is holding (``held`` is None outside any block)."""

    held: list[int] | None = None


def stop_handler(signum: int, frame: FrameType | None) -> None:
    """The SIGINT/SIGTERM handler of node processes, installed before ``rclpy.init`` (whose own
    handlers chain to it): a stop is a KeyboardInterrupt, unless a :func:`stops_deferred` block
    runs, which remembers it and raises it when the block ends."""
    if _Deferral.held is not None:
        _Deferral.held.append(signum)
        return
    raise KeyboardInterrupt


def install_stop_handler() -> None:
    """A stop from here on is a KeyboardInterrupt (:func:`stop_handler`), also replacing a
    launch script's start-up handler."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, stop_handler)


@contextmanager
def stops_deferred() -> Iterator[None]:
    """Hold SIGINT/SIGTERM while native code runs (numba compiling), deliver them after.

    Why: a KeyboardInterrupt raised inside llvmlite (its object-cache callback, called from
    native code) is lost there and prints an "Exception ignored" traceback, though the stop
    itself is clean. Masking the signals on this thread alone does not keep it out: the kernel
    delivers a signal to any thread that does not block it (the DDS threads started earlier),
    and Python runs the handler on the main thread at its next bytecode, inside the compiler.
    So :func:`stop_handler` only remembers a stop during the block. Why not swap the handler
    with ``signal.signal``: that would replace rclpy's own handlers, which chain to ours.
    """
    blocked = (signal.SIGINT, signal.SIGTERM)
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, blocked)
    if threading.current_thread() is not threading.main_thread():
        try:  # only the main thread runs handlers: a stop must not wait for another thread's block
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)
        return
    outer = _Deferral.held
    _Deferral.held = [] if outer is None else outer
    try:
        yield
    finally:
        stops, _Deferral.held = _Deferral.held, outer
        signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)
        if stops and outer is None:
            raise KeyboardInterrupt


def _is_events(executor: Executor) -> bool:
    return not isinstance(executor, SingleThreadedExecutor)


def close_node(node: Node) -> None:
    """Let the node report (``close()``), then destroy it."""
    close = getattr(node, "close", None)
    if close is not None:
        close()
    node.destroy_node()
