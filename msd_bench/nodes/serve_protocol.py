"""Moved to :mod:`msd_bench.app.serve_protocol` (graph imports it, and graph never imports a node).

Re-exported here only so a node module written against the old path keeps working while
branches merge; new code imports :mod:`msd_bench.app.serve_protocol`. The layer test
(tests/test_layers.py) refuses this module to anything outside nodes.
"""

from msd_bench.app.serve_protocol import (
    EVENT_PREFIX,
    MAX_EVENT_BYTES,
    READY_LINE,
    SERVE_FLAG,
    STOP_LINE,
    EventError,
    event_line,
    exit_line,
    exit_pattern,
    parse_event,
    running_line,
)

__all__ = ["EVENT_PREFIX", "MAX_EVENT_BYTES", "READY_LINE", "SERVE_FLAG", "STOP_LINE", "EventError",
           "event_line", "exit_line", "exit_pattern", "parse_event", "running_line"]
