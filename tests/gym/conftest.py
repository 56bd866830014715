"""Gym test fixtures: a lock-step plant node served from a background thread of this process."""

from __future__ import annotations

import itertools
import os
import threading
import warnings
from collections.abc import Iterator

import pytest

with warnings.catch_warnings():  # rclpy pulls in lark, which imports the deprecated sre_* modules
    warnings.filterwarnings("ignore", "module 'sre_.*' is deprecated", DeprecationWarning)
    import lark  # noqa: F401

_names = itertools.count()


@pytest.fixture
def lockstep_plant() -> Iterator[str]:
    """A lock-step PlantNode of the default preset under a fresh namespace; yields the namespace.

    It runs on its own context and executor in a thread, as a separate node
    would, so the environment's ROS backend talks to it over DDS for real.
    """
    yield from _served_plant(lockstep=True, with_reset=True)


@pytest.fixture(params=[pytest.param(True, id="with-reset"),
                        # without reset the episode waits in real time for the mass to come to rest
                        pytest.param(False, id="no-reset", marks=pytest.mark.realtime)])
def realtime_plant(request: pytest.FixtureRequest) -> Iterator[str]:
    """A real-time PlantNode (100 Hz), with or without its ``reset`` subscription (a rig has none)."""
    yield from _served_plant(lockstep=False, with_reset=bool(request.param))


@pytest.fixture
def rig_emulator() -> Iterator[str]:
    """The rig emulator with its realistic defaults (2 mm noise, delay, lag, friction, no reset)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from msd_bench.nodes.rig_node import RigNode

    ns = f"/gymrig{os.getpid()}_{next(_names)}"
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    node = RigNode(namespace=ns, context=ctx, parameter_overrides=[Parameter("duplicate_check", value=0.0)])
    yield from _spin(node, ctx, ns)


def _spin(node: object, ctx: object, ns: str) -> Iterator[str]:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=ctx)  # type: ignore[arg-type]
    executor.add_node(node)  # type: ignore[arg-type]
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()
    try:
        yield ns
    finally:
        executor.shutdown()
        thread.join(timeout=5.0)
        node.destroy_node()  # type: ignore[attr-defined]
        rclpy.try_shutdown(context=ctx)  # type: ignore[arg-type]


def _served_plant(lockstep: bool, with_reset: bool) -> Iterator[str]:
    import rclpy
    from rclpy.context import Context

    from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec

    ns = f"/gym{os.getpid()}_{next(_names)}"
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    node = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=lockstep, duplicate_check=0.0),
                     namespace=ns, context=ctx)
    if not with_reset:
        for sub in list(node.subscriptions):
            if sub.topic_name.endswith("/reset"):
                node.destroy_subscription(sub)
    yield from _spin(node, ctx, ns)
