"""Start the recorder node: ``python launch_scripts/recorder.py --ros-args -p bag_path:=bags/x``.

Thin entry point (STYLE.md §9) over :func:`msd_bench.nodes.spin.main`:
``with rclpy.init(args=args):``, spin until shutdown or until the recorder
reaches its limit, catch ``KeyboardInterrupt`` and ``ExternalShutdownException``.
rclpy's own SIGINT/SIGTERM handlers shut the context down; the node is then
closed, which completes the bag (summary and ``metadata.yaml``).
"""

from __future__ import annotations

if __package__ in (None, ""):  # `python launch_scripts/recorder.py` from the repo root
    import _reexec  # noqa: F401  (first: the repo on sys.path; re-exec into the project's venv if needed)

from msd_bench.nodes.recorder_node import RecorderNode
from msd_bench.nodes.spin import run


def main() -> None:
    """Run one recorder until its bag is complete."""
    run(RecorderNode)


if __name__ == "__main__":
    main()
