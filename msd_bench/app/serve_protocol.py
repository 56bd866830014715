"""The line protocol of a served node process, shared by the server and its launcher.

Kept apart from :mod:`msd_bench.nodes.serve` so a launcher can speak it without
importing rclpy, and in the application layer because both sides import it: the
served node (nodes) and the launcher (graph), which never imports a node
(docs/design.md §Layers). It needs only core's errors and io's bounded reader.
"""

import json
from typing import Any

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.storage.safe_read import loads_bounded

SERVE_FLAG = "--serve"
"""The launch-script argument (before ``--ros-args``) that turns on serving."""
STOP_LINE = "stop"
"""The stdin line that ends the running node early."""
READY_LINE = "[serve] ready"
"""Printed once the process can take jobs."""


def running_line(n: int) -> str:
    """Printed when job ``n``'s node is built and spinning."""
    return f"[serve] job {n} running"


def exit_line(n: int, status: int) -> str:
    """Printed when job ``n`` has ended with ``status``."""
    return f"[serve] job {n} exit {status}"


def exit_pattern(n: int) -> str:
    """A regex matching job ``n``'s exit line (the status is its last word)."""
    return rf"^\[serve\] job {n} exit (-?\d+)$"


EVENT_PREFIX = "[event] "
"""Start of a structured result event: this prefix, then one JSON object on the same line.

Why a line of its own on stdout rather than a parsed log line: a served process has one
stdout shared by its jobs and the launcher reads it already (exit lines), so no second
channel is needed, while a log line (``[INFO] [...] [identifier]: ...``) never starts with
this prefix, so no wording a node logs can pass for a result (docs/design.md §Jobs).
"""
MAX_EVENT_BYTES = 64 << 10
"""Largest event line read (64 KiB): a real one is under 1 KiB."""


class EventError(MsdBenchError):
    """A malformed result event; the message names the node that sent it."""


def event_line(node: str, event: str, payload: dict[str, Any]) -> str:
    """The line node ``node`` prints to report ``event`` with ``payload`` (JSON-serialisable)."""
    return EVENT_PREFIX + json.dumps({"node": node, "event": event, **payload}, separators=(",", ":"))


def parse_event(line: str, node: str) -> dict[str, Any] | None:
    """The event on ``line`` if it is one (else None); EventError naming ``node`` if it is malformed.

    ``node`` is who the launcher expects the line from: an event naming another node is
    malformed too (a stray line must not pass for this job's result).
    """
    if not line.startswith(EVENT_PREFIX):
        return None
    doc = loads_bounded(line[len(EVENT_PREFIX):], f"{node}: result event", EventError,
                        max_bytes=MAX_EVENT_BYTES, max_depth=4)
    if not isinstance(doc, dict) or not isinstance(doc.get("event"), str):
        raise EventError(f"{node}: malformed result event: expected an object with an 'event' name")
    if doc.get("node") != node:
        raise EventError(f"{node}: malformed result event: it names node {doc.get('node')!r}")
    return doc
