"""Fault row "duplicate plants": exactly one plant-like node survives on a namespace, no race."""

from __future__ import annotations

import time

import pytest
import rclpy
from rclpy.context import Context

from msd_bench.graph import launch
from msd_bench.nodes import plant_claim
from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec


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
        survivor.wait_for_line(r"ready \(", 10.0)
    assert "shutdown: steps=" in survivor.output()


def test_started_later_yields_at_its_heartbeat() -> None:
    """A plant that skipped the start-up wait still yields once it hears an earlier claim."""
    with launch.process_group() as procs:
        first = procs.start("plant.py", ["-p", "duplicate_check:=0.0"], name="first")
        first.wait_for_line(r"ready \(", 30.0)
        second = procs.start("plant.py", ["-p", "duplicate_check:=0.0"], name="second")
        assert second.wait(30.0) == 2
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


def test_claim_order_and_staleness() -> None:
    own = plant_claim.Claim(2_000, 10, "b", "/msd/plant")
    earlier = plant_claim.Claim(1_000, 99, "a", "/msd/plant")
    tie = plant_claim.Claim(2_000, 9, "c", "/msd/plant")
    now = 10**12
    assert plant_claim.earlier_rival(own, {"a": (earlier, now)}, now) == earlier
    assert plant_claim.earlier_rival(own, {"c": (tie, now)}, now) == tie  # same start: lower pid wins
    assert plant_claim.earlier_rival(earlier, {"b": (own, now)}, now) is None
    stale = now - int((plant_claim.STALE_S + 0.1) * 1e9)
    assert plant_claim.earlier_rival(own, {"a": (earlier, stale)}, now) is None
