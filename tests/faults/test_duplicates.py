"""Fault row "duplicate plants": exactly one plant-like node survives on a namespace, no race."""

from __future__ import annotations

import os
import time

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String

from msd_bench.graph import launch
from msd_bench.nodes import plant_claim
from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec
from msd_msgs_py.contract import PLANT_CLAIM
from msd_msgs_py.ros import qos


def test_simultaneous_plant_processes_leave_exactly_one() -> None:
    with launch.process_group() as procs:
        a = procs.start("plant.py", ["-p", "duplicate_check:=3.0"], name="a")
        b = procs.start("plant.py", ["-p", "duplicate_check:=3.0"], name="b")
        deadline = time.monotonic() + 40.0
        while time.monotonic() < deadline and a.popen.poll() is None and b.popen.poll() is None:
            time.sleep(0.1)
        time.sleep(2.0)  # a late loser would go within a heartbeat
        alive = [p for p in (a, b) if p.popen.poll() is None]
        gone = [p for p in (a, b) if p.popen.poll() is not None]
        assert len(alive) == 1 and len(gone) == 1, (a.output(), b.output())
        loser = gone[0]
        assert loser.wait(1.0) == 2
        errors = [ln for ln in loser.lines if ln.startswith("error:")]
        assert len(errors) == 1 and "already has a publisher" in errors[0]
        assert "Traceback" not in loser.output()
        survivor = alive[0]
        survivor.wait_for_line(r"ready \(", 120.0)
        # SIGINT with a generous grace: the group's own 5 s went by before the shutdown line on a
        # loaded machine (the behaviour is a clean shutdown, not how fast)
        launch.stop(survivor, grace=(90.0, 10.0, 3.0))
    assert "shutdown: steps=" in survivor.output()


def test_started_later_yields_at_its_heartbeat() -> None:
    """A plant that skipped the start-up wait still yields once it hears an earlier claim."""
    with launch.process_group() as procs:
        first = procs.start("plant.py", ["-p", "duplicate_check:=0.0"], name="first")
        first.wait_for_line(r"ready \(", 120.0)
        second = procs.start("plant.py", ["-p", "duplicate_check:=0.0"], name="second")
        # generous: the second plant's start-up (imports, discovery) before its first heartbeat took
        # over 30 s beside a loaded suite; the behaviour is that it yields, not how fast
        assert second.wait(180.0) == 2
        assert any("already has a publisher" in ln and "shutting down" in ln for ln in second.lines)
        assert first.popen.poll() is None


@pytest.mark.ros
def test_a_node_destroyed_a_moment_ago_is_not_a_rival() -> None:
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        old = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.0),
                        context=ctx)
        old.destroy_node()
        new = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.5),
                        context=ctx)  # would raise GraphConflictError if the old claim counted
        assert not new.done.done()
        new.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)


def _heard(claim: plant_claim.Claim, at: int, established: bool = False) -> plant_claim.Heard:
    return plant_claim.Heard(claim, at, at, established)


def test_claim_order_and_staleness() -> None:
    own = plant_claim.Claim(2_000, 10, "b", "/msd/plant")
    earlier = plant_claim.Claim(1_000, 99, "a", "/msd/plant")
    tie = plant_claim.Claim(2_000, 9, "c", "/msd/plant")
    now, window = 10_000, 10**9
    assert plant_claim.earlier_rival(own, {earlier: _heard(earlier, now)}, now, window) == earlier
    assert plant_claim.earlier_rival(own, {tie: _heard(tie, now)}, now, window) == tie  # same start: pid
    assert plant_claim.earlier_rival(earlier, {own: _heard(own, now)}, now, window) is None
    later = now + int((plant_claim.STALE_S + 0.1) * 1e9)
    assert plant_claim.earlier_rival(own, {earlier: _heard(earlier, now)}, later, window) is None


def test_a_claim_first_heard_after_the_window_never_wins_whatever_its_start() -> None:
    own = plant_claim.Claim(10**9, 10, "b", "/msd/plant")
    fake = plant_claim.Claim(0, 1, "f", "/msd/plant")  # states the earliest possible start
    book = plant_claim.ClaimBook(own, 0.0)
    heard_at = own.start_ns + book.window_ns + 1
    book.hear(plant_claim.encode(fake, established=True), now_ns=heard_at)
    assert book.rival(heard_at) is None
    assert [h.claim for h in book.ignored(heard_at)] == [fake]
    assert book.ignored(heard_at) == []  # reported once
    within = plant_claim.ClaimBook(own, 0.0)
    within.hear(plant_claim.encode(fake), now_ns=own.start_ns + within.window_ns)
    assert within.rival(own.start_ns + within.window_ns) == fake  # a simultaneous start is arbitrated


def test_the_window_starts_when_the_node_first_listens_not_at_its_claim() -> None:
    """CI on Jazzy: a plant without a start-up wait compiled its model for longer than the window
    before it first spun, heard the serving plant's latched claim only then, ignored it, and ran."""
    own = plant_claim.Claim(10**9, 10, "new", "/msd/plant")
    serving = plant_claim.Claim(5 * 10**8, 20, "old", "/msd/plant")
    book = plant_claim.ClaimBook(own, 0.0)
    spun_at = own.start_ns + 10 * book.window_ns  # a long build before the first spin
    assert not book.established(spun_at)  # not listening yet: it never claims to be serving
    book.begin_listening(spun_at)
    book.hear(plant_claim.encode(serving, established=True), now_ns=spun_at + 10**8)
    assert book.rival(spun_at + 10**8) == serving
    book.begin_listening(spun_at + 2 * book.window_ns)  # once: a later call does not reopen the window
    late = plant_claim.Claim(0, 1, "f", "/msd/plant")
    heard_at = spun_at + book.window_ns + 1
    book.hear(plant_claim.encode(late, established=True), now_ns=heard_at)
    assert [h.claim for h in book.ignored(heard_at)] == [late]
    assert book.established(heard_at)


def test_a_newcomer_yields_to_an_established_claim_whatever_the_start_times() -> None:
    """Two hosts with skewed clocks: the newcomer states the earlier start and still yields."""
    own = plant_claim.Claim(5 * 10**9, 10, "new", "/msd/plant")
    serving = plant_claim.Claim(9 * 10**9, 20, "old", "/msd/plant")
    book = plant_claim.ClaimBook(own, 1.0)
    book.hear(plant_claim.encode(serving, established=True), now_ns=own.start_ns + 10**8)
    assert book.rival(own.start_ns + 10**8) == serving
    simultaneous = plant_claim.ClaimBook(serving, 1.0)  # heard not yet established: start order decides
    simultaneous.hear(plant_claim.encode(own), now_ns=serving.start_ns)
    simultaneous.hear(plant_claim.encode(own, established=True), now_ns=serving.start_ns + 10**8)
    assert simultaneous.rival(serving.start_ns + 10**8) == own


NOT_CLAIMS = ["", "not json", "[]", "{}", "[" * 100_000, '{"a": "' + "x" * 10_000 + '"}',
              '{"start_ns": "x", "pid": 1, "token": "t", "node": "n", "sent_ns": 1}']


@pytest.mark.parametrize("text", NOT_CLAIMS)
def test_anything_but_a_claim_is_dropped(text: str) -> None:
    book = plant_claim.ClaimBook(plant_claim.Claim(0, 1, "own"), 0.0)
    book.hear(text, now_ns=1)
    assert book.heard == {}


def test_a_flood_of_claims_is_bounded() -> None:
    own = plant_claim.Claim(10**12, 1, "own")
    book = plant_claim.ClaimBook(own, 0.0)
    for i in range(plant_claim.MAX_HEARD + 50):
        book.hear(plant_claim.encode(plant_claim.Claim(i, 2, f"t{i}")), now_ns=own.start_ns)
    assert len(book.heard) == plant_claim.MAX_HEARD


def _claims_of(node: Node, topic: str, into: list[str]) -> None:
    listen = qos(PLANT_CLAIM)
    listen.depth = 32
    node.create_subscription(String, topic, lambda m: into.append(m.data), listen)


def test_a_fake_early_claim_does_not_stop_a_serving_plant() -> None:
    """Issue 20: a participant publishing a claim that states an early start shut a running plant down."""
    ns = f"/fakeclaim{os.getpid()}"
    topic = PLANT_CLAIM.resolve(ns)
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    node = rclpy.create_node("fake_claimer", context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    seen: list[str] = []
    _claims_of(node, topic, seen)
    try:
        with launch.process_group() as procs:
            plant = procs.start("plant.py", ["-p", "duplicate_check:=0.0", "-r", f"__ns:={ns}"])
            deadline = time.monotonic() + 60.0
            while not any('"established": true' in m for m in seen) and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.1)
            assert any('"established": true' in m for m in seen), plant.output()
            fake = plant_claim.Claim(0, 1, "f" * 16, f"{ns}/plant")
            pub = node.create_publisher(String, topic, qos(PLANT_CLAIM))
            since = len(plant.lines)
            for _ in range(40):  # re-sent as a real claimer would, until the plant has judged it
                pub.publish(String(data=plant_claim.encode(fake, established=True)))
                executor.spin_once(timeout_sec=0.25)
                if any("ignoring the claim of" in ln for ln in plant.lines[since:]):
                    break
            plant.wait_for_line(r"ignoring the claim of .*pid 1\b", 5.0, since)
            assert plant.popen.poll() is None, plant.output()
            assert "already has a publisher" not in plant.output()
            # a clean exit on SIGINT, given the time a loaded machine needs (stop_all's 5 s ended in
            # SIGTERM once, beside a loaded suite)
            assert launch.stop(plant, grace=(120.0, 5.0, 5.0)) == 0
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
