"""The line protocol of a served node process, shared by the server and its launcher.

Kept apart from :mod:`.serve` so a launcher can speak it without importing
rclpy (docs/design.md §Layers: the graph layer starts processes, it does not
join the graph).
"""

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
