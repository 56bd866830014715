"""Session fixtures of the e2e tier."""

from __future__ import annotations

import pytest

from tests.e2e.realtime_runs import Run, run_both


@pytest.fixture(scope="session")
def realtime_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Run]:
    """Both real-time ``--plant-ns`` runs (msd face and ros2_control face), run once, side by side."""
    return run_both(tmp_path_factory.mktemp("realtime"))
