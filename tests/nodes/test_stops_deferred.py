"""A stop during a node's compile-before-the-first-tick block waits for the block, whichever thread
the kernel hands the signal to (fault row "shutdown", docs/faults.md)."""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Iterator

import pytest

from msd_bench.nodes.spin import stops_deferred
from msd_bench.nodes.spin_loop import install_stop_handler


@pytest.fixture(autouse=True)
def node_stop_handler() -> Iterator[None]:
    """The handler a node process runs with, this test's only."""
    old = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    install_stop_handler()
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


@pytest.fixture()
def other_thread() -> Iterator[threading.Thread]:
    """A thread that does not block the stop signals, as the DDS threads rclpy starts."""
    gate = threading.Event()
    thread = threading.Thread(target=gate.wait)
    thread.start()
    try:
        yield thread
    finally:
        gate.set()
        thread.join()


def _bytecodes() -> None:
    """Give Python the chance to run a pending handler on this (the main) thread."""
    for _ in range(50):
        time.sleep(0.001)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_sent_to_another_thread_is_raised_after_the_block(
        other_thread: threading.Thread, sig: signal.Signals) -> None:
    finished = False
    with pytest.raises(KeyboardInterrupt), stops_deferred():
        assert other_thread.ident is not None
        signal.pthread_kill(other_thread.ident, sig)
        _bytecodes()
        finished = True
    assert finished


def test_a_stop_inside_a_nested_block_waits_for_the_outer_one(other_thread: threading.Thread) -> None:
    assert other_thread.ident is not None
    inner_done = outer_done = False
    with pytest.raises(KeyboardInterrupt), stops_deferred():
        with stops_deferred():
            signal.pthread_kill(other_thread.ident, signal.SIGINT)
            _bytecodes()
        inner_done = True
        _bytecodes()
        outer_done = True
    assert inner_done and outer_done


def test_no_stop_no_interrupt_and_a_stop_outside_a_block_is_immediate(other_thread: threading.Thread) -> None:
    with stops_deferred():
        _bytecodes()
    assert other_thread.ident is not None
    with pytest.raises(KeyboardInterrupt):
        signal.pthread_kill(other_thread.ident, signal.SIGINT)
        _bytecodes()
        pytest.fail("the stop outside a block was not raised at once")


def test_a_block_on_another_thread_does_not_hold_a_stop(other_thread: threading.Thread) -> None:
    """Only the main thread runs handlers: a stop must reach it even while a worker thread compiles."""
    entered, release = threading.Event(), threading.Event()

    def compile_elsewhere() -> None:
        with stops_deferred():
            entered.set()
            release.wait(10.0)

    worker = threading.Thread(target=compile_elsewhere)
    worker.start()
    try:
        assert entered.wait(10.0) and other_thread.ident is not None
        with pytest.raises(KeyboardInterrupt):
            signal.pthread_kill(other_thread.ident, signal.SIGINT)
            _bytecodes()
            pytest.fail("the stop waited for another thread's block")
    finally:
        release.set()
        worker.join()
