"""Serve a plant-like node in-process on its own context and thread; check it from another context."""

from __future__ import annotations

import argparse
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from msd_bench.cli import build_parser
from msd_bench.commands import check_rig
from msd_bench.core.rigs.conformance import Clause
from tests.nodes.conftest import shutdown_context

LENIENT = ["--timing-tolerance", "10", "--seconds", "0", "--discovery-timeout", "10"]
"""Options of every check in the suite: timing limits x10, so a loaded machine cannot fail them."""


@contextmanager
def serving(build: Callable[[Context], Node]) -> Iterator[Node]:
    """``build(context)`` spun on a background thread until the block ends."""
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    stop = threading.Event()
    try:
        node = build(ctx)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(node)

        def spin() -> None:
            while not stop.is_set():
                ex.spin_once(timeout_sec=0.02)
        thread = threading.Thread(target=spin, daemon=True)
        thread.start()
        try:
            yield node
        finally:
            stop.set()
            thread.join(5.0)
            ex.shutdown()
    finally:
        shutdown_context(ctx)


def check(namespace: str, *options: str) -> list[Clause]:
    """check-rig on ``namespace`` from a private context, with the suite's lenient timing."""
    args: argparse.Namespace = build_parser().parse_args(["check-rig", namespace, *LENIENT, *options])
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        return check_rig.check(args, context=ctx)
    finally:
        shutdown_context(ctx)


def failed(clauses: list[Clause]) -> list[str]:
    """Names of the clauses that failed."""
    return [c.name for c in clauses if not c.passed]
