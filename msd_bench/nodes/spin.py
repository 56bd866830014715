"""The one thin ``main()`` every node process shares (ros2/examples pattern, docs/design.md §Conventions).

``with ros_session(args):`` build the node, spin, and end cleanly on
Ctrl-C (``KeyboardInterrupt``), SIGTERM (rclpy's handler shuts the context
down, the spin raises ``ExternalShutdownException``) or when the node says it
is done. A user mistake (:class:`MsdBenchError`, e.g. ``-p m:=-1``) prints one
line and exits with status 2, never a traceback.

Nodes that finish on their own (the excitation) expose ``done``: an rclpy
``Future`` whose result is the exit status. Every node may expose
``close()``, called once before it is destroyed (the plant logs its counters
there).

The executors, the spin loop and closing live in :mod:`.spin_loop`, which the
served process (:mod:`.serve`) shares; they are re-exported here.
"""

from __future__ import annotations

import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import rclpy
from rclpy._rclpy_pybind11 import RCLError, UnknownROSArgsError
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.utilities import remove_ros_args

from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.nodes import serve
from msd_bench.nodes.params import (
    allow_wildcard_names,
    check_params_files,
    check_rig_files,
    expand_rig_option,
    reject_unknown_parameters,
    wildcard_parameter_names,
)
from msd_bench.nodes.spin_loop import (
    EVENTS_SPIN_S,
    EXIT_USAGE,
    close_node,
    install_stop_handler,
    make_executor,
    spin_node,
    stops_deferred,
    stops_requested,
    wants_events_executor,
)

__all__ = [  # the spinning helpers are re-exported: callers import them from here
    "EVENTS_SPIN_S", "EXIT_USAGE", "DeadlinePacer", "DeadlineThread", "close_node", "main",
    "make_executor", "ros_session", "run", "spin_node", "stops_deferred", "stops_requested",
    "wants_events_executor",
]


@dataclass
class DeadlinePacer:
    """Absolute-deadline schedule of a periodic step (no drift, bounded catch-up).

    Why: rcl skips timer periods the process missed (a stall under load), so the
    mean rate falls below 1/period. The caller instead asks ``due(now)``, which
    returns the scheduled times of every step whose slot has begun — usually
    one, several after a stall — so the long-run rate stays exactly 1/period.
    After a stall longer than ``max_lag`` the schedule re-anchors at ``now``
    (counted in ``reanchors``).

    Times are integer nanoseconds of the monotonic clock (``time.monotonic_ns``)
    and each deadline is ``anchor + slot·period``, never a running sum. Why: a
    float deadline advanced by adding the period rounds at every step; at a
    monotonic clock of a few days (≈2·10⁵ s) that drifts by about 0.1 ns per
    step, so stamps derived from the deadlines stopped being an exact 10 ms grid
    after a few hundred samples — a CI failure on a machine with a long uptime.

    ``lead`` (periods): a slot counts as begun that long before its deadline.
    0 suits a caller that sleeps to :attr:`next_deadline_ns` itself
    (:class:`DeadlineThread`): a step runs at its deadline, never before. A
    caller woken on a grid of its own (an rcl timer) needs a lead, since its
    grid sits at an arbitrary phase against the schedule (wherever its first
    tick fell); but then a tick only ``1 - lead`` periods minus that phase late
    — as little as nothing — runs two steps and leaves the next tick empty: a
    gap of up to two periods where the timer itself was a little late. That is
    why the plant node no longer runs its steps from a timer.
    """

    period: float
    """Seconds between steps (used to the nanosecond)."""
    max_lag: float = 1.0
    """Longest stall (s) that is caught up by a burst of steps."""
    lead: float = 0.5
    """Fraction of a period before its deadline at which a slot counts as begun."""
    reanchors: int = 0
    """How many times the schedule gave up catching up."""
    _anchor_ns: int | None = field(default=None, repr=False)
    _slot: int = field(default=0, repr=False)

    @property
    def period_ns(self) -> int:
        """The period in whole nanoseconds: the grid the deadlines sit on."""
        return round(self.period * 1e9)

    def due(self, now_ns: int) -> list[int]:
        """Deadlines (monotonic ns) of the steps to run at ``now_ns``, oldest first."""
        nxt = self.next_deadline_ns
        if nxt is None or now_ns - nxt > self.max_lag * 1e9:
            self.reanchors += nxt is not None
            self._anchor_ns, self._slot = now_ns, 0
        begun = now_ns + self.lead * self.period_ns
        out = []
        while (deadline := self._deadline_ns(self._slot)) <= begun:
            out.append(deadline)
            self._slot += 1
        return out

    def _deadline_ns(self, slot: int) -> int:
        assert self._anchor_ns is not None
        return self._anchor_ns + slot * self.period_ns

    @property
    def next_deadline_ns(self) -> int | None:
        """Deadline (monotonic ns) of the next step not yet run (None before the first)."""
        return None if self._anchor_ns is None else self._deadline_ns(self._slot)


class DeadlineThread:
    """Call ``on_due(now_ns, due_ns)`` at the pacer's absolute deadlines, from a thread of its own.

    Why not an rcl timer on the node's executor: the executor wakes for every
    entity of the node (subscriptions, services, other timers), rebuilds its
    wait set in Python each time and runs one callback after another, so a
    tick that falls due while it is busy waits — measured as the plant's p99
    inter-arrival above a bare timer's (benchmarks/bench_plant_rate.py). This
    thread does nothing but sleep to the next deadline (a timed wait on a
    monotonic clock, released GIL) and run the steps whose slots have begun,
    so its lateness is the kernel's wake-up plus the step itself. The schedule
    is the pacer's: absolute, no drift, a stall caught up by running the missed
    slots at once (their samples are already late), a long one re-anchored.

    The thread ends on :meth:`stop`, when ``alive()`` turns false (the context
    shut down under it: a signal), or when ``on_due`` raises — then the error is
    printed and ``on_error`` told, unless ``alive()`` is false by then (a
    publisher refusing to publish on a context a signal shut down is a stop).
    SIGINT/SIGTERM are blocked in it so they always reach the main thread.
    """

    def __init__(self, pacer: DeadlinePacer, on_due: Callable[[int, list[int]], None], *,
                 alive: Callable[[], bool], on_error: Callable[[BaseException], None],
                 name: str = "deadline") -> None:
        self.pacer = pacer
        self._on_due = on_due
        self._alive = alive
        self._on_error = on_error
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        """Run the first step now and the rest at their deadlines (not after :meth:`stop`)."""
        if not self._stop.is_set():
            self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Ask the thread to end and wait for it (a step in progress finishes first); a thread
        not started yet never will be."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    @property
    def started(self) -> bool:
        """Whether :meth:`start` ran (the thread may have ended since)."""
        return self._thread.ident is not None

    @property
    def running(self) -> bool:
        """Whether the thread is still alive."""
        return self._thread.is_alive()

    def _run(self) -> None:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
        try:
            while not self._stop.is_set() and self._alive():
                now_ns = time.monotonic_ns()
                due = self.pacer.due(now_ns)
                if due:
                    self._on_due(now_ns, due)
                deadline = self.pacer.next_deadline_ns
                wait = 0.0 if deadline is None else (deadline - time.monotonic_ns()) * 1e-9
                self._stop.wait(max(wait, 0.0))
        except Exception as exc:  # reported below unless it is part of a stop
            if self._stop.is_set() or not self._alive():
                return
            traceback.print_exc()
            self._on_error(exc)


@contextmanager
def ros_session(args: Sequence[str] | None = None) -> Iterator[None]:
    """``rclpy.init`` on the default context, ``rclpy.try_shutdown`` on the way out.

    Why not ``with rclpy.init(args=...)``: only Kilted's rclpy returns a context
    manager there; Jazzy's returns None and the ``with`` raises TypeError.
    """
    rclpy.init(args=None if args is None else list(args))
    try:
        yield
    finally:
        rclpy.try_shutdown()


def main(build: Callable[[], Node], args: Sequence[str] | None = None) -> int:
    """Run the node ``build()`` makes in this process; return the process exit status.

    An ``RCLError`` means malformed ``--ros-args`` only while rcl initialises;
    once the context exists, one raised after a signal shut the context down
    ("publisher's context is invalid", "failed to initialize wait set") is
    part of a normal stop and exits 0.
    """
    argv = list(sys.argv if args is None else args)
    try:
        argv = expand_rig_option(argv)
        check_params_files(argv)
        check_rig_files(argv)
        allow_wildcard_names(wildcard_parameter_names(argv))
    except MsdBenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    install_stop_handler()  # a stop from here on is KeyboardInterrupt (a deferred one too)
    try:
        # no `with rclpy.init(...)`: only Kilted's rclpy returns a context manager there, Jazzy's None
        rclpy.init(args=argv)
    except RCLError as exc:  # malformed --ros-args: rcl refuses to initialise
        print(f"error: {str(exc).split(', at ')[0]}", file=sys.stderr)
        return EXIT_USAGE
    except UnknownROSArgsError as exc:
        print(f"error: unknown ROS argument {exc} (after --ros-args)", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        return 0
    try:
        return _run_node(build, argv)
    except KeyboardInterrupt:
        return 0
    finally:
        rclpy.try_shutdown()


def _run_node(build: Callable[[], Node], argv: list[str]) -> int:
    """Build, spin and close the node inside an initialised context."""
    node: Node | None = None
    status = 0
    try:
        extra = remove_ros_args(argv)[1:]
        if extra:
            raise ConfigError(f"unexpected argument {extra[0]!r}: node options go after --ros-args, "
                              f"e.g. --ros-args -p name:=value")
        node = build()
        reject_unknown_parameters(node)
        executor = make_executor(events=wants_events_executor(node))  # alive until the node is closed
        status = spin_node(node, executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        status = 0
    except MsdBenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        status = EXIT_USAGE
    except RCLError:
        if rclpy.ok():
            raise
        status = 0  # a signal shut the context down under a callback: a normal stop
    finally:
        if node is not None:
            status = _close(node, status)
    return status


def _close(node: Node, status: int) -> int:
    """Close the node; a ``done`` it completed while closing (a failed bag) decides the status."""
    try:
        close_node(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RCLError:
        if rclpy.ok():
            raise
    done = getattr(node, "done", None)
    if status == 0 and done is not None and done.done():
        return int(done.result())
    return status


def run(build: Callable[..., Node]) -> None:
    """``sys.exit(main(build))`` for launch scripts; with ``--serve``, node after node (:mod:`.serve`)."""
    if serve.wants_serving(sys.argv):
        sys.exit(serve.serve(build, sys.argv))
    sys.exit(main(build))
