"""Fixtures of the app tests: one local Ray cluster shared by every Ray test of the package."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from msd_bench.app.executor import ExecutorOptions, RayExecutor


@pytest.fixture(scope="package")
def ray_cluster() -> Iterator[None]:
    """A two-CPU local cluster started once, as ``--executor ray --workers 2`` starts it: starting
    Ray costs seconds a time, and the executor joins a running cluster (leaving it running) as it
    joins a user's. Starting and shutting down a cluster of its own is this fixture's work."""
    executor = RayExecutor(ExecutorOptions(kind="ray", workers=2), lambda line: None)
    assert executor.started, "a Ray cluster was already running before the app tests"
    try:
        yield
    finally:
        executor.close()
        assert not executor.ray.is_initialized()
