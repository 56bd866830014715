"""``--serve``: one long-lived process runs node after node, each built from a line on stdin.

Why: a node process pays for its interpreter, its imports and the DDS
participant's discovery (1-3 s on this machine) before it does anything. The
main job records twelve experiments and validates several agent kinds one
after another; as one process per experiment and per kind that start-up was
most of its time. A served process pays it once: every later node joins the
same participant, and only its endpoints need matching (milliseconds).

Protocol (line based, so any launcher can drive it):

* stdin, one per line: a JSON list of ROS arguments for the next node
  (``["-p", "bag_path:=bags/x", "-r", "__ns:=/msd"]``: exactly what would
  follow ``--ros-args`` on a command line); ``stop`` ends the running node
  early (closing it, as Ctrl-C would: a recorder completes its bag); end of
  input ends the process after the running node.
* stdout: ``[serve] ready`` once, then per node ``[serve] job N running``
  (its node is built and spinning) and ``[serve] job N exit S`` (S as the
  node's own process would have exited: 0 done, 2 a user mistake, 1 a failure).

Each node is built with its own arguments (``cli_args``), spun until its
``done`` future completes or ``stop`` arrives, then closed and destroyed; a
user mistake in one job is that job's one error line and exit 2, and the
server goes on. SIGINT/SIGTERM close the running node and end the process.

The process also keeps a pool of endpoints (:mod:`msd_bench.nodes.endpoints`)
spun beside each job's node: a lock-step job that asks for it gets the
publishers and subscriptions an earlier job matched, so only the first job of
a stage waits for discovery.
"""

from __future__ import annotations

import json
import os
import queue
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy._rclpy_pybind11 import RCLError, UnknownROSArgsError
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from msd_bench.app.serve_protocol import READY_LINE, SERVE_FLAG, STOP_LINE, exit_line, running_line
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.nodes import endpoints
from msd_bench.nodes.params import (
    allow_wildcard_names,
    check_params_files,
    reject_unknown_parameters,
    wildcard_parameter_names,
)
from msd_bench.nodes.spin_loop import (
    EXIT_USAGE,
    close_node,
    install_stop_handler,
    make_executor,
    stops_requested,
    wants_events_executor,
)

_POLL_S = 0.2
"""Longest time a ``stop`` waits for the executor to notice it."""


def wants_serving(argv: Sequence[str]) -> bool:
    """Whether the process was started with ``--serve`` (before any ``--ros-args``)."""
    head = list(argv[1:])
    if "--ros-args" in head:
        head = head[: head.index("--ros-args")]
    return SERVE_FLAG in head


def job_args(line: str) -> list[str]:
    """A stdin job line as ROS arguments; ConfigError unless it is a JSON list of strings."""
    try:
        value = json.loads(line)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"a job line must be a JSON list of ROS arguments: {exc.msg}") from None
    if not isinstance(value, list) or not all(isinstance(a, str) for a in value):
        raise ConfigError("a job line must be a JSON list of ROS arguments (strings)")
    return value


class _Inbox:
    """stdin read on a thread: job lines queued in order, ``stop`` flagged at once, None at the end."""

    def __init__(self) -> None:
        self.jobs: queue.Queue[str | None] = queue.Queue()
        self.stop = threading.Event()
        threading.Thread(target=self._read, daemon=True, name="serve-stdin").start()

    def _read(self) -> None:
        for raw in sys.stdin:
            line = raw.strip()
            if line == STOP_LINE:
                self.stop.set()
            elif line:
                self.jobs.put(line)
        self.jobs.put(None)


def serve(build: Callable[..., Node], argv: Sequence[str]) -> int:
    """Run nodes from stdin lines in this process until the input ends (module docstring)."""
    install_stop_handler()  # a stop from here on is KeyboardInterrupt (a deferred one too)
    try:
        rclpy.init(args=[a for a in argv if a != SERVE_FLAG])
    except (RCLError, UnknownROSArgsError) as exc:
        print(f"error: {str(exc).split(', at ')[0]}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        return 0
    inbox, executor = _Inbox(), make_executor()
    endpoints.install(endpoints.EndpointPool(Node(f"served_endpoints_{os.getpid()}")))
    print(READY_LINE, flush=True)
    try:
        n = 0
        while (line := inbox.jobs.get()) is not None:
            inbox.stop.clear()
            status = run_job(build, line, n, executor, inbox.stop)
            print(exit_line(n, status), flush=True)
            n += 1
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    finally:
        rclpy.try_shutdown()


def run_job(build: Callable[..., Node], line: str, n: int, executor: Executor, stop: threading.Event) -> int:
    """Build one node from a job line, spin it until done or stopped, close it; its exit status."""
    try:
        args = job_args(line)
        check_params_files(args)
        allow_wildcard_names(wildcard_parameter_names(args))
        node = build(cli_args=["--ros-args", *args], use_global_arguments=False)
    except MsdBenchError as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        return EXIT_USAGE
    except (RCLError, UnknownROSArgsError) as exc:
        print(f"error: malformed ROS arguments: {str(exc).split(', at ')[0]}", file=sys.stderr, flush=True)
        return EXIT_USAGE
    status = 0
    own = wants_events_executor(node)
    if own:  # this job's own events executor (msd_bench.nodes.spin_loop.make_executor)
        executor = make_executor(events=True)
    pool = endpoints.pool()
    finished = False
    try:
        reject_unknown_parameters(node)
        for spun in (node, pool.node) if pool is not None else (node,):
            executor.add_node(spun)
        print(running_line(n), flush=True)
        status = _spin_until_done(node, executor, stop)
        finished = _done_by_itself(node) and status == 0
    except MsdBenchError as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        status = EXIT_USAGE
    finally:
        for spun in (node, pool.node) if pool is not None else (node,):
            executor.remove_node(spun)
        status = _closed(node, status)
        if pool is not None:  # what a job that did not finish left in flight dies with the endpoints
            pool.end_job(finished and status == 0)
        if own:
            executor.shutdown()
    return status


def _done_by_itself(node: Node) -> bool:
    done: Any = getattr(node, "done", None)
    return done is not None and done.done()


def _spin_until_done(node: Node, executor: Executor, stop: threading.Event) -> int:
    done: Any = getattr(node, "done", None)
    if done is None:
        raise ConfigError(f"{node.get_name()} never finishes by itself: it cannot be served")
    if isinstance(executor, SingleThreadedExecutor):
        while not done.done() and not stop.is_set():
            executor.spin_until_future_complete(done, timeout_sec=_POLL_S)
    else:  # events executor: a stop signal must not be raised inside a callback it calls from C++
        with stops_requested() as stopped:
            while not done.done() and not stop.is_set() and not stopped() and executor.context.ok():
                executor.spin_until_future_complete(done, timeout_sec=_POLL_S)
        if stopped():
            raise KeyboardInterrupt
    return int(done.result()) if done.done() else 0


def _closed(node: Node, status: int) -> int:
    """Close and destroy the node; a ``done`` completed while closing (a failed bag) decides."""
    close_node(node)
    done: Any = getattr(node, "done", None)
    if status == 0 and done is not None and done.done():
        return int(done.result())
    return status
