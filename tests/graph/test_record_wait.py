"""bench.py's wait for an experiment to start playing (graph/record._wait_playing), on fake jobs.

Why: on a loaded machine a short lock-step experiment played whole, and its recorder stopped at
its message count, between two polls of the wait; the wait then blamed the recorder for ending
"before recording" although the bag held every message (seen under xdist at load 15)."""

from __future__ import annotations

import pytest

from msd_bench.graph.record import EXCITATION, PLAYING_EVENT, RecordError, _wait_playing


class FakeJob:
    """A job that has (or has not) finished and has (or has not) announced it plays."""

    def __init__(self, name: str, finished: bool, playing: bool) -> None:
        self.name, self._finished, self._playing = name, finished, playing
        self.lines = ["closed the bag with 400 messages"]

    def finished(self) -> bool:
        return self._finished

    def wait(self, timeout: float) -> int:
        return 0

    def events(self, node: str, event: str) -> list[dict[str, object]]:
        assert (node, event) == (EXCITATION, PLAYING_EVENT)
        return [{"event": event}] if self._playing else []


class Spec:
    name = "val_broad"


def test_an_experiment_that_played_whole_before_the_poll_is_not_an_error() -> None:
    _wait_playing(Spec(), FakeJob("excitation", True, True), FakeJob("recorder", True, False), 1.0)  # type: ignore[arg-type]


def test_a_recorder_that_ended_before_anything_played_is_one_line() -> None:
    with pytest.raises(RecordError, match=r"recorder ended \(0\) before recording: closed the bag"):
        _wait_playing(Spec(), FakeJob("excitation", False, False), FakeJob("recorder", True, False), 1.0)  # type: ignore[arg-type]
