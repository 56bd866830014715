"""Start the recorder node: ``python launch_scripts/recorder.py --ros-args -p bag_path:=bags/x``.

Thin entry point (docs/design.md §Conventions) over :func:`msd_bench.nodes.spin.main`:
``with rclpy.init(args=args):``, spin until shutdown or until the recorder
reaches its limit, catch ``KeyboardInterrupt`` and ``ExternalShutdownException``.
rclpy's own SIGINT/SIGTERM handlers shut the context down; the node is then
closed, which completes the bag (summary and ``metadata.yaml``).
"""

from __future__ import annotations

# ruff: noqa: E402  (the stop handlers must be in place before the slow imports)
import os
import signal

for _sig in (signal.SIGINT, signal.SIGTERM):  # stopped while importing: nothing to clean up yet
    signal.signal(_sig, lambda *_: os._exit(0))
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # launch.start blocked them


if __package__ in (None, ""):  # `python launch_scripts/recorder.py` from the repo root
    import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.recorder_node import RecorderNode
from msd_bench.nodes.spin import run


def main() -> None:
    """Run one recorder until its bag is complete."""
    run(RecorderNode)


if __name__ == "__main__":
    main()
