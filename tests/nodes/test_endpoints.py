"""Pooled endpoints (msd_bench.nodes.endpoints): what a served job may reuse from the one before."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import Float64, String

from msd_bench.nodes import endpoints
from tests.nodes.conftest import spin_until

pytestmark = pytest.mark.ros

VOLATILE = QoSProfile(depth=10)
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture
def pool(ctx: Context) -> Iterator[endpoints.EndpointPool]:
    """A pool installed as a served process installs it; uninstalled afterwards."""
    made = endpoints.EndpointPool(Node("pool_under_test", context=ctx))
    endpoints.install(made)
    try:
        yield made
    finally:
        endpoints.install(None)


def _job(ctx: Context, name: str) -> Node:
    return Node(name, namespace="/pool_test", context=ctx)


def test_without_a_pool_a_node_gets_its_own_endpoints(ctx: Context) -> None:
    endpoints.install(None)
    node = _job(ctx, "plain")
    pub = endpoints.create_publisher(node, Float64, "x", VOLATILE, pooled=True)
    sub = endpoints.create_subscription(node, Float64, "x", lambda m: None, VOLATILE, pooled=True)
    assert pub in node.publishers and sub in node.subscriptions


def test_a_later_job_reuses_the_endpoints_and_gets_only_its_own_messages(
        ctx: Context, pool: endpoints.EndpointPool) -> None:
    """Same topic, type and QoS: the second job's endpoints are the first's, matched already; messages
    go to the handler of the job that holds the endpoint, none to a finished job's."""
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(pool.node)
    first, second = [], []
    job1 = _job(ctx, "job1")
    pub1 = endpoints.create_publisher(job1, Float64, "x", VOLATILE, pooled=True)
    sub1 = endpoints.create_subscription(job1, Float64, "x", lambda m: first.append(m.data), VOLATILE,
                                         pooled=True)
    assert pub1 not in job1.publishers and sub1.topic_name == "/pool_test/x"
    assert spin_until(executor, lambda: sub1.get_publisher_count() > 0 and pub1.get_subscription_count() > 0)
    matched = endpoints.matched_since(sub1, True)
    pub1.publish(Float64(data=1.0))
    assert spin_until(executor, lambda: first == [1.0])
    job1.destroy_node()
    pool.end_job(finished=True)

    job2 = _job(ctx, "job2")
    pub2 = endpoints.create_publisher(job2, Float64, "x", VOLATILE, pooled=True)
    sub2 = endpoints.create_subscription(job2, Float64, "x", lambda m: second.append(m.data), VOLATILE,
                                         pooled=True)
    assert pub2 is pub1 and sub2 is sub1 and sub2.get_publisher_count() > 0
    assert endpoints.matched_since(sub2, True, now=time.monotonic() + 10.0) == matched  # grace long over
    again = endpoints.create_subscription(job2, Float64, "x", lambda m: None, VOLATILE, pooled=True)
    assert again is not sub2 and again in job2.subscriptions  # a second asker: a private endpoint
    pub2.publish(Float64(data=2.0))
    assert spin_until(executor, lambda: second == [2.0])
    assert first == [1.0]
    executor.shutdown()


def test_a_job_that_did_not_finish_discards_the_pool(ctx: Context, pool: endpoints.EndpointPool) -> None:
    """Whatever a failed or stopped job left in flight must not reach the next job: new endpoints."""
    job1 = _job(ctx, "failed")
    sub1 = endpoints.create_subscription(job1, Float64, "x", lambda m: None, VOLATILE, pooled=True)
    pub1 = endpoints.create_publisher(job1, Float64, "x", VOLATILE, pooled=True)
    pool.end_job(finished=False)
    assert list(pool.node.subscriptions) == [] and pub1 not in list(pool.node.publishers)
    job2 = _job(ctx, "next")
    fresh = endpoints.create_subscription(job2, Float64, "x", lambda m: None, VOLATILE, pooled=True)
    assert fresh is not sub1
    assert endpoints.create_publisher(job2, Float64, "x", VOLATILE, pooled=True) is not pub1


def test_a_match_time_starts_again_when_the_far_side_went_away() -> None:
    endpoint = endpoints.PooledSubscription(0)
    assert endpoints.matched_since(endpoint, True, now=5.0) == 5.0
    assert endpoints.matched_since(endpoint, True, now=9.0) == 5.0
    assert endpoints.matched_since(endpoint, False) is None
    assert endpoints.matched_since(endpoint, True, now=12.0) == 12.0
    kept, fresh = endpoints.PooledSubscription(0), endpoints.PooledSubscription(0)
    endpoints.matched_since(kept, True, now=1.0)
    assert endpoints.all_matched_since((kept, None), now=20.0) == 1.0  # a kept endpoint: wait long over
    assert endpoints.all_matched_since((kept, fresh, None), now=20.0) == 20.0  # a new one: wait from now


def test_a_latched_subscription_hands_its_last_messages_to_the_next_job(
        ctx: Context, pool: endpoints.EndpointPool) -> None:
    """A recorder's ``ready`` may arrive while the previous excitation job still runs: the next job
    must see it, as a new transient-local reader would."""
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(pool.node)
    talker = Node("talker", context=ctx)
    executor.add_node(talker)
    pub = talker.create_publisher(String, "/pool_test/ready", LATCHED)
    old: list[str] = []
    sub = endpoints.create_subscription(_job(ctx, "old"), String, "/pool_test/ready",
                                        lambda m: old.append(m.data), LATCHED, pooled=True)
    assert spin_until(executor, lambda: sub.get_publisher_count() > 0)
    pub.publish(String(data="bag_b"))
    assert spin_until(executor, lambda: old == ["bag_b"])
    pool.end_job(finished=True)
    new: list[str] = []
    endpoints.create_subscription(_job(ctx, "new"), String, "/pool_test/ready",
                                  lambda m: new.append(m.data), LATCHED, pooled=True)
    assert new == ["bag_b"]
    executor.shutdown()
