"""Session fixtures of the e2e tier."""

from __future__ import annotations

import pytest

from tests.conftest import OnDemandPair
from tests.e2e.realtime_runs import BackgroundPair, Run


@pytest.fixture(scope="session")
def realtime_runs(realtime_pair: BackgroundPair | OnDemandPair | None) -> dict[str, Run]:
    """Both real-time ``--plant-ns`` runs (msd face and ros2_control face), started with the session
    in the background (tests/conftest.py); waits for them to end."""
    assert realtime_pair is not None, "tests/conftest.py starts the pair for every test that reads it"
    return realtime_pair.result()
