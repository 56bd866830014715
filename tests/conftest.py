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
if "MSD_TEST_DOMAIN_ID" not in os.environ:
    # One domain for the whole run, shared with the node processes tests start.
    os.environ["MSD_TEST_DOMAIN_ID"] = str(random.Random(os.getpid()).randint(1, 200))
os.environ["ROS_DOMAIN_ID"] = os.environ["MSD_TEST_DOMAIN_ID"]

if TYPE_CHECKING:
    from tests.e2e.realtime_runs import BackgroundPair

REALTIME = "realtime_runs"
"""The e2e fixture of the two real-time ``--plant-ns`` runs (tests/e2e/realtime_runs.py)."""


def _reads_realtime_runs(item: pytest.Item) -> bool:
    return REALTIME in getattr(item, "fixturenames", ())


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The tests that read the real-time runs go last (stable otherwise): the runs start with the
    session and take about 320 s of real time (three runs, the PLM route among them), which the
    rest of the selected tests spend working. They are the realtime tier (docs/testing.md §Tiers),
    not in the default ``make test``."""
    items.sort(key=_reads_realtime_runs)


@pytest.fixture(scope="session", autouse=True)
def realtime_pair(request: pytest.FixtureRequest,
                  tmp_path_factory: pytest.TempPathFactory) -> Iterator[BackgroundPair | None]:
    """The real-time runs, started in the background at the first test if any selected test reads
    them (None otherwise); stopped at the end of the session whatever happened."""
    if not any(_reads_realtime_runs(item) for item in request.session.items):
        yield None
        return
    from tests.e2e.realtime_runs import BackgroundPair

    pair = BackgroundPair(tmp_path_factory.mktemp("realtime")).start()
    try:
        yield pair
    finally:
        pair.close()
