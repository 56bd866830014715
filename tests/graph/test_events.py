"""Structured result events: the identifier's models are announced as events, never a parsed log line."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from msd_bench.app.serve_protocol import EventError, event_line, exit_line, parse_event
from msd_bench.graph.bench import StageError, _check_identified, _follow_saved
from msd_bench.graph.jobs import Job

LOG_SAVED = "[INFO] [1764630000.1] [identifier]: saved model glm: /run/models/glm.json"


def _job(lines: list[str], index: int = 0) -> Job:
    """A Job over a served process that printed ``lines`` (and is still running)."""
    proc = SimpleNamespace(lines=lines, popen=SimpleNamespace(poll=lambda: None), name="identifier")
    return Job(server=SimpleNamespace(proc=proc), index=index, since=0, name="identifier")  # type: ignore[arg-type]


def _followed(lines: list[str]) -> list[str]:
    heard: list[str] = []
    _follow_saved(_job([*lines, exit_line(0, 0)]), heard.append, deadline=float("inf"))
    return heard


def test_an_event_announces_a_model():
    saved = event_line("identifier", "model_saved", {"model": "glm", "path": "/run/models/glm.json"})
    assert _followed([saved]) == ["glm"]


def test_a_log_line_that_looks_like_a_result_no_longer_counts():
    assert _followed([LOG_SAVED, "saved model plm: /x.json"]) == []
    with pytest.raises(StageError, match="without its 'identified' result event"):
        _check_identified(_job([LOG_SAVED, "identified", exit_line(0, 0)]))


def test_the_end_event_is_what_counts():
    _check_identified(_job([event_line("identifier", "identified", {"models": ["glm"]}), exit_line(0, 0)]))


@pytest.mark.parametrize("line, why", [
    ("[event] {not json", "not valid JSON"),
    ("[event] [1, 2]", "expected an object"),
    ('[event] {"node": "identifier"}', "expected an object with an 'event' name"),
    ('[event] {"node": "agent", "event": "model_saved", "model": "glm"}', "names node 'agent'"),
    ('[event] {"node": "identifier", "event": "model_saved", "model": 3}', "names model 3"),
])
def test_a_malformed_event_is_one_line_naming_the_node(line, why):
    with pytest.raises(EventError, match=why) as err:
        _followed([line])
    assert str(err.value).startswith("identifier: ") and "\n" not in str(err.value)


def test_events_of_a_later_job_are_not_this_jobs():
    later = event_line("identifier", "model_saved", {"model": "plm", "path": "/x"})
    job = _job([exit_line(0, 0), later])
    assert job.events("identifier", "model_saved") == []


def test_a_line_without_the_prefix_is_no_event():
    assert parse_event(' [event] {"node": "identifier", "event": "identified"}', "identifier") is None


def test_the_record_stage_waits_for_the_playing_event_not_the_log_line():
    from msd_bench.graph.record import RecordError, _wait_playing, paper_plan

    spec, rec = paper_plan(0, 100, 100)[0], _job([])
    playing = event_line("excitation", "playing", {"commands": 100})
    _wait_playing(spec, _job([playing]), rec, timeout=5.0)
    log = "[INFO] [1.0] [excitation]: plant matched: playing 100 commands"
    with pytest.raises(RecordError, match="ended before playing"):
        _wait_playing(spec, _job([log, exit_line(0, 1)]), rec, timeout=5.0)
    with pytest.raises(RecordError, match="excitation: malformed result event"):
        _wait_playing(spec, _job(['[event] {"node": "excitation"}']), rec, timeout=5.0)
