"""Suite-wide isolation: every test run gets its own ROS 2 domain on loopback only.

Set before any test imports rclpy, so DDS never multicasts off the machine and
two concurrent runs (or a developer's bench.py) never see each other.
"""

from __future__ import annotations

import os
import random
from collections.abc import Iterator
from typing import TYPE_CHECKING

import pytest

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
MAX_DOMAIN = 232
"""Largest ROS domain id Fast DDS maps to ports with its defaults."""
if "MSD_TEST_DOMAIN_ID" not in os.environ:
    # One domain for the whole run, shared with the node processes tests start.
    os.environ["MSD_TEST_DOMAIN_ID"] = str(random.Random(os.getpid()).randint(1, 200))


def worker_domain(base: int, worker: str | None) -> int:
    """The domain of one pytest-xdist worker (``gw0``, ``gw1`` ...): the run's domain plus the
    worker's index, wrapped into 1..MAX_DOMAIN. Why: workers inherit the run's domain, and two
    workers in one domain would see each other's plants (namespace claims, topics) mid-test."""
    if not worker or not worker.startswith("gw"):
        return base
    return 1 + (base - 1 + int(worker[2:])) % MAX_DOMAIN


os.environ["MSD_TEST_DOMAIN_ID"] = str(worker_domain(int(os.environ["MSD_TEST_DOMAIN_ID"]),
                                                     os.environ.get("PYTEST_XDIST_WORKER")))
os.environ["ROS_DOMAIN_ID"] = os.environ["MSD_TEST_DOMAIN_ID"]

if TYPE_CHECKING:
    from tests.e2e.realtime_runs import BackgroundPair, Run

REALTIME = "realtime_runs"
"""The e2e fixture of the two real-time ``--plant-ns`` runs (tests/e2e/realtime_runs.py)."""


def _reads_realtime_runs(item: pytest.Item) -> bool:
    return REALTIME in getattr(item, "fixturenames", ())


LONG_FIRST = ("e2e", "browser", "rig", "faults", "nodes", "app", "deeprl", "fuzz")
"""The folders whose files run long (node processes, whole bench runs, check-rig's real-time protocol,
whole sweeps, Hypothesis over bags; files of 10-40 s): their files are handed to pytest-xdist's workers
first, and the folders of many short files (core, io, graph, gym, designs, msgs, the top level) last.
Why: ``--dist loadfile`` hands out files in collection order, and a long file handed out last keeps
one worker busy after the others have finished; long jobs first is the classic remedy
(longest-processing-time-first). Only the order changes, never what runs."""


def _folder_rank(item: pytest.Item) -> int:
    parts = item.nodeid.split("/")
    return LONG_FIRST.index(parts[1]) if len(parts) > 2 and parts[1] in LONG_FIRST else len(LONG_FIRST)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The tests that read the real-time runs go last: the runs start with the session and take about
    320 s of real time (three runs, the PLM route among them), which the rest of the selected tests
    spend working. They are the realtime tier (docs/testing.md §Tiers), not in the default
    ``make test``. Before them, the long folders' files go first (:data:`LONG_FIRST`); the sort is
    stable, so a file's tests keep their order."""
    items.sort(key=lambda item: (_reads_realtime_runs(item), _folder_rank(item)))


class OnDemandPair:
    """The real-time runs of one pytest-xdist worker, started by the first test that reads them.

    Why not at the session's start as without workers: every worker collects every test, so each
    would start its own runs; only a worker that is given a reader asks. (CI runs the realtime tier
    in one process, where the runs start with the session and overlap the other tests.)"""

    def __init__(self, tmp_path_factory: pytest.TempPathFactory) -> None:
        self._tmp = tmp_path_factory
        self._pair: BackgroundPair | None = None

    def result(self) -> dict[str, Run]:
        """The runs' results, starting them on the first call; waits for them to end."""
        if self._pair is None:
            from tests.e2e.realtime_runs import BackgroundPair

            self._pair = BackgroundPair(self._tmp.mktemp("realtime")).start()
        return self._pair.result()

    def close(self) -> None:
        """Stops the runs if they were started."""
        if self._pair is not None:
            self._pair.close()


@pytest.fixture(scope="session", autouse=True)
def realtime_pair(request: pytest.FixtureRequest,
                  tmp_path_factory: pytest.TempPathFactory) -> Iterator[BackgroundPair | OnDemandPair | None]:
    """The real-time runs, started in the background at the first test if any selected test reads
    them (None otherwise); stopped at the end of the session whatever happened. In a
    pytest-xdist worker, started by the first reader instead (:class:`OnDemandPair`)."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        on_demand = OnDemandPair(tmp_path_factory)
        try:
            yield on_demand
        finally:
            on_demand.close()
        return
    if not any(_reads_realtime_runs(item) for item in request.session.items):
        yield None
        return
    from tests.e2e.realtime_runs import BackgroundPair

    pair = BackgroundPair(tmp_path_factory.mktemp("realtime")).start()
    try:
        yield pair
    finally:
        pair.close()
